// A robot description from a URDF alone: fitted capsules, end effector, sampled self-collision exclusions, home
// posture; see robot_setup.h and docs/robot-description.md. The SRDF's part: robot_setup_srdf.cc; its files (and
// loading a URDF with or without them): robot_setup_files.cc.
#include "rmpmarl/setup/robot_setup.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/common/random.h"
#include "rmpmarl/setup/capsule_fit.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/urdf_geometry.h"
#include "rmpmarl/setup/mesh.h"
#include "robot_setup_internal.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::setup {

using namespace kinematics;  // the robot description being set up: kinematics' types throughout
namespace {

namespace fs = std::filesystem;
constexpr double kPi = 3.14159265358979323846;

// a stream of uniform doubles in [0, 1) from SplitMix64: identical on every platform for a seed.
class UniformStream {
 public:
  explicit UniformStream(std::uint64_t seed) : state_(SplitMix64(seed)) {}
  double Next() {
    state_ = SplitMix64(state_);
    return static_cast<double>(state_ >> 11) * 0x1.0p-53;
  }
  double Normal() {  // Box–Muller
    const double u1 = std::max(Next(), 1e-300), u2 = Next();
    return std::sqrt(-2.0 * std::log(u1)) * std::cos(2.0 * kPi * u2);
  }

