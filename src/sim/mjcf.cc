// MJCF generation for a robot + scene and in-memory compilation (MuJoCo 2.2.2 VFS); conventions in docs/sim.md.
#include "rmpmarl/sim/mjcf.h"

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "rmpmarl/common/error.h"

namespace rmpmarl::sim {
namespace {

using kinematics::JointType;
using kinematics::Robot;

// collision bitmasks: robot geoms collide with robot and scene geoms; scene geoms (obstacles, floor) only with the
// robot, so obstacle–obstacle and obstacle–floor pairs are never generated; the target collides with nothing.
constexpr int kRobotContype = 1;
constexpr int kRobotConaffinity = 1;
constexpr int kSceneContype = 2;
constexpr int kSceneConaffinity = 1;
// a robot with a separate self-collision set (Robot::self_capsules): its capsules touch the scene only (conaffinity
// 0), the self-collision capsules each other only (the value 4, bit 2: in neither the scene's contype nor its
// conaffinity)
constexpr int kSelfContype = 4;
constexpr int kSelfConaffinity = 4;

// a capsule shorter than this is written as a sphere around it (MuJoCo rejects a fromto shorter than √mjEPS = 1e-7).
constexpr double kMinCapsuleLength = 1e-6;

std::string Num(double x) { return fmt::format("{:.17g}", x); }

std::string Vec(const Eigen::Vector3d& v) { return fmt::format("{:.17g} {:.17g} {:.17g}", v.x(), v.y(), v.z()); }

// MuJoCo quaternion (w x y z) of a rotation matrix.
std::string Quat(const Eigen::Matrix3d& R) {
  const Eigen::Quaterniond q(R);
  return fmt::format("{:.17g} {:.17g} {:.17g} {:.17g}", q.w(), q.x(), q.y(), q.z());
}

// escapes a name for an XML attribute value.
std::string Xml(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default: out += c;
    }
  }
  return out;
}

[[noreturn]] void Fail(const std::string& what, const std::string& expected, const std::string& got) {
  throw InputError(fmt::format("sim: {}: expected {}, got {}", what, expected, got));
}

void CheckPositive(double x, const std::string& what) {
  if (!(std::isfinite(x) && x > 0.0)) Fail(what, "a finite value > 0", Num(x));
}

void CheckNonNegative(double x, const std::string& what) {
  if (!(std::isfinite(x) && x >= 0.0)) Fail(what, "a finite value >= 0", Num(x));
}

void CheckPose(const Eigen::Isometry3d& X, const std::string& what) {
  if (!X.matrix().allFinite()) Fail(what, "a finite pose", "non-finite entries");
  const Eigen::Matrix3d R = X.linear();
  const double err = (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-6 || R.determinant() < 0.0) {
    Fail(what, "a rotation (orthonormal, det +1)", fmt::format("|RᵀR − I|max = {:.3g}, det = {:.6g}", err,
                                                                 R.determinant()));
  }
}

// link weld groups as MuJoCo forms them: a link joined by a fixed joint moves with its parent; group 0 is the
// world (the root link is fixed to it).
std::vector<int> WeldGroups(const kinematics::Model& model) {
  std::vector<int> weld(model.num_links(), 0);
  for (int k = 1; k < model.num_links(); ++k) {
    weld[k] = model.link(k).joint_type == JointType::kFixed ? weld[model.link(k).parent] : k;
  }
  return weld;
}

