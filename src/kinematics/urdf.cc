// URDF → kinematics::Model, through urdfdom. urdfdom reports parse errors only through console_bridge, so a
// temporary output handler captures them for our InputError messages.
#include <console_bridge/console.h>
#include <fmt/format.h>
#include <fmt/ranges.h>
#include <urdf_parser/urdf_parser.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <mutex>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/kinematics/urdf_geometry.h"

namespace rmpmarl::kinematics {
namespace {

// collects console_bridge messages emitted while urdfdom parses.
class CapturingHandler : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level >= console_bridge::CONSOLE_BRIDGE_LOG_WARN) messages += (messages.empty() ? "" : "; ") + text;
  }
  std::string messages;
};

std::mutex& ConsoleBridgeMutex() {
  static std::mutex mutex;
  return mutex;
}

Eigen::Isometry3d ToIsometry(const urdf::Pose& pose) {
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(pose.position.x, pose.position.y, pose.position.z);
  Eigen::Quaterniond quat(pose.rotation.w, pose.rotation.x, pose.rotation.y, pose.rotation.z);
  X.linear() = quat.normalized().toRotationMatrix();
  return X;
}

bool Finite(double v) { return std::isfinite(v); }

// true when the text is a xacro macro file (it uses a xacro element) rather than plain URDF; URDFs expanded by xacro
// keep the xmlns:xacro declaration, so the namespace alone does not count.
bool LooksLikeXacro(const std::string& xml) { return xml.find("<xacro:") != std::string::npos; }

// parses URDF text with urdfdom, its console_bridge messages captured into the InputError.
urdf::ModelInterfaceSharedPtr ParseWithUrdfdom(const std::string& urdf_xml, const std::string& source) {
  if (LooksLikeXacro(urdf_xml)) {
    throw InputError(fmt::format("{}: this is a xacro file, not plain URDF: expand it with ROS's xacro first "
                                 "(`xacro {} > robot.urdf`, from ros-<distro>-xacro or `pip install xacro`) and pass "
                                 "the .urdf", source, source));
  }
  urdf::ModelInterfaceSharedPtr urdf_model;
  std::string messages;
  {
    std::lock_guard<std::mutex> lock(ConsoleBridgeMutex());
    CapturingHandler handler;
    console_bridge::useOutputHandler(&handler);
    try {
      urdf_model = urdf::parseURDF(urdf_xml);
    } catch (const std::exception& e) {
      handler.messages += std::string("; ") + e.what();
    }
    console_bridge::restorePreviousOutputHandler();
    messages = handler.messages;
  }
  if (!urdf_model) {
    throw InputError(fmt::format("{}: not a valid URDF: {}", source, messages.empty() ? "parse failed" : messages));
  }
  return urdf_model;
}

// a mimic joint as read: its link, the joint it follows, value = multiplier · leader + offset.
struct PendingMimic {
  int link;
  std::string leader;
  double multiplier, offset;
};

// points every mimic joint at the independent dof at the end of its chain of leaders (a mimic of a mimic composes:
// m1 (m2 q + o2) + o1); refuses unknown, fixed and cyclic leaders.
void ResolveMimicJoints(const std::vector<PendingMimic>& mimics, const std::string& source, std::vector<Link>* links) {
  auto find_joint = [&](const std::string& name) {
    for (size_t k = 1; k < links->size(); ++k) {
      if ((*links)[k].joint_name == name) return static_cast<int>(k);
    }
    return -1;
  };
  auto pending_of = [&](int link) -> const PendingMimic* {
    for (const PendingMimic& p : mimics) {
      if (p.link == link) return &p;
    }
    return nullptr;
  };
  for (const PendingMimic& mimic : mimics) {
    Link& follower = (*links)[mimic.link];
    if (!std::isfinite(mimic.multiplier) || !std::isfinite(mimic.offset)) {
      throw InputError(fmt::format("{}: joint '{}': <mimic multiplier offset> must be finite numbers, got {} {}",
                                   source, follower.joint_name, mimic.multiplier, mimic.offset));
    }
    double multiplier = mimic.multiplier, offset = mimic.offset;
    std::string leader = mimic.leader;
    std::vector<std::string> chain{follower.joint_name};
    for (;;) {
      const int k = find_joint(leader);
      if (k < 0) {
        throw InputError(fmt::format("{}: joint '{}': <mimic joint=\"{}\">: no joint of that name", source,
                                     follower.joint_name, leader));
      }
      if (std::find(chain.begin(), chain.end(), leader) != chain.end()) {
        throw InputError(fmt::format("{}: joint '{}': <mimic> joints follow each other in a cycle ({} -> {})",
                                     source, follower.joint_name, fmt::join(chain, " -> "), leader));
      }
      const Link& lead = (*links)[k];
      if (lead.joint_type == JointType::kFixed) {
        throw InputError(fmt::format("{}: joint '{}': <mimic joint=\"{}\">: that joint is fixed (expected a moving "
                                     "joint)", source, follower.joint_name, leader));
      }
      if (lead.q_index >= 0) {
        follower.mimic_dof = lead.q_index;
        break;
      }
      const PendingMimic* next = pending_of(k);
      RMPMARL_ASSERT(next != nullptr, "a moving joint without a dof must be a pending mimic joint");
      chain.push_back(leader);
      offset += multiplier * next->offset;  // m1 (m2 q + o2) + o1
      multiplier *= next->multiplier;
      leader = next->leader;
    }
    follower.mimic_multiplier = multiplier;
    follower.mimic_offset = offset;
  }
}

}  // namespace

