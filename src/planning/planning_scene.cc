// MoveIt planning scenes and motion-plan requests (YAML) as obstacles, start states and joint goals.
#include "rmpmarl/planning/planning_scene.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <sstream>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::planning {
namespace {

using internal::YamlReader;

// node kinds that are false for an absent key (yaml-cpp throws when asked the type of a missing node)
bool IsSeq(const YAML::Node& n) { return n.IsDefined() && n.IsSequence(); }
bool IsMap(const YAML::Node& n) { return n.IsDefined() && n.IsMap(); }
bool Absent(const YAML::Node& n) { return !n.IsDefined() || n.IsNull(); }
bool IsScalar(const YAML::Node& n) { return n.IsDefined() && n.IsScalar(); }

std::string ReadText(const std::filesystem::path& path, std::string_view what) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("{}: cannot open '{}'", what, path.string()));
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// a vector of `n` numbers: a list, or a mapping with the keys `names` (a ROS message written as YAML)
Eigen::VectorXd Numbers(const YamlReader& r, const YAML::Node& node, const std::string& key,
                        std::initializer_list<const char*> names) {
  const int n = static_cast<int>(names.size());
  Eigen::VectorXd v(n);
  if (IsSeq(node)) {
    if (static_cast<int>(node.size()) != n) {
      r.Fail(node, key, fmt::format("expected {} numbers, got {}", n, node.size()));
    }
    for (int i = 0; i < n; ++i) v[i] = r.Number(node[i], fmt::format("{}[{}]", key, i));
    return v;
  }
  if (!IsMap(node)) r.Fail(node, key, fmt::format("expected a list of {} numbers or a mapping", n));
  int i = 0;
  for (const char* name : names) {
    v[i++] = r.Number(node[name], key + "." + name);
  }
  return v;
}

// a unit quaternion [x, y, z, w] (or a mapping) as a rotation matrix
Eigen::Matrix3d Rotation(const YamlReader& r, const YAML::Node& node, const std::string& key) {
  const Eigen::VectorXd q = Numbers(r, node, key, {"x", "y", "z", "w"});
  if (!(std::abs(q.norm() - 1.0) <= 1e-3)) {
    r.Fail(node, key, fmt::format("expected a unit quaternion [x, y, z, w], got norm {:.6g}", q.norm()));
  }
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]).normalized().toRotationMatrix();
}

// a rigid transform written under two keys, an offset `at` and a unit quaternion `turn` [x, y, z, w] (a pose's position
// and orientation, a geometry_msgs/Transform's translation and rotation); absent: the identity
Eigen::Isometry3d Rigid(const YamlReader& r, const YAML::Node& node, const std::string& key, const char* what,
                        const char* at, const char* turn) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  if (Absent(node)) return X;
  if (!IsMap(node)) r.Fail(node, key, fmt::format("expected a {} {{{}, {}}}", what, at, turn));
  if (const YAML::Node p = node[at]) X.translation() = Numbers(r, p, fmt::format("{}.{}", key, at), {"x", "y", "z"});
  if (const YAML::Node o = node[turn]) X.linear() = Rotation(r, o, fmt::format("{}.{}", key, turn));
  return X;
}

// a pose {position, orientation}
Eigen::Isometry3d Pose(const YamlReader& r, const YAML::Node& node, const std::string& key) {
  return Rigid(r, node, key, "pose", "position", "orientation");
}

// a geometry_msgs/Transform {translation, rotation}
Eigen::Isometry3d Transform(const YamlReader& r, const YAML::Node& node, const std::string& key) {
  return Rigid(r, node, key, "transform", "translation", "rotation");
}

// The frames a scene's objects may be given in, each as its pose in the robot's base frame R. MoveIt's planning frame
// P is the parent of the robot's virtual joint, whose transform (robot_state.multi_dof_joint_state, one joint) is the
// base link's pose in P; fixed_frame_transforms give more frames (child_frame_id) by their pose in P.
struct Frames {
  std::vector<std::pair<std::string, Eigen::Isometry3d>> X_RF;  // name → pose in R
  const Eigen::Isometry3d* Find(const std::string& name) const {
    for (const auto& [n, X] : X_RF) {
      if (n == name) return &X;
    }
    return nullptr;
  }
  std::string Names() const {
    std::vector<std::string> names;
    for (const auto& [n, X] : X_RF) names.push_back(n.empty() ? "'' (the planning frame)" : "'" + n + "'");
    return fmt::format("{}", fmt::join(names, ", "));
  }
};