 private:
  std::uint64_t state_;
};

double Lower(const DofLimits& l) { return std::isfinite(l.lower) ? l.lower : -kPi; }
double Upper(const DofLimits& l) { return std::isfinite(l.upper) ? l.upper : kPi; }

Eigen::VectorXd MidRange(const Model& model) {
  Eigen::VectorXd q(model.nq());
  for (int i = 0; i < model.nq(); ++i) q[i] = 0.5 * (Lower(model.limits()[i]) + Upper(model.limits()[i]));
  return q;
}

Eigen::VectorXd RandomConfiguration(const Model& model, UniformStream& u) {
  Eigen::VectorXd q(model.nq());
  for (int i = 0; i < model.nq(); ++i) {
    const DofLimits& l = model.limits()[i];
    q[i] = Lower(l) + (Upper(l) - Lower(l)) * u.Next();
  }
  return q;
}

// the geometry of one link prepared for its cover: its surfaces, and the exact smallest capsule of a single
// primitive.
struct LinkGeometry {
  CoverGeometry cover;   // what the capsules cover (a cylinder's circumscribed prism)
  CoverGeometry check;   // what they are measured against (a cylinder's inscribed prism: on or inside it)
  bool has_cylinder = false;
  std::optional<math::Capsule> closed_form;  // single primitive: its exact smallest capsule
  std::string source;
  bool missing = false;
};

math::Capsule Transformed(const Eigen::Isometry3d& X, const math::Capsule& c) { return {X * c.p_WA, X * c.p_WB, c.radius}; }

// adds one shape to the link's geometry; a missing or unreadable mesh sets `missing` and a warning.
void AddShape(const LinkShape& shape, const fs::path& urdf_path, const RobotSetupOptions& options,
              const std::string& link_name, LinkGeometry* g, std::vector<std::string>* warnings) {
  const Eigen::Isometry3d& X = shape.X_LG;
  const std::string element = shape.visual ? "visual" : "collision";
  switch (shape.kind) {
    case ShapeKind::kSphere: {
      g->cover.balls.push_back({X.translation(), shape.radius});
      g->check.balls.push_back({X.translation(), shape.radius});
      g->closed_form = Transformed(X, CapsuleCoveringSphere(shape.radius));
      g->source = fmt::format("{} sphere r={:.3f}", element, shape.radius);
      break;
    }
    case ShapeKind::kBox: {
      AppendBoxSurface(X, shape.size, &g->cover);
      AppendBoxSurface(X, shape.size, &g->check);
      g->closed_form = Transformed(X, CapsuleCoveringBox(shape.size));
      g->source = fmt::format("{} box {:.3f} x {:.3f} x {:.3f}", element, shape.size.x(), shape.size.y(),
                              shape.size.z());
      break;
    }
    case ShapeKind::kCylinder: {
      AppendCylinderSurface(X, shape.radius, shape.length, 64, true, &g->cover);
      AppendCylinderSurface(X, shape.radius, shape.length, 64, false, &g->check);
      g->has_cylinder = true;
      g->closed_form = Transformed(X, CapsuleCoveringCylinder(shape.radius, shape.length));
      g->source = fmt::format("{} cylinder r={:.3f} l={:.3f}", element, shape.radius, shape.length);
      break;
    }
    case ShapeKind::kMesh: {
      std::string tried;
      const fs::path path = ResolveMeshUri(shape.mesh_uri, urdf_path, options.package_paths, &tried);
      g->source = fmt::format("{} mesh {}", element, shape.mesh_uri);
      if (path.empty()) {
        warnings->push_back(fmt::format("link '{}': mesh '{}' not found (looked in: {}); using a capsule between the "
                                        "joint origins", link_name, shape.mesh_uri, tried));
        g->missing = true;
        return;
      }
      TriangleMesh mesh;
      try {
        mesh = ReadMesh(path, shape.mesh_scale);
      } catch (const InputError& e) {
        warnings->push_back(fmt::format("link '{}': {}; using a capsule between the joint origins", link_name,
                                        e.what()));
        g->missing = true;
        return;
      }
      const Eigen::Matrix3Xd p_L = X * mesh.p_M;
      const int offset = static_cast<int>(g->cover.vertices.size());
      for (Eigen::Index i = 0; i < p_L.cols(); ++i) g->cover.vertices.push_back(p_L.col(i));
      for (const Eigen::Vector3i& t : mesh.triangles) {
        g->cover.triangles.push_back(t + Eigen::Vector3i::Constant(offset));
      }
      if (mesh.triangles.empty()) {  // a point set: each vertex a ball of radius 0
        for (Eigen::Index i = 0; i < p_L.cols(); ++i) g->cover.balls.push_back({p_L.col(i), 0.0});
      }
      const int check_offset = static_cast<int>(g->check.vertices.size());
      g->check.vertices.insert(g->check.vertices.end(), g->cover.vertices.begin() + offset, g->cover.vertices.end());
      for (const Eigen::Vector3i& t : mesh.triangles) {
        g->check.triangles.push_back(t + Eigen::Vector3i::Constant(check_offset));
      }
      if (mesh.triangles.empty()) {
        for (Eigen::Index i = 0; i < p_L.cols(); ++i) g->check.balls.push_back({p_L.col(i), 0.0});
      }
      g->source += fmt::format(" ({} vertices)", p_L.cols());
      break;
    }
  }
}

// the end-effector link: options.end_effector, else the tip of the longest revolute chain, moved on along fixed
// joints to a tool frame when one is named like one (tcp, tool0, ee, flange, hand).
int PickEndEffector(const Model& model, const std::string& requested) {
  if (!requested.empty()) return model.LinkIndex(requested);
  // rotational joints from the root to link k, mimic joints of a rotational dof included (a coupled wrist joint is
  // part of the arm), those a prismatic dof drives not (a gripper's linkage)
  auto revolute_count = [&](int k) {
    int n = 0;
    for (int j = k; j > 0; j = model.link(j).parent) {
      const Link& l = model.link(j);
      if (!l.moving() || l.joint_type == JointType::kPrismatic) continue;
      n += model.link(model.dof_link(l.driving_dof())).joint_type != JointType::kPrismatic;
    }
    return n;
  };
  int tip = 0;
  for (int k = 0; k < model.num_links(); ++k) {
    if (revolute_count(k) > revolute_count(tip)) tip = k;
  }
  // the link carrying the last revolute joint (not a prismatic finger below it)
  while (tip > 0 && model.link(tip).joint_type == JointType::kFixed && revolute_count(model.link(tip).parent) ==
                                                                            revolute_count(tip)) {
    tip = model.link(tip).parent;
  }
  return internal::ToolFrameAtOrBelow(model, tip);
}

// the nearest proper ancestor of link k that carries a capsule, or -1.
int NearestAncestorWithCapsule(const Model& model, const std::vector<int>& capsule_count, int k) {
  for (int a = model.link(k).parent; a >= 0; a = model.link(a).parent) {
    if (capsule_count[a] > 0) return a;
  }
  return -1;
}

void SortUnique(std::vector<std::pair<int, int>>* pairs) {
  std::sort(pairs->begin(), pairs->end());
  pairs->erase(std::unique(pairs->begin(), pairs->end()), pairs->end());
}

// world capsules of every self-collision capsule at the current data.
void WorldCapsules(const Robot& robot, const Data& data, std::vector<math::Capsule>* out) {
  const std::vector<LinkCapsule>& capsules = robot.self_collision_capsules();
  out->resize(capsules.size());
  for (size_t c = 0; c < capsules.size(); ++c) (*out)[c] = WorldCapsule(capsules[c], data);
}

double CapsuleDistance(const math::Capsule& a, const math::Capsule& b) {
  return math::ClosestPointsSegmentSegment(a.p_WA, a.p_WB, b.p_WA, b.p_WB).distance - a.radius - b.radius;
}

// self-collision capsule indices per link.
std::vector<std::vector<int>> CapsulesPerLink(const Robot& robot) {
  const std::vector<LinkCapsule>& capsules = robot.self_collision_capsules();
  std::vector<std::vector<int>> per_link(robot.model.num_links());
  for (size_t c = 0; c < capsules.size(); ++c) per_link[capsules[c].link].push_back(static_cast<int>(c));
  return per_link;
}

// smallest distance between the capsules of links a and b.
double LinkPairDistance(const std::vector<std::vector<int>>& per_link, const std::vector<math::Capsule>& world, int a,
                        int b) {
  double d = std::numeric_limits<double>::infinity();
  for (int i : per_link[a]) {
    for (int j : per_link[b]) d = std::min(d, CapsuleDistance(world[i], world[j]));
  }
  return d;
}

}  // namespace