Model ParseUrdfModel(const std::string& urdf_xml, const std::string& source) {
  const urdf::ModelInterfaceSharedPtr urdf_model = ParseWithUrdfdom(urdf_xml, source);
  const urdf::LinkConstSharedPtr root = urdf_model->getRoot();
  if (!root) throw InputError(fmt::format("{}: URDF has no root link", source));

  // Depth-first pre-order, children ordered by joint name: parents come before children (topological order), a
  // serial chain gets its dofs numbered from the base outwards and each branch's dofs are contiguous.
  std::vector<Link> links;
  std::vector<DofLimits> limits;
  Link root_link;
  root_link.name = root->name;
  links.push_back(root_link);
  // pushes the child joints of `link` (at index `index`) so that the first by name is popped first.
  struct Pending {
    urdf::JointSharedPtr joint;
    int parent;
  };
  std::vector<Pending> stack;
  std::vector<PendingMimic> mimics;
  auto push_children = [&stack](const urdf::LinkConstSharedPtr& link, int index) {
    std::vector<urdf::JointSharedPtr> child_joints = link->child_joints;
    std::sort(child_joints.begin(), child_joints.end(),
              [](const auto& a, const auto& b) { return a->name > b->name; });
    for (const urdf::JointSharedPtr& joint : child_joints) stack.push_back({joint, index});
  };
  push_children(root, 0);
  while (!stack.empty()) {
    const Pending current = stack.back();
    stack.pop_back();
    const urdf::JointSharedPtr& joint = current.joint;
    Link link;
    link.name = joint->child_link_name;
    link.parent = current.parent;
    link.joint_name = joint->name;
    link.X_PJ = ToIsometry(joint->parent_to_joint_origin_transform);
    const Eigen::Vector3d axis(joint->axis.x, joint->axis.y, joint->axis.z);
    if (!link.X_PJ.translation().allFinite() || !link.X_PJ.linear().allFinite() || !axis.allFinite()) {
      throw InputError(fmt::format("{}: joint '{}': <origin>/<axis> must be finite numbers", source, joint->name));
    }
    switch (joint->type) {
      case urdf::Joint::REVOLUTE: link.joint_type = JointType::kRevolute; break;
      case urdf::Joint::CONTINUOUS: link.joint_type = JointType::kContinuous; break;
      case urdf::Joint::PRISMATIC: link.joint_type = JointType::kPrismatic; break;
      case urdf::Joint::FIXED: link.joint_type = JointType::kFixed; break;
      default:
        throw InputError(fmt::format("{}: joint '{}': type not supported (expected revolute, continuous, "
                                     "prismatic or fixed)", source, joint->name));
    }
    // a <mimic> on a fixed joint has no value to set (a gripper frozen open, as MotionBenchMaker's Panda has it):
    // the joint stays fixed, as in ROS and MoveIt
    if (joint->mimic && link.joint_type != JointType::kFixed) {
      if (axis.norm() < 1e-12) {
        throw InputError(fmt::format("{}: joint '{}': <axis xyz> must be non-zero, got [{} {} {}]", source,
                                     joint->name, axis.x(), axis.y(), axis.z()));
      }
      link.axis_J = axis.normalized();
      mimics.push_back({static_cast<int>(links.size()), joint->mimic->joint_name, joint->mimic->multiplier,
                        joint->mimic->offset});
    } else if (link.joint_type != JointType::kFixed) {
      if (axis.norm() < 1e-12) {
        throw InputError(fmt::format("{}: joint '{}': <axis xyz> must be non-zero, got [{} {} {}]", source,
                                     joint->name, axis.x(), axis.y(), axis.z()));
      }
      link.axis_J = axis.normalized();
      link.q_index = static_cast<int>(limits.size());
      DofLimits dof;
      if (link.joint_type == JointType::kContinuous) {
        dof.lower = -std::numeric_limits<double>::infinity();
        dof.upper = std::numeric_limits<double>::infinity();
      }
      if (joint->limits) {
        if (link.joint_type != JointType::kContinuous) {
          dof.lower = joint->limits->lower;
          dof.upper = joint->limits->upper;
        }
        dof.velocity = joint->limits->velocity;
        dof.effort = joint->limits->effort;
      }
      if (!joint->limits || !(dof.velocity > 0.0) || !Finite(dof.velocity)) {
        throw InputError(fmt::format("{}: joint '{}': <limit velocity> must be a positive number, got {}", source,
                                     joint->name, joint->limits ? joint->limits->velocity : 0.0));
      }
      if (link.joint_type != JointType::kContinuous &&
          (!Finite(dof.lower) || !Finite(dof.upper) || !(dof.lower < dof.upper))) {
        throw InputError(fmt::format("{}: joint '{}': <limit> expected finite lower < upper, got lower={} "
                                     "upper={}", source, joint->name, dof.lower, dof.upper));
      }
      limits.push_back(dof);
    }
    links.push_back(link);
    const urdf::LinkConstSharedPtr child = urdf_model->getLink(joint->child_link_name);
    if (!child) throw InputError(fmt::format("{}: joint '{}': unknown child link", source, joint->name));
    push_children(child, static_cast<int>(links.size()) - 1);
  }
  if (static_cast<int>(links.size()) != static_cast<int>(urdf_model->links_.size())) {
    throw InputError(fmt::format("{}: expected all {} links to form one tree under root '{}', reached {}", source,
                                 urdf_model->links_.size(), root->name, links.size()));
  }
  ResolveMimicJoints(mimics, source, &links);
  return Model(urdf_model->getName(), std::move(links), std::move(limits));
}