// appends the <body> of link k (and, recursively, its children) at the given indentation.
void WriteBody(const Robot& robot, const WorldOptions& options, const ServoGains& gains,
               const std::vector<std::vector<int>>& children, const std::vector<std::vector<int>>& link_capsules,
               const std::vector<std::vector<int>>& link_self_capsules, int k, int depth, std::string* out) {
  const kinematics::Model& model = robot.model;
  const kinematics::Link& link = model.link(k);
  const std::string pad(2 * depth, ' ');
  if (k == 0) {
    *out += fmt::format("{}<body name=\"{}\" pos=\"0 0 0\">\n", pad, Xml(MjcfNames::LinkBody(robot, k)));
  } else {
    *out += fmt::format("{}<body name=\"{}\" pos=\"{}\" quat=\"{}\">\n", pad, Xml(MjcfNames::LinkBody(robot, k)),
                        Vec(link.X_PJ.translation()), Quat(link.X_PJ.linear()));
  }
  if (k != 0 && link.joint_type != JointType::kFixed) {
    // a mimic joint: no limits of its own (it follows its leader through an <equality><joint>), the leader's damping
    const int i = link.driving_dof();
    const kinematics::DofLimits& lim = model.limits()[i];
    const bool slide = link.joint_type == JointType::kPrismatic;
    const bool limited = link.joint_type != JointType::kContinuous && link.q_index >= 0;
    std::string range = limited ? fmt::format(" limited=\"true\" range=\"{} {}\"", Num(lim.lower), Num(lim.upper))
                                : std::string(" limited=\"false\"");
    *out += fmt::format("{}  <joint name=\"{}\" type=\"{}\" pos=\"0 0 0\" axis=\"{}\"{} damping=\"{}\" armature=\"{}\"/>\n",
                        pad, Xml(link.joint_name), slide ? "slide" : "hinge", Vec(link.axis_J), range,
                        Num(gains.damping[i]), Num(options.servo.armature));
  }
  if (link_capsules[k].empty()) {
    // no geometry: a small sphere-like inertia keeps the compiler and the mass matrix well defined.
    const double m = options.min_link_mass;
    const double I = 0.4 * m * 0.05 * 0.05;
    *out += fmt::format("{}  <inertial pos=\"0 0 0\" mass=\"{}\" diaginertia=\"{} {} {}\"/>\n", pad, Num(m), Num(I),
                        Num(I), Num(I));
  }
  const bool separate = !robot.self_capsules.empty();
  auto geom = [&](const kinematics::LinkCapsule& cap, const std::string& name, const std::string& attributes) {
    const double length = (cap.p_LB - cap.p_LA).norm();
    const bool sphere = length < kMinCapsuleLength;
    const std::string common = fmt::format("size=\"{}\" {}", Num(sphere ? cap.radius + 0.5 * length : cap.radius),
                                           attributes);
    if (sphere) {
      *out += fmt::format("{}  <geom name=\"{}\" type=\"sphere\" pos=\"{}\" {}/>\n", pad, Xml(name),
                          Vec(0.5 * (cap.p_LA + cap.p_LB)), common);
    } else {
      *out += fmt::format("{}  <geom name=\"{}\" type=\"capsule\" fromto=\"{} {}\" {}/>\n", pad, Xml(name),
                          Vec(cap.p_LA), Vec(cap.p_LB), common);
    }
  };
  for (int c : link_capsules[k]) {
    geom(robot.capsules[c], MjcfNames::CapsuleGeom(robot, c),
         fmt::format("density=\"{}\" contype=\"{}\" conaffinity=\"{}\" condim=\"1\" margin=\"{}\" gap=\"{}\" "
                     "group=\"1\" rgba=\"0.7 0.7 0.75 1\"",
                     Num(options.link_density), kRobotContype, separate ? 0 : kRobotConaffinity,
                     Num(options.warning_margin), Num(options.warning_margin)));
  }
  // the self-collision capsules: massless and unseen, for contacts between links only
  for (int c : link_self_capsules[k]) {
    geom(robot.self_capsules[c], MjcfNames::SelfCapsuleGeom(robot, c),
         fmt::format("density=\"0\" contype=\"{}\" conaffinity=\"{}\" condim=\"1\" margin=\"{}\" gap=\"{}\" "
                     "group=\"3\" rgba=\"0.5 0.5 0.9 0\"",
                     kSelfContype, kSelfConaffinity, Num(options.warning_margin), Num(options.warning_margin)));
  }
  for (int child : children[k]) {
    WriteBody(robot, options, gains, children, link_capsules, link_self_capsules, child, depth + 1, out);
  }
  *out += fmt::format("{}</body>\n", pad);
}

}  // namespace

ObstacleSpec ObstacleSpec::Box(const Eigen::Vector3d& half_size, const Eigen::Isometry3d& X_WO) {
  ObstacleSpec spec;
  spec.shape = ObstacleShape::kBox;
  spec.half_size = half_size;
  spec.X_WO = X_WO;
  return spec;
}

ObstacleSpec ObstacleSpec::Cube(double side, const Eigen::Isometry3d& X_WO) {
  return Box(Eigen::Vector3d::Constant(0.5 * side), X_WO);
}

ObstacleSpec ObstacleSpec::Sphere(double radius, const Eigen::Vector3d& p_WO) {
  ObstacleSpec spec;
  spec.shape = ObstacleShape::kSphere;
  spec.radius = radius;
  spec.X_WO = Eigen::Isometry3d(Eigen::Translation3d(p_WO));
  return spec;
}