namespace internal {

// link `tip`, or the link fixed below it (through fixed joints only) named like a tool frame, best name first.
int ToolFrameAtOrBelow(const Model& model, int tip) {
  std::vector<int> fixed_below = {tip};
  for (int k = tip + 1; k < model.num_links(); ++k) {
    const int p = model.link(k).parent;
    if (model.link(k).joint_type == JointType::kFixed && std::find(fixed_below.begin(), fixed_below.end(), p) !=
                                                              fixed_below.end()) {
      fixed_below.push_back(k);
    }
  }
  for (const char* key : {"tcp", "tool0", "tool", "end_effector", "_ee", "ee_", "flange", "hand"}) {
    for (int k : fixed_below) {
      std::string name = model.link(k).name;
      std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
      if (name.find(key) != std::string::npos || (std::string(key) == "_ee" && name == "ee")) return k;
    }
  }
  return tip;
}

}  // namespace internal

std::string_view ExclusionReasonName(ExclusionReason reason) {
  switch (reason) {
    case ExclusionReason::kAdjacent: return "adjacent";
    case ExclusionReason::kAlwaysInContact: return "always in contact";
    case ExclusionReason::kNeverClose: return "never close";
    case ExclusionReason::kContactAtHome: return "in contact at home";
    case ExclusionReason::kOneGripper: return "one gripper (moved against each other by one mimic dof)";
    case ExclusionReason::kSrdf: return "disabled in the SRDF";
  }
  return "unknown";
}