std::string_view ShapeKindName(ShapeKind kind) {
  switch (kind) {
    case ShapeKind::kSphere: return "sphere";
    case ShapeKind::kBox: return "box";
    case ShapeKind::kCylinder: return "cylinder";
    case ShapeKind::kMesh: return "mesh";
  }
  return "unknown";
}

std::vector<LinkShape> ParseUrdfShapes(const std::string& urdf_xml, const Model& model, const std::string& source,
                                       UrdfShapeSource which) {
  const urdf::ModelInterfaceSharedPtr urdf_model = ParseWithUrdfdom(urdf_xml, source);
  std::vector<LinkShape> shapes;
  for (int k = 0; k < model.num_links(); ++k) {
    const urdf::LinkConstSharedPtr link = urdf_model->getLink(model.link(k).name);
    if (!link) continue;
    const bool visual = which == UrdfShapeSource::kCollisionFirst ? link->collision_array.empty()
                                                                  : !link->visual_array.empty();
    std::vector<std::pair<urdf::Pose, urdf::GeometrySharedPtr>> elements;
    if (!visual) {
      for (const auto& c : link->collision_array) elements.emplace_back(c->origin, c->geometry);
    } else {
      for (const auto& v : link->visual_array) elements.emplace_back(v->origin, v->geometry);
    }
    for (const auto& [origin, geometry] : elements) {
      if (!geometry) continue;
      LinkShape shape;
      shape.link = k;
      shape.visual = visual;
      shape.X_LG = ToIsometry(origin);
      const std::string what = fmt::format("{}: link '{}' <{}>", source, link->name, visual ? "visual" : "collision");
      if (!shape.X_LG.matrix().allFinite()) throw InputError(what + ": <origin> must be finite numbers");
      auto positive = [&what](double v, const char* key) {
        if (!(Finite(v) && v > 0.0)) throw InputError(fmt::format("{}: {} must be a positive number, got {}", what, key, v));
        return v;
      };
      switch (geometry->type) {
        case urdf::Geometry::SPHERE:
          shape.kind = ShapeKind::kSphere;
          shape.radius = positive(static_cast<const urdf::Sphere&>(*geometry).radius, "sphere radius");
          break;
        case urdf::Geometry::BOX: {
          const auto& box = static_cast<const urdf::Box&>(*geometry);
          shape.kind = ShapeKind::kBox;
          shape.size = Eigen::Vector3d(positive(box.dim.x, "box size x"), positive(box.dim.y, "box size y"),
                                       positive(box.dim.z, "box size z"));
          break;
        }
        case urdf::Geometry::CYLINDER: {
          const auto& cylinder = static_cast<const urdf::Cylinder&>(*geometry);
          shape.kind = ShapeKind::kCylinder;
          shape.radius = positive(cylinder.radius, "cylinder radius");
          shape.length = positive(cylinder.length, "cylinder length");
          break;
        }
        case urdf::Geometry::MESH: {
          const auto& mesh = static_cast<const urdf::Mesh&>(*geometry);
          shape.kind = ShapeKind::kMesh;
          shape.mesh_uri = mesh.filename;
          shape.mesh_scale = Eigen::Vector3d(mesh.scale.x, mesh.scale.y, mesh.scale.z);
          if (!shape.mesh_scale.allFinite() || shape.mesh_scale.cwiseAbs().minCoeff() == 0.0) {
            throw InputError(what + ": <mesh scale> must be finite and non-zero");
          }
          break;
        }
      }
      shapes.push_back(shape);
    }
  }
  return shapes;
}

Model LoadUrdfModel(const std::filesystem::path& urdf_path) {
  std::ifstream file(urdf_path);
  if (!file) throw InputError(fmt::format("{}: cannot open URDF file (missing or unreadable)", urdf_path.string()));
  std::stringstream buffer;
  buffer << file.rdbuf();
  return ParseUrdfModel(buffer.str(), urdf_path.string());
}

}  // namespace rmpmarl::kinematics