ObstacleSpec ObstacleSpec::Cylinder(double radius, double half_length, const Eigen::Isometry3d& X_WO) {
  ObstacleSpec spec;
  spec.shape = ObstacleShape::kCylinder;
  spec.radius = radius;
  spec.half_length = half_length;
  spec.X_WO = X_WO;
  return spec;
}

ObstacleSpec ObstacleSpec::Of(const rmp::Obstacle& obstacle) {
  switch (obstacle.shape) {
    case rmp::ObstacleShape::kSphere: return Sphere(obstacle.sphere.radius, obstacle.sphere.p_WC);
    case rmp::ObstacleShape::kBox: return Box(obstacle.box.half_size, obstacle.box.X_WB);
    case rmp::ObstacleShape::kCylinder:
      return Cylinder(obstacle.cylinder.radius, obstacle.cylinder.half_length, obstacle.cylinder.X_WC);
    case rmp::ObstacleShape::kPoints: break;
  }
  throw InputError("ObstacleSpec::Of: a point-set obstacle has no MuJoCo shape (give spheres, boxes or cylinders)");
}

rmp::Obstacle ObstacleSpec::AsRmp(const Eigen::Isometry3d& X_WO, const Eigen::Vector3d& v_WO) const {
  switch (shape) {
    case ObstacleShape::kSphere: return rmp::Obstacle::MakeSphere(X_WO.translation(), radius, v_WO);
    case ObstacleShape::kCylinder: return rmp::Obstacle::MakeCylinder(X_WO, radius, half_length, v_WO);
    case ObstacleShape::kBox: break;
  }
  return rmp::Obstacle::MakeBox(X_WO, half_size, v_WO);
}

std::string MjcfNames::LinkBody(const Robot& robot, int link) {
  const std::string& name = robot.model.link(link).name;
  const bool reserved = name == "world" || name.starts_with("scene/") || name.starts_with("link/");
  return reserved ? "link/" + name : name;
}

std::string MjcfNames::CapsuleGeom(const Robot& robot, int capsule) {
  return fmt::format("{}/capsule{}", robot.model.link(robot.capsules[capsule].link).name, capsule);
}

std::string MjcfNames::SelfCapsuleGeom(const Robot& robot, int capsule) {
  return fmt::format("{}/self_capsule{}", robot.model.link(robot.self_capsules[capsule].link).name, capsule);
}

std::string MjcfNames::Actuator(const Robot& robot, int dof) {
  return fmt::format("{}/servo", robot.model.dof_name(dof));
}

std::string MjcfNames::ObstacleBody(int obstacle) { return fmt::format("scene/obstacle{}", obstacle); }

std::string MjcfNames::ObstacleGeom(int obstacle) { return fmt::format("scene/obstacle{}/geom", obstacle); }