RobotSetup FitRobot(const fs::path& urdf_path, const RobotSetupOptions& options) {
  std::ifstream file(urdf_path);
  if (!file) throw InputError(fmt::format("{}: cannot open URDF file (missing or unreadable)", urdf_path.string()));
  std::stringstream buffer;
  buffer << file.rdbuf();
  const std::string xml = buffer.str();
  const std::string source = urdf_path.string();
  if (!(options.fallback_radius > 0.0)) {
    throw InputError(fmt::format("setup: fallback_radius: expected > 0, got {}", options.fallback_radius));
  }

  RobotSetup setup;
  Robot& robot = setup.robot;
  robot.model = ParseUrdfModel(xml, source);
  robot.name = robot.model.name();
  robot.urdf_path = urdf_path;
  const Model& model = robot.model;
  const std::vector<LinkShape> shapes = ParseUrdfShapes(xml, model, source);
  if (!MeshReadingAvailable() &&
      std::any_of(shapes.begin(), shapes.end(), [](const LinkShape& s) { return s.kind == ShapeKind::kMesh; })) {
    setup.warnings.push_back("rmpmarl was built without assimp: mesh links get capsules between joint origins "
                             "(install libassimp-dev and rebuild)");
  }

  for (const auto& [name, tolerance] : options.link_tolerance) {
    model.LinkIndex(name);  // an unknown link: InputError listing the links
    if (!(std::isfinite(tolerance) && tolerance > 0.0)) {
      throw InputError(fmt::format("setup: link tolerance of '{}': expected a finite value > 0 m, got {}", name,
                                   tolerance));
    }
  }
  for (int k = 0; k < model.num_links(); ++k) {
    LinkFit fit;
    fit.link = k;
    CapsuleCoverOptions link_cover = options.cover;
    if (const auto it = options.link_tolerance.find(model.link(k).name); it != options.link_tolerance.end()) {
      link_cover.tolerance = it->second;
    }
    LinkGeometry g;
    int num_shapes = 0;
    std::string sources;
    for (const LinkShape& shape : shapes) {
      if (shape.link != k) continue;
      ++num_shapes;
      AddShape(shape, urdf_path, options, model.link(k).name, &g, &setup.warnings);
      sources += (sources.empty() ? "" : " + ") + g.source;
    }
    if (num_shapes == 0) {
      fit.source = "frame only (no geometry)";
      setup.links.push_back(fit);
      continue;
    }
    std::vector<math::Capsule> capsules, self_capsules;
    if (g.missing) {
      // a capsule between the link origin and its children's joint origins
      std::vector<Ball> balls = {{Eigen::Vector3d::Zero(), options.fallback_radius}};
      for (int c = k + 1; c < model.num_links(); ++c) {
        if (model.link(c).parent == k) balls.push_back({model.link(c).X_PJ.translation(), options.fallback_radius});
      }
      capsules = {FitCapsuleToBalls(balls)};
      fit.fallback = true;
      fit.source = fmt::format("{}: MISSING, capsule between joint origins (r={:.3f})", sources,
                               options.fallback_radius);
      fit.excess = fit.outside = std::numeric_limits<double>::quiet_NaN();
    } else {
      // a single primitive keeps its exact smallest capsule when that is within the tolerance; everything else is
      // covered by as many capsules as its shape needs
      auto cover_link = [&](const CapsuleCoverOptions& cover_options, const char* which, bool* closed) {
        CapsuleCover cover;
        *closed = false;
        if (num_shapes == 1 && g.closed_form) {
          cover = MeasureCapsuleCover(g.check, {*g.closed_form}, cover_options);
          *closed = cover.within_tolerance;
        }
        if (!*closed) {
          CapsuleCover fitted = FitCapsuleCover(g.cover, cover_options);
          if (g.has_cylinder) fitted = MeasureCapsuleCover(g.check, fitted.capsules, cover_options);
          if (g.closed_form && num_shapes == 1 && !(fitted.max_excess < cover.max_excess)) {
            *closed = true;  // the closed form is no worse
          } else {
            cover = fitted;
          }
        }
        if (cover.max_outside > 1e-6) {
          setup.warnings.push_back(fmt::format("link '{}': a sample of its geometry lies {:.3f} mm outside its "
                                               "{}capsules", model.link(k).name, 1e3 * cover.max_outside, which));
        }
        return cover;
      };
      bool closed = false;
      const CapsuleCover cover = cover_link(link_cover, "", &closed);
      capsules = cover.capsules;
      fit.excess = cover.max_excess;
      fit.mean_excess = cover.mean_excess;
      fit.outside = cover.max_outside;
      fit.samples = cover.samples;
      fit.within_tolerance = cover.within_tolerance;
      fit.reached_max_capsules = cover.reached_max_capsules;
      fit.source = sources + (closed ? " (closed form)" : fmt::format(" ({} capsule{})", capsules.size(),
                                                                      capsules.size() == 1 ? "" : "s"));
      if (options.self_cover) {
        bool self_closed = false;
        const CapsuleCover self_cover = cover_link(*options.self_cover, "self-collision ", &self_closed);
        self_capsules = self_cover.capsules;
        fit.self_excess = self_cover.max_excess;
      }
    }
    for (const math::Capsule& capsule : capsules) {
      fit.capsules.push_back(static_cast<int>(robot.capsules.size()));
      robot.capsules.push_back({k, capsule.p_WA, capsule.p_WB, capsule.radius});
    }
    // with a separate self-collision cover every link with capsules has self-collision capsules (a fallback's own)
    if (options.self_cover) {
      for (const math::Capsule& capsule : self_capsules.empty() ? capsules : self_capsules) {
        fit.self_capsules.push_back(static_cast<int>(robot.self_capsules.size()));
        robot.self_capsules.push_back({k, capsule.p_WA, capsule.p_WB, capsule.radius});
      }
      if (self_capsules.empty()) fit.self_excess = fit.excess;
    }
    setup.links.push_back(fit);
  }
  std::string above;
  for (const LinkFit& fit : setup.links) {
    if (!fit.capsules.empty() && !fit.fallback && !fit.within_tolerance) {
      above += fmt::format("{}{} ({:.1f} mm, {} capsule{}{})", above.empty() ? "" : ", ", model.link(fit.link).name,
                           1e3 * fit.excess, fit.capsules.size(), fit.capsules.size() == 1 ? "" : "s",
                           fit.reached_max_capsules ? ", the most allowed" : ", no cut made them stick out less");
    }
  }
  if (!above.empty()) {
    setup.notes.push_back(fmt::format("capsules sticking out more than the tolerance {:.1f} mm{} somewhere (mostly caps "
                                      "over flat faces, which a round capsule cannot follow): {}",
                                      1e3 * options.cover.tolerance,
                                      options.link_tolerance.empty() ? "" : " (or the link's own)", above));
  }
  if (robot.capsules.empty()) {
    throw InputError(fmt::format("{}: no link has <collision> or <visual> geometry: nothing to fit capsules to (write "
                                 "a collision YAML by hand, docs/robot-description.md)", source));
  }
  robot.end_effector.link = PickEndEffector(model, options.end_effector);

  // adjacent pairs: parent–child, and a link with the nearest ancestor that carries a capsule (frame-only links
  // in between, as MoveIt's adjacency skips links without geometry)
  std::vector<int> capsule_count(model.num_links(), 0);
  for (const LinkCapsule& c : robot.capsules) ++capsule_count[c.link];
  for (int k = 1; k < model.num_links(); ++k) {
    robot.excluded_pairs.emplace_back(std::min(k, model.link(k).parent), std::max(k, model.link(k).parent));
    if (capsule_count[k] == 0) continue;
    const int a = NearestAncestorWithCapsule(model, capsule_count, k);
    if (a >= 0 && a != model.link(k).parent) {
      robot.excluded_pairs.emplace_back(std::min(a, k), std::max(a, k));
      setup.exclusions.push_back({std::min(a, k), std::max(a, k), ExclusionReason::kAdjacent, 0.0, 0.0, ""});
    }
  }
  // links that only a gripper's dof moves relative to each other (the fingers of one gripper: the path between them
  // in the tree has fixed joints and joints of one dof with mimic followers): touching is what they are for
  for (int a = 1; a < model.num_links(); ++a) {
    for (int b = a + 1; b < model.num_links(); ++b) {
      if (capsule_count[a] == 0 || capsule_count[b] == 0 || robot.IsExcludedPair(a, b)) continue;
      if (model.IsAncestorOrSelf(a, b) || model.IsAncestorOrSelf(b, a)) continue;  // one chain: not two fingers
      std::set<int> path_dofs;
      for (int k = a; !model.IsAncestorOrSelf(k, b); k = model.link(k).parent) {
        if (model.link(k).moving()) path_dofs.insert(model.link(k).driving_dof());
      }
      for (int k = b; !model.IsAncestorOrSelf(k, a); k = model.link(k).parent) {
        if (model.link(k).moving()) path_dofs.insert(model.link(k).driving_dof());
      }
      if (path_dofs.size() != 1 || model.dof_joint_links(*path_dofs.begin()).size() < 2) continue;
      robot.excluded_pairs.emplace_back(a, b);
      setup.exclusions.push_back({a, b, ExclusionReason::kOneGripper, 0.0, 0.0, ""});
    }
  }
  SortUnique(&robot.excluded_pairs);
  return setup;
}