Frames ReadFrames(const YamlReader& r, const YAML::Node& root, std::string_view base_link) {
  Eigen::Isometry3d X_PR = Eigen::Isometry3d::Identity();
  const YAML::Node state = root["robot_state"];
  const YAML::Node multi = IsMap(state) ? state["multi_dof_joint_state"] : YAML::Node();
  if (IsMap(multi) && IsSeq(multi["transforms"]) && multi["transforms"].size() > 0) {
    if (multi["transforms"].size() != 1) {
      r.Fail(multi["transforms"], "robot_state.multi_dof_joint_state.transforms",
             fmt::format("expected the virtual joint's one transform, got {}", multi["transforms"].size()));
    }
    X_PR = Transform(r, multi["transforms"][0], "robot_state.multi_dof_joint_state.transforms[0]");
  }
  const Eigen::Isometry3d X_RP = X_PR.inverse();
  Frames frames;
  frames.X_RF.emplace_back("", X_RP);
  if (!base_link.empty()) frames.X_RF.emplace_back(std::string(base_link), Eigen::Isometry3d::Identity());
  const YAML::Node fixed = root["fixed_frame_transforms"];
  if (IsSeq(fixed)) {
    for (size_t i = 0; i < fixed.size(); ++i) {
      const std::string key = fmt::format("fixed_frame_transforms[{}]", i);
      const YAML::Node t = fixed[i];
      if (!IsMap(t)) r.Fail(t, key, "expected a transform {header, child_frame_id, transform}");
      // the planning frame's own name, where the file gives it
      const YAML::Node header = t["header"];
      if (IsMap(header) && IsScalar(header["frame_id"]) && !header["frame_id"].Scalar().empty() &&
          frames.Find(header["frame_id"].Scalar()) == nullptr) {
        frames.X_RF.emplace_back(header["frame_id"].Scalar(), X_RP);
      }
      const std::string child = r.String(t["child_frame_id"], key + ".child_frame_id");
      const Eigen::Isometry3d X_RC = X_RP * Transform(r, t["transform"], key + ".transform");
      if (const Eigen::Isometry3d* known = frames.Find(child)) {
        if (!known->isApprox(X_RC, 1e-9)) {
          r.Fail(t, key, fmt::format("frame '{}' given twice, at different poses", child));
        }
        continue;
      }
      frames.X_RF.emplace_back(child, X_RC);
    }
  }
  return frames;
}

double Positive(const YamlReader& r, const YAML::Node& node, const std::string& key) {
  const double v = r.Number(node, key);
  if (!(v > 0.0)) r.Fail(node, key, fmt::format("expected a size > 0 m, got {}", v));
  return v;
}

rmp::Obstacle Primitive(const YamlReader& r, const YAML::Node& node, const std::string& key,
                        const Eigen::Isometry3d& X_WP) {
  if (!IsMap(node)) r.Fail(node, key, "expected a primitive {type, dimensions}");
  const std::string type = r.String(node["type"], key + ".type");
  const YAML::Node dims = node["dimensions"];
  const std::string dkey = key + ".dimensions";
  if (!IsSeq(dims)) r.Fail(dims, dkey, "expected a list of numbers");
  auto need = [&](size_t n, const char* what) {
    if (dims.size() != n) r.Fail(dims, dkey, fmt::format("a {} takes {}, got {} numbers", type, what, dims.size()));
  };
  if (type == "box" || type == "1" || type == "BOX") {
    need(3, "[x, y, z] (side lengths)");
    const Eigen::Vector3d half(0.5 * Positive(r, dims[0], dkey + "[0]"), 0.5 * Positive(r, dims[1], dkey + "[1]"),
                               0.5 * Positive(r, dims[2], dkey + "[2]"));
    return rmp::Obstacle::MakeBox(X_WP, half);
  }
  if (type == "sphere" || type == "2" || type == "SPHERE") {
    need(1, "[radius]");
    return rmp::Obstacle::MakeSphere(X_WP.translation(), Positive(r, dims[0], dkey + "[0]"));
  }
  if (type == "cylinder" || type == "3" || type == "CYLINDER") {
    need(2, "[height, radius]");
    const double height = Positive(r, dims[0], dkey + "[0]");
    return rmp::Obstacle::MakeCylinder(X_WP, Positive(r, dims[1], dkey + "[1]"), 0.5 * height);
  }
  if (type == "cone" || type == "4" || type == "CONE") {
    r.Fail(node["type"], key + ".type", "cone primitives are not supported (give a cylinder around it)");
  }
  r.Fail(node["type"], key + ".type", fmt::format("expected box, sphere or cylinder, got '{}'", type));
}