void CheckWorldInputs(const Robot& robot, const SceneSpec& scene, const WorldOptions& options) {
  const int nq = robot.model.nq();
  const int num_links = robot.model.num_links();
  if (num_links < 1) Fail("robot '" + robot.name + "'", "a model with at least one link", "an empty model");
  CheckPositive(options.timestep, "WorldOptions.timestep");
  CheckNonNegative(options.warning_margin, "WorldOptions.warning_margin");
  CheckPositive(options.link_density, "WorldOptions.link_density");
  CheckPositive(options.min_link_mass, "WorldOptions.min_link_mass");
  CheckPositive(options.servo.natural_frequency, "WorldOptions.servo.natural_frequency");
  CheckNonNegative(options.servo.damping_ratio, "WorldOptions.servo.damping_ratio");
  CheckNonNegative(options.servo.armature, "WorldOptions.servo.armature");
  if (options.servo.kp.size() != 0) {
    if (options.servo.kp.size() != nq) {
      Fail("WorldOptions.servo.kp", fmt::format("{} entries (one per dof) or none", nq),
           fmt::format("{}", options.servo.kp.size()));
    }
    for (int i = 0; i < nq; ++i) CheckPositive(options.servo.kp[i], fmt::format("WorldOptions.servo.kp[{}]", i));
  }
  if (options.servo.damping.size() != 0) {
    if (options.servo.damping.size() != nq) {
      Fail("WorldOptions.servo.damping", fmt::format("{} entries (one per dof) or none", nq),
           fmt::format("{}", options.servo.damping.size()));
    }
    for (int i = 0; i < nq; ++i) {
      CheckNonNegative(options.servo.damping[i], fmt::format("WorldOptions.servo.damping[{}]", i));
    }
  }
  auto check_capsules = [&](const std::vector<kinematics::LinkCapsule>& capsules, const char* name) {
    for (size_t c = 0; c < capsules.size(); ++c) {
      const kinematics::LinkCapsule& cap = capsules[c];
      const std::string what = fmt::format("robot '{}' {}[{}]", robot.name, name, c);
      if (cap.link < 0 || cap.link >= num_links) {
        Fail(what + ".link", fmt::format("a link index in [0, {})", num_links), fmt::format("{}", cap.link));
      }
      if (!cap.p_LA.allFinite() || !cap.p_LB.allFinite()) Fail(what, "finite end points", "non-finite entries");
      CheckPositive(cap.radius, what + ".radius");
    }
  };
  check_capsules(robot.capsules, "capsules");
  check_capsules(robot.self_capsules, "self_capsules");
  if (const int k = robot.LinkInOneCoverOnly(); k >= 0) {
    Fail(fmt::format("robot '{}' link '{}'", robot.name, robot.model.link(k).name),
         "capsules and self_capsules on the same links",
         fmt::format("{} capsules and {} self_capsules", Robot::CountOn(robot.capsules, k),
                     Robot::CountOn(robot.self_capsules, k)));
  }
  for (size_t j = 0; j < scene.obstacles.size(); ++j) {
    const ObstacleSpec& obs = scene.obstacles[j];
    const std::string what = fmt::format("SceneSpec.obstacles[{}]", j);
    if (obs.shape == ObstacleShape::kBox) {
      for (int a = 0; a < 3; ++a) CheckPositive(obs.half_size[a], fmt::format("{}.half_size[{}]", what, a));
    } else {
      CheckPositive(obs.radius, what + ".radius");
      if (obs.shape == ObstacleShape::kCylinder) CheckPositive(obs.half_length, what + ".half_length");
    }
    CheckPose(obs.X_WO, what + ".X_WO");
  }
  if (scene.has_target) {
    CheckPositive(scene.target_radius, "SceneSpec.target_radius");
    if (!scene.p_WT.allFinite()) Fail("SceneSpec.p_WT", "a finite position", "non-finite entries");
  }
  if (scene.has_floor && !std::isfinite(scene.floor_height)) {
    Fail("SceneSpec.floor_height", "a finite height", Num(scene.floor_height));
  }
}