std::vector<PairStatistics> SampleSelfCollision(const Robot& robot, const RobotSetupOptions& options) {
  if (options.samples < 1 || options.samples > 10'000'000) {
    throw InputError(fmt::format("setup: samples: expected 1 to 10000000, got {}", options.samples));
  }
  const Model& model = robot.model;
  const std::vector<std::vector<int>> per_link = CapsulesPerLink(robot);
  std::vector<PairStatistics> stats;
  for (int a = 0; a < model.num_links(); ++a) {
    for (int b = a + 1; b < model.num_links(); ++b) {
      if (per_link[a].empty() || per_link[b].empty() || robot.IsExcludedPair(a, b)) continue;
      stats.push_back({a, b, 0, std::numeric_limits<double>::infinity()});
    }
  }
  Data data(model);
  std::vector<math::Capsule> world;
  UniformStream u(options.seed);
  for (int s = 0; s < options.samples; ++s) {
    CalcForwardKinematics(model, RandomConfiguration(model, u), &data);
    WorldCapsules(robot, data, &world);
    for (PairStatistics& p : stats) {
      const double d = LinkPairDistance(per_link, world, p.link_a, p.link_b);
      p.contacts += d < 0.0;
      p.min_distance = std::min(p.min_distance, d);
    }
  }
  return stats;
}