SceneObject Object(const YamlReader& r, const YAML::Node& node, const std::string& key, const Frames& frames) {
  if (!IsMap(node)) r.Fail(node, key, "expected a collision object");
  SceneObject object;
  object.id = node["id"] ? r.String(node["id"], key + ".id") : "";
  const std::string name = object.id.empty() ? key : fmt::format("{} ('{}')", key, object.id);
  if (const YAML::Node op = node["operation"]) {
    const std::string o = IsScalar(op) ? op.Scalar() : "";
    if (o != "0" && o != "ADD" && o != "add") {
      r.Fail(op, name + ".operation", fmt::format("only ADD (0) objects are read, got '{}'", o));
    }
  }
  for (const char* shapes : {"meshes", "planes"}) {
    const YAML::Node s = node[shapes];
    if (s && IsSeq(s) && s.size() > 0) {
      r.Fail(s, fmt::format("{}.{}", name, shapes),
             fmt::format("{} are not read (give the object's primitives, or its surface as a point cloud)", shapes));
    }
  }
  // the frame its poses are in: its header's, else the planning frame
  const Eigen::Isometry3d* X_RF = frames.Find("");
  const YAML::Node header = node["header"];
  if (IsMap(header) && !Absent(header["frame_id"])) {
    const std::string frame = r.String(header["frame_id"], name + ".header.frame_id");
    X_RF = frames.Find(frame);
    if (X_RF == nullptr) {
      r.Fail(header["frame_id"], name + ".header.frame_id",
             fmt::format("unknown frame '{}': the scene's frames are {} (an object attached to a robot link is not "
                         "read)", frame, frames.Names()));
    }
  }
  const Eigen::Isometry3d X_WO = *X_RF * Pose(r, node["pose"], name + ".pose");
  const YAML::Node prims = node["primitives"];
  const YAML::Node poses = node["primitive_poses"];
  if (Absent(prims)) return object;
  if (!IsSeq(prims)) r.Fail(prims, name + ".primitives", "expected a list");
  if (!IsSeq(poses) || poses.size() != prims.size()) {
    r.Fail(poses, name + ".primitive_poses",
           fmt::format("expected one pose per primitive ({}), got {}", prims.size(),
                       IsSeq(poses) ? fmt::format("{}", poses.size()) : std::string("none")));
  }
  for (size_t i = 0; i < prims.size(); ++i) {
    const Eigen::Isometry3d X_WP = X_WO * Pose(r, poses[i], fmt::format("{}.primitive_poses[{}]", name, i));
    object.primitives.push_back(Primitive(r, prims[i], fmt::format("{}.primitives[{}]", name, i), X_WP));
  }
  return object;
}

NamedJoints Joints(const YamlReader& r, const YAML::Node& state, const std::string& key) {
  const YAML::Node js = state["joint_state"];
  if (!IsMap(js)) r.Fail(js, key + ".joint_state", "expected a joint state {name, position}");
  const YAML::Node names = js["name"], positions = js["position"];
  if (!IsSeq(names)) r.Fail(names, key + ".joint_state.name", "expected a list of joint names");
  if (!IsSeq(positions) || positions.size() != names.size()) {
    r.Fail(positions, key + ".joint_state.position",
           fmt::format("expected one position per name ({})", names.size()));
  }
  NamedJoints joints;
  joints.positions.resize(static_cast<Eigen::Index>(names.size()));
  for (size_t i = 0; i < names.size(); ++i) {
    joints.names.push_back(r.String(names[i], fmt::format("{}.joint_state.name[{}]", key, i)));
    joints.positions[static_cast<Eigen::Index>(i)] =
        r.Number(positions[i], fmt::format("{}.joint_state.position[{}]", key, i));
  }
  return joints;
}

JointGoal Goal(const YamlReader& r, const YAML::Node& constraints, const std::string& key) {
  if (!IsSeq(constraints) || constraints.size() == 0) {
    r.Fail(constraints, key, "expected a non-empty list of goal constraints");
  }
  const YAML::Node c = constraints[0];
  if (!IsMap(c)) r.Fail(c, key + "[0]", "expected a constraints mapping (joint_constraints, ...)");
  const YAML::Node jc = c["joint_constraints"];
  if (!IsSeq(jc) || jc.size() == 0) {
    const bool pose = (c["position_constraints"] && c["position_constraints"].size() > 0) ||
                      (c["orientation_constraints"] && c["orientation_constraints"].size() > 0);
    r.Fail(c, key + "[0].joint_constraints",
           pose ? "only joint-space goals are read; this goal has position/orientation constraints only"
                : "expected a non-empty list of joint constraints");
  }
  JointGoal goal;
  const auto n = static_cast<Eigen::Index>(jc.size());
  goal.joints.positions.resize(n);
  goal.tolerance_below.resize(n);
  goal.tolerance_above.resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    const YAML::Node j = jc[static_cast<size_t>(i)];
    const std::string k = fmt::format("{}[0].joint_constraints[{}]", key, i);
    if (!IsMap(j)) r.Fail(j, k, "expected a joint constraint {joint_name, position}");
    goal.joints.names.push_back(r.String(j["joint_name"], k + ".joint_name"));
    goal.joints.positions[i] = r.Number(j["position"], k + ".position");
    // MoveIt's default tolerance when a request leaves it out (kinematic_constraints: 1e-3 rad or m)
    auto tolerance = [&](const char* field) {
      if (!j[field]) return 1e-3;
      const double t = r.Number(j[field], k + "." + field);
      if (!(t >= 0.0)) r.Fail(j[field], k + "." + field, fmt::format("expected a tolerance >= 0, got {}", t));
      return t;
    };
    goal.tolerance_below[i] = tolerance("tolerance_below");
    goal.tolerance_above[i] = tolerance("tolerance_above");
  }
  return goal;
}

}  // namespace