std::string WriteMjcf(const Robot& robot, const SceneSpec& scene, const WorldOptions& options,
                      const ServoGains& gains) {
  const kinematics::Model& model = robot.model;
  const int num_links = model.num_links();
  const int nq = model.nq();
  RMPMARL_ASSERT(gains.kp.size() == nq && gains.damping.size() == nq, "servo gains must have one entry per dof");

  std::vector<std::vector<int>> children(num_links), link_capsules(num_links), link_self_capsules(num_links);
  for (int k = 1; k < num_links; ++k) children[model.link(k).parent].push_back(k);
  for (size_t c = 0; c < robot.capsules.size(); ++c) link_capsules[robot.capsules[c].link].push_back(static_cast<int>(c));
  for (size_t c = 0; c < robot.self_capsules.size(); ++c) {
    link_self_capsules[robot.self_capsules[c].link].push_back(static_cast<int>(c));
  }
  const std::vector<int> weld = WeldGroups(model);
  const int num_capsules = static_cast<int>(robot.capsules.size());
  const int num_obstacles = static_cast<int>(scene.obstacles.size());

  // explicit <pair>s for pairs MuJoCo's dynamic filter would drop but rmpmarl checks: world-welded capsules (the
  // base) against obstacles (mocap bodies count as world-welded, and MuJoCo never collides two such bodies), and
  // capsules of distinct non-excluded links that a fixed joint welds together.
  std::vector<std::pair<std::string, std::string>> pairs;
  int num_dynamic_pairs = 0;
  // self pairs: of the self-collision set when the robot has one (after the obstacle pairs), else of the capsules
  // (each capsule's after its obstacle pairs)
  const bool separate = !robot.self_capsules.empty();
  auto self_pairs_of = [&](const std::vector<kinematics::LinkCapsule>& self, int c, auto&& geom_name) {
    const int lc = self[c].link;
    for (int d = c + 1; d < static_cast<int>(self.size()); ++d) {
      const int ld = self[d].link;
      if (lc == ld || robot.IsExcludedPair(lc, ld)) continue;
      if (weld[lc] == weld[ld]) pairs.emplace_back(geom_name(robot, c), geom_name(robot, d));
      else ++num_dynamic_pairs;
    }
  };
  for (int c = 0; c < num_capsules; ++c) {
    const int lc = robot.capsules[c].link;
    for (int j = 0; j < num_obstacles; ++j) {
      if (weld[lc] == 0) pairs.emplace_back(MjcfNames::CapsuleGeom(robot, c), MjcfNames::ObstacleGeom(j));
      else ++num_dynamic_pairs;
    }
    if (scene.has_floor && weld[lc] != 0) ++num_dynamic_pairs;
    if (!separate) self_pairs_of(robot.capsules, c, MjcfNames::CapsuleGeom);
  }
  for (int c = 0; separate && c < static_cast<int>(robot.self_capsules.size()); ++c) {
    self_pairs_of(robot.self_capsules, c, MjcfNames::SelfCapsuleGeom);
  }
  // every primitive pair used here yields at most 2 contacts (capsule–capsule, capsule–box, capsule–plane), so the
  // contact list never overflows. Only penetrating contacts are constraints (gap = margin: the contacts within the
  // margin are warnings, no force), one row each (condim 1), beside one per joint limit and mimic joint. MuJoCo 2.2.2
  // preallocates njmax² doubles per mjData for the solver: rows for every contact would cost gigabytes with a hundred
  // capsules (and fail to allocate), so the contact rows are capped at kMaxContactRows penetrating contacts at once —
  // far more than an arm pressed into a cell has; past it MuJoCo drops rows (ContactReport::contact_buffer_full).
  constexpr int kMaxContactRows = 512;
  const int nconmax = 2 * (num_dynamic_pairs + static_cast<int>(pairs.size())) + 16;
  int num_mimic = 0;
  for (int k = 1; k < num_links; ++k) num_mimic += model.link(k).mimic_dof >= 0;
  const int njmax = std::min(nconmax, kMaxContactRows) + 2 * nq + num_mimic + 16;

  std::string out;
  out.reserve(4096 + 512 * (num_links + num_capsules + num_obstacles));
  out += fmt::format("<mujoco model=\"{}\">\n", Xml(robot.name));
  out += "  <!-- generated by rmpmarl::sim::WriteMjcf; see docs/sim.md -->\n";
  out += "  <compiler angle=\"radian\" inertiafromgeom=\"auto\"/>\n";
  out += fmt::format("  <option timestep=\"{}\" integrator=\"{}\" gravity=\"0 0 0\">\n", Num(options.timestep),
                     options.integrator == Integrator::kImplicit ? "implicit" : "Euler");
  out += "    <flag filterparent=\"disable\"/>\n";
  out += "  </option>\n";
  out += fmt::format("  <size nconmax=\"{}\" njmax=\"{}\"/>\n", nconmax, njmax);
  out += "  <worldbody>\n";
  if (scene.has_floor) {
    out += fmt::format(
        "    <geom name=\"{}\" type=\"plane\" pos=\"0 0 {}\" size=\"0 0 1\" contype=\"{}\" conaffinity=\"{}\" "
        "condim=\"1\" rgba=\"0.8 0.8 0.8 1\"/>\n",
        MjcfNames::kFloorGeom, Num(scene.floor_height), kSceneContype, kSceneConaffinity);
  }
  WriteBody(robot, options, gains, children, link_capsules, link_self_capsules, 0, 2, &out);
  for (int j = 0; j < num_obstacles; ++j) {
    const ObstacleSpec& obs = scene.obstacles[j];
    out += fmt::format("    <body name=\"{}\" mocap=\"true\" pos=\"{}\" quat=\"{}\">\n", MjcfNames::ObstacleBody(j),
                       Vec(obs.X_WO.translation()), Quat(obs.X_WO.linear()));
    std::string shape = fmt::format("type=\"sphere\" size=\"{}\"", Num(obs.radius));
    if (obs.shape == ObstacleShape::kBox) shape = fmt::format("type=\"box\" size=\"{}\"", Vec(obs.half_size));
    if (obs.shape == ObstacleShape::kCylinder) {
      shape = fmt::format("type=\"cylinder\" size=\"{} {}\"", Num(obs.radius), Num(obs.half_length));
    }
    out += fmt::format(
        "      <geom name=\"{}\" {} contype=\"{}\" conaffinity=\"{}\" condim=\"1\" group=\"2\" "
        "rgba=\"0.9 0.3 0.2 1\"/>\n",
        MjcfNames::ObstacleGeom(j), shape, kSceneContype, kSceneConaffinity);
    out += "    </body>\n";
  }
  if (scene.has_target) {
    out += fmt::format("    <body name=\"{}\" mocap=\"true\" pos=\"{}\">\n", MjcfNames::kTargetBody, Vec(scene.p_WT));
    out += fmt::format(
        "      <geom name=\"{}\" type=\"sphere\" size=\"{}\" contype=\"0\" conaffinity=\"0\" group=\"2\" "
        "rgba=\"0.2 0.9 0.2 0.5\"/>\n",
        MjcfNames::kTargetGeom, Num(scene.target_radius));
    out += "    </body>\n";
  }
  out += "  </worldbody>\n";
  if (!robot.excluded_pairs.empty() || !pairs.empty()) {
    out += "  <contact>\n";
    for (const auto& [i, j] : robot.excluded_pairs) {
      out += fmt::format("    <exclude body1=\"{}\" body2=\"{}\"/>\n", Xml(MjcfNames::LinkBody(robot, i)),
                         Xml(MjcfNames::LinkBody(robot, j)));
    }
    for (const auto& [g1, g2] : pairs) {
      out += fmt::format("    <pair geom1=\"{}\" geom2=\"{}\" condim=\"1\" margin=\"{}\" gap=\"{}\"/>\n", Xml(g1),
                         Xml(g2), Num(options.warning_margin), Num(options.warning_margin));
    }
    out += "  </contact>\n";
  }
  if (num_mimic > 0) {
    // URDF <mimic>: follower = multiplier · leader + offset (MuJoCo: joint1 = polycoef(joint2))
    out += "  <equality>\n";
    for (int k = 1; k < num_links; ++k) {
      const kinematics::Link& link = model.link(k);
      if (link.mimic_dof < 0) continue;
      out += fmt::format("    <joint joint1=\"{}\" joint2=\"{}\" polycoef=\"{} {} 0 0 0\"/>\n", Xml(link.joint_name),
                         Xml(model.dof_name(link.mimic_dof)), Num(link.mimic_offset), Num(link.mimic_multiplier));
    }
    out += "  </equality>\n";
  }
  if (nq > 0) {
    out += "  <actuator>\n";
    for (int i = 0; i < nq; ++i) {
      const kinematics::DofLimits& lim = model.limits()[i];
      const bool limited = model.link(model.dof_link(i)).joint_type != JointType::kContinuous;
      std::string ctrl = limited ? fmt::format("ctrllimited=\"true\" ctrlrange=\"{} {}\"", Num(lim.lower),
                                               Num(lim.upper))
                                 : std::string("ctrllimited=\"false\"");
      std::string force;
      if (options.servo.limit_force_to_effort && lim.effort > 0.0) {
        force = fmt::format(" forcelimited=\"true\" forcerange=\"{} {}\"", Num(-lim.effort), Num(lim.effort));
      }
      out += fmt::format("    <position name=\"{}\" joint=\"{}\" kp=\"{}\" {}{}/>\n",
                         Xml(MjcfNames::Actuator(robot, i)), Xml(model.dof_name(i)), Num(gains.kp[i]), ctrl, force);
    }
    out += "  </actuator>\n";
  }
  out += "</mujoco>\n";
  return out;
}

std::shared_ptr<mjModel> CompileMjcf(const std::string& mjcf, std::string_view source) {
  static constexpr const char* kFileName = "rmpmarl_world.xml";
  auto vfs = std::make_unique<mjVFS>();  // ~2 MB: never on the stack
  mj_defaultVFS(vfs.get());
  const int size = static_cast<int>(mjcf.size());
  if (mj_makeEmptyFileVFS(vfs.get(), kFileName, size) != 0) {
    throw InputError(fmt::format("{}: could not create the in-memory MJCF file ({} bytes)", source, size));
  }
  const int index = mj_findFileVFS(vfs.get(), kFileName);
  RMPMARL_ASSERT(index >= 0, "the VFS file just made must exist");
  std::memcpy(vfs->filedata[index], mjcf.data(), mjcf.size());
  char error[1024] = "";
  mjModel* model = mj_loadXML(kFileName, vfs.get(), error, sizeof(error));
  mj_deleteVFS(vfs.get());
  if (model == nullptr) {
    throw InputError(fmt::format("{}: MuJoCo could not compile the generated MJCF: {}", source, error));
  }
  return std::shared_ptr<mjModel>(model, [](mjModel* m) { mj_deleteModel(m); });
}

}  // namespace rmpmarl::sim