double Manipulability(const Robot& robot, const Eigen::VectorXd& q) {
  const Model& model = robot.model;
  Data data(model);
  CalcForwardKinematics(model, q, &data);
  const int ee = robot.end_effector.link;
  // the columns of the dofs that move the end effector (a gripper's dof beside it would make any posture singular)
  const std::vector<int>& dofs = model.link_dofs(ee);
  const int n = static_cast<int>(dofs.size());
  Eigen::MatrixXd J = Eigen::MatrixXd::Zero(6, n);
  const Eigen::Vector3d p_WE = data.X_WL[ee] * robot.end_effector.X_LE.translation();
  for (int c = 0; c < n; ++c) {
    const int i = dofs[c];
    J.block<3, 1>(0, c) = CalcPointJacobianColumn(model, data, i, ee, p_WE);
    for (int k : model.dof_joint_links(i)) {  // angular rows: the rotational joints dof i drives (mimic followers too)
      const Link& joint = model.link(k);
      if (joint.joint_type == JointType::kPrismatic || !model.IsAncestorOrSelf(k, ee)) continue;
      J.block<3, 1>(3, c) += (joint.q_index >= 0 ? 1.0 : joint.mimic_multiplier) * data.axis_WL.col(k);
    }
  }
  const Eigen::MatrixXd G = n >= 6 ? Eigen::MatrixXd(J * J.transpose()) : Eigen::MatrixXd(J.transpose() * J);
  return std::sqrt(std::max(0.0, G.determinant()));
}