std::vector<rmp::Obstacle> PlanningScene::Obstacles() const {
  std::vector<rmp::Obstacle> all;
  for (const SceneObject& o : objects) all.insert(all.end(), o.primitives.begin(), o.primitives.end());
  return all;
}

PlanningScene ParsePlanningScene(const std::string& yaml, std::string_view source, std::string_view base_link) {
  const YamlReader r{std::string(source)};
  const YAML::Node root = internal::LoadYamlText(yaml, std::string(source));
  if (!IsMap(root)) r.Fail(root, "<root>", "expected a planning scene (a mapping with `world`)");
  PlanningScene scene;
  if (root["name"] && IsScalar(root["name"])) scene.name = root["name"].Scalar();
  const YAML::Node world = root["world"];
  if (!IsMap(world)) r.Fail(world, "world", "expected a mapping with collision_objects");
  const Frames frames = ReadFrames(r, root, base_link);
  const YAML::Node objects = world["collision_objects"];
  if (!Absent(objects)) {
    if (!IsSeq(objects)) r.Fail(objects, "world.collision_objects", "expected a list");
    for (size_t i = 0; i < objects.size(); ++i) {
      scene.objects.push_back(Object(r, objects[i], fmt::format("world.collision_objects[{}]", i), frames));
    }
  }
  const YAML::Node octomap = world["octomap"];
  if (IsMap(octomap) && IsMap(octomap["octomap"]) && IsSeq(octomap["octomap"]["data"]) &&
      octomap["octomap"]["data"].size() > 0) {
    scene.ignored.push_back("world.octomap");
  }
  const YAML::Node attached =
      IsMap(root["robot_state"]) ? root["robot_state"]["attached_collision_objects"] : YAML::Node();
  if (attached && IsSeq(attached) && attached.size() > 0) {
    scene.ignored.push_back("robot_state.attached_collision_objects");
  }
  return scene;
}

PlanningScene ReadPlanningScene(const std::filesystem::path& path, std::string_view base_link) {
  return ParsePlanningScene(ReadText(path, "planning scene"), path.string(), base_link);
}

MotionPlanRequest ParseMotionPlanRequest(const std::string& yaml, std::string_view source) {
  const YamlReader r{std::string(source)};
  const YAML::Node root = internal::LoadYamlText(yaml, std::string(source));
  if (!IsMap(root)) r.Fail(root, "<root>", "expected a motion-plan request (start_state, goal_constraints)");
  MotionPlanRequest request;
  if (root["group_name"] && IsScalar(root["group_name"])) request.group = root["group_name"].Scalar();
  const YAML::Node start = root["start_state"];
  if (!IsMap(start)) r.Fail(start, "start_state", "expected a robot state with a joint_state");
  request.start = Joints(r, start, "start_state");
  request.goal = Goal(r, root["goal_constraints"], "goal_constraints");
  return request;
}

MotionPlanRequest ReadMotionPlanRequest(const std::filesystem::path& path) {
  return ParseMotionPlanRequest(ReadText(path, "motion-plan request"), path.string());
}

Eigen::VectorXd JointVector(const kinematics::Robot& robot, const NamedJoints& joints, std::string_view what) {
  const kinematics::Model& m = robot.model;
  Eigen::VectorXd q(m.nq());
  std::vector<std::string> missing;
  for (int i = 0; i < m.nq(); ++i) {
    const auto it = std::find(joints.names.begin(), joints.names.end(), m.dof_name(i));
    if (it == joints.names.end()) {
      missing.push_back(m.dof_name(i));
      continue;
    }
    q[i] = joints.positions[it - joints.names.begin()];
  }
  if (!missing.empty()) {
    throw InputError(fmt::format("{}: expected a value for every joint of robot '{}', missing {} (given: {})", what,
                                 robot.name, fmt::join(missing, ", "), fmt::join(joints.names, ", ")));
  }
  return q;
}

Eigen::VectorXd JointGoalTolerance(const kinematics::Robot& robot, const JointGoal& goal, std::string_view what) {
  NamedJoints below{goal.joints.names, goal.tolerance_below};
  NamedJoints above{goal.joints.names, goal.tolerance_above};
  return JointVector(robot, below, what).cwiseMin(JointVector(robot, above, what));
}

}  // namespace rmpmarl::planning