std::vector<ClosestPair> SelfCollisionPairsWithin(const Robot& robot, const Eigen::VectorXd& q, double distance) {
  const Model& model = robot.model;
  Data data(model);
  CalcForwardKinematics(model, q, &data);
  std::vector<math::Capsule> world;
  WorldCapsules(robot, data, &world);
  const std::vector<std::vector<int>> per_link = CapsulesPerLink(robot);
  std::vector<ClosestPair> pairs;
  for (int a = 0; a < model.num_links(); ++a) {
    for (int b = a + 1; b < model.num_links(); ++b) {
      if (per_link[a].empty() || per_link[b].empty() || robot.IsExcludedPair(a, b)) continue;
      const double d = LinkPairDistance(per_link, world, a, b);
      if (d < distance) pairs.push_back({a, b, d});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const ClosestPair& x, const ClosestPair& y) { return x.distance < y.distance; });
  return pairs;
}

ClosestPair ClosestSelfCollisionPair(const Robot& robot, const Eigen::VectorXd& q) {
  const auto pairs = SelfCollisionPairsWithin(robot, q, std::numeric_limits<double>::infinity());
  if (pairs.empty()) return {-1, -1, std::numeric_limits<double>::infinity()};
  return pairs.front();
}

namespace {

// lowest z of the capsules of links that some dof moves, at q (the floor test of a home candidate).
double LowestMovingCapsule(const Robot& robot, const Data& data) {
  double z = std::numeric_limits<double>::infinity();
  for (const LinkCapsule& c : robot.capsules) {
    if (robot.model.link_dofs(c.link).empty()) continue;
    z = std::min({z, (data.X_WL[c.link] * c.p_LA).z() - c.radius, (data.X_WL[c.link] * c.p_LB).z() - c.radius});
  }
  return z;
}

// the home search's score: log manipulability minus a penalty on the distance from mid-range (each joint's offset in
// units of its half range, squared, averaged); −inf when infeasible.
struct HomeScorer {
  const Robot& robot;
  Eigen::VectorXd lo, hi, mid, half;
  double min_clearance;
  double min_floor;
  mutable Data data;

  double centering;

  HomeScorer(const Robot& r, double clearance, double floor, double centering_weight)
      : robot(r), min_clearance(clearance), min_floor(floor), data(r.model), centering(centering_weight) {
    const Model& m = r.model;
    lo.resize(m.nq());
    hi.resize(m.nq());
    for (int i = 0; i < m.nq(); ++i) {
      const double l = Lower(m.limits()[i]), u = Upper(m.limits()[i]);
      lo[i] = l + 0.1 * (u - l);  // keep 10 % of each range free for the controller
      hi[i] = u - 0.1 * (u - l);
    }
    mid = 0.5 * (lo + hi);
    half = (0.5 * (hi - lo)).cwiseMax(1e-9);
  }

  double operator()(const Eigen::VectorXd& q) const {
    for (int i = 0; i < q.size(); ++i) {
      if (q[i] < lo[i] || q[i] > hi[i]) return -std::numeric_limits<double>::infinity();
    }
    CalcForwardKinematics(robot.model, q, &data);
    if (LowestMovingCapsule(robot, data) < min_floor) return -std::numeric_limits<double>::infinity();
    if (ClosestSelfCollisionPair(robot, q).distance < min_clearance) return -std::numeric_limits<double>::infinity();
    const double w = Manipulability(robot, q);
    if (!(w > 0.0)) return -std::numeric_limits<double>::infinity();
    const double spread = ((q - mid).cwiseQuotient(half)).squaredNorm() / std::max<Eigen::Index>(q.size(), 1);
    return std::log(w) - centering * spread;
  }
};

}  // namespace

RobotSetup SetupRobot(const fs::path& urdf_path, const RobotSetupOptions& options) {
  RobotSetup setup = FitRobot(urdf_path, options);
  Robot& robot = setup.robot;
  const Model& model = robot.model;
  setup.samples = options.samples;
  if (options.home) {
    const Eigen::VectorXd& q = *options.home;
    if (q.size() != model.nq() || !q.allFinite()) {
      throw InputError(fmt::format("--home: expected {} finite joint positions ({}), got {}", model.nq(),
                                   [&] {
                                     std::string s;
                                     for (int i = 0; i < model.nq(); ++i) s += (i ? ", " : "") + model.dof_name(i);
                                     return s;
                                   }(),
                                   q.size()));
    }
    for (int i = 0; i < model.nq(); ++i) {
      if (q[i] < model.limits()[i].lower || q[i] > model.limits()[i].upper) {
        throw InputError(fmt::format("--home[{}] ({}): expected a value within [{}, {}], got {}", i, model.dof_name(i),
                                     model.limits()[i].lower, model.limits()[i].upper, q[i]));
      }
    }
  }

  // the robot's own SRDF first: sampling then judges only the pairs its authors left enabled, and the home search
  // uses its end effector
  internal::ApplySrdf(urdf_path, options, &setup);

  // sampled exclusions
  const std::vector<PairStatistics> stats = SampleSelfCollision(robot, options);
  for (const PairStatistics& p : stats) {
    const double share = static_cast<double>(p.contacts) / options.samples;
    if (share >= options.always_in_contact) {
      setup.exclusions.push_back({p.link_a, p.link_b, ExclusionReason::kAlwaysInContact, share, p.min_distance, ""});
    } else if (p.min_distance > options.warning_distance) {
      setup.exclusions.push_back({p.link_a, p.link_b, ExclusionReason::kNeverClose, share, p.min_distance, ""});
    }
  }
  for (const Exclusion& e : setup.exclusions) robot.excluded_pairs.emplace_back(e.link_a, e.link_b);
  SortUnique(&robot.excluded_pairs);

  // home: given, else the best sample by HomeScorer (clearance 2 cm, capsules above z = 5 cm; relaxed step by step
  // when nothing qualifies) among uniform and near-mid-range samples, refined by a seeded local search
  if (options.home) {
    setup.home = *options.home;
  } else {
    const Eigen::VectorXd mid = MidRange(model);
    setup.home = mid;
    bool found = false;
    for (const auto& [clearance, floor] : std::vector<std::pair<double, double>>{
             {0.02, 0.05}, {0.0, 0.0}, {0.0, -std::numeric_limits<double>::infinity()}}) {
      const HomeScorer score(robot, clearance, floor, options.home_centering);
      UniformStream u(SplitMix64(options.seed) ^ 0x686f6d65ULL);
      Eigen::VectorXd best = mid;
      double best_score = score(mid);
      const int candidates = std::max(1, std::min(options.samples, 4000));
      for (int s = 0; s < candidates; ++s) {
        // uniform samples, and as many around mid-range (Gaussian, a quarter of each half range)
        Eigen::VectorXd q = RandomConfiguration(model, u);
        if (s % 2 == 1) {
          for (int i = 0; i < q.size(); ++i) q[i] = score.mid[i] + 0.25 * score.half[i] * u.Normal();
        }
        const double v = score(q);
        if (v > best_score) {
          best_score = v;
          best = q;
        }
      }
      if (!std::isfinite(best_score)) continue;
      double step = 0.2;
      for (int it = 0; it < 600; ++it) {
        if (it % 150 == 149) step *= 0.5;
        Eigen::VectorXd q = best;
        for (int i = 0; i < q.size(); ++i) q[i] += step * score.half[i] * u.Normal();
        const double v = score(q);
        if (v > best_score) {
          best_score = v;
          best = q;
        }
      }
      setup.home = best;
      found = true;
      break;
    }
    if (!found) setup.warnings.push_back("no collision-free home posture found among the samples: using mid-range");
  }
  // pairs in contact at home are excluded (only possible with --home or when the search failed)
  for (const ClosestPair& p : SelfCollisionPairsWithin(robot, setup.home, 0.0)) {
    setup.exclusions.push_back({p.link_a, p.link_b, ExclusionReason::kContactAtHome, 0.0, p.distance, ""});
    robot.excluded_pairs.emplace_back(p.link_a, p.link_b);
  }
  SortUnique(&robot.excluded_pairs);
  setup.home_manipulability = Manipulability(robot, setup.home);
  setup.home_min_distance = ClosestSelfCollisionPair(robot, setup.home).distance;
  return setup;
}

}  // namespace rmpmarl::setup
