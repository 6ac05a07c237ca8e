// Scenarios: the workspace box, the ready posture and the scenario base class (moving obstacles and target). The
// scenes: static_scenarios.cc, crossing_scenarios.cc, cluttered_scenario.cc, cells_scenario.cc; the registry of them
// by name: scenario_registry.cc.
#include "rmpmarl/sim/scenario.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "scenario_internal.h"

namespace rmpmarl::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

using internal::BaseDistance;
using internal::CutToSpawnDisc;
using internal::EndEffector;
using internal::HorizontalPath;
using internal::LowestMovingPoint;
using internal::MinSelfClearance;
using internal::Require;
using internal::SamplingRange;
using internal::CheckStart;
using internal::Uniform;

}  // namespace

namespace internal {

void CheckStart(const kinematics::Robot& robot, const Eigen::VectorXd& q, std::string_view where) {
  const kinematics::Model& m = robot.model;
  if (q.size() != m.nq() || !q.allFinite()) {
    throw InputError(fmt::format("{}: q_start: expected {} finite values (robot '{}'), got {}{}", where, m.nq(),
                                 robot.name, q.size(), q.allFinite() ? "" : " with non-finite entries"));
  }
  for (int i = 0; i < m.nq(); ++i) {
    if (q[i] < m.limits()[i].lower || q[i] > m.limits()[i].upper) {
      throw InputError(fmt::format("{}: q_start[{}] ({}): expected a value within [{}, {}], got {}", where, i,
                                   m.dof_name(i), m.limits()[i].lower, m.limits()[i].upper, q[i]));
    }
  }
}

SceneSpec CubeScene(int n, double side) {
  SceneSpec spec;
  for (int j = 0; j < n; ++j) spec.obstacles.push_back(ObstacleSpec::Cube(side));
  spec.has_target = true;
  return spec;
}

}  // namespace internal

// ---------------------------------------------------------------------------------------------------- workspace

Workspace MakeWorkspace(const kinematics::Robot& robot, const Eigen::VectorXd& q_start, const WorkspaceOptions& o) {
  Require(std::isfinite(o.near) && o.near >= 0.0 && o.near < o.far, "WorkspaceOptions.near",
          "0 <= near < far", o.near);
  Require(std::isfinite(o.far) && o.far <= 1.0, "WorkspaceOptions.far", "far <= 1 (a fraction of the reach)", o.far);
  Require(std::isfinite(o.half_width) && o.half_width >= 0.0, "WorkspaceOptions.half_width", ">= 0", o.half_width);
  Require(std::isfinite(o.half_height) && o.half_height >= 0.0, "WorkspaceOptions.half_height", ">= 0",
          o.half_height);
  Require(std::isfinite(o.min_height), "WorkspaceOptions.min_height", "a finite height", o.min_height);
  Require(o.samples >= 1, "WorkspaceOptions.samples", ">= 1", o.samples);
  const kinematics::Model& m = robot.model;
  kinematics::Data data(m);
  Workspace w;
  kinematics::CalcForwardKinematics(m, Eigen::VectorXd::Zero(m.nq()), &data);
  const int shoulder_dof = std::min(1, m.nq() - 1);
  w.p_WS = Eigen::Vector3d(0.0, 0.0, data.X_WL[m.dof_link(shoulder_dof)].translation().z());
  std::mt19937_64 rng(0x5eedc0ffee);  // fixed: the workspace is a property of the robot
  Eigen::VectorXd q(m.nq());
  double z_lo = kInf, z_hi = -kInf;
  for (int s = 0; s < o.samples; ++s) {
    for (int i = 0; i < m.nq(); ++i) {
      const auto [lo, hi] = SamplingRange(m.limits()[i]);
      q[i] = Uniform(rng, lo, hi);
    }
    kinematics::CalcForwardKinematics(m, q, &data);
    const Eigen::Vector3d p = EndEffector(robot, data);
    w.reach = std::max(w.reach, (p - w.p_WS).norm());
    w.horizontal_reach = std::max(w.horizontal_reach, p.head<2>().norm());
    z_lo = std::min(z_lo, p.z());
    z_hi = std::max(z_hi, p.z());
  }
  w.planar = z_hi - z_lo < 1e-9;
  CheckStart(robot, q_start, "MakeWorkspace");
  kinematics::CalcForwardKinematics(m, q_start, &data);
  const Eigen::Vector3d p_E0 = EndEffector(robot, data);
  if (std::abs(p_E0.y()) > std::abs(p_E0.x())) {
    w.front = Eigen::Vector3d(0.0, p_E0.y() > 0.0 ? 1.0 : -1.0, 0.0);
  } else {
    w.front = Eigen::Vector3d(p_E0.x() >= 0.0 ? 1.0 : -1.0, 0.0, 0.0);
  }
  const double R = w.reach;
  // corners in the front frame (x forward, y lateral), then rotated: a quarter turn keeps the box axis-aligned
  const Eigen::Vector2d a = o.near * R * w.front.head<2>() - o.half_width * R * w.lateral().head<2>();
  const Eigen::Vector2d b = o.far * R * w.front.head<2>() + o.half_width * R * w.lateral().head<2>();
  Eigen::Vector3d lo(std::min(a.x(), b.x()), std::min(a.y(), b.y()), 0.0);
  Eigen::Vector3d hi(std::max(a.x(), b.x()), std::max(a.y(), b.y()), 0.0);
  if (w.planar) {
    lo.z() = hi.z() = z_lo;
  } else {
    hi.z() = w.p_WS.z() + o.half_height * R;
    lo.z() = std::min(hi.z(), std::max(w.p_WS.z() - o.half_height * R, o.min_height));
  }
  w.box = Eigen::AlignedBox3d(lo, hi);
  return w;
}

Eigen::VectorXd ReadyConfiguration(const kinematics::Robot& robot) {
  const kinematics::Model& m = robot.model;
  const std::filesystem::path path = rmp::RmpflowConfigPath(robot);
  const rmp::RmpflowOptions options = rmp::LoadRmpflowOptions(robot);
  Eigen::VectorXd q(m.nq());
  if (!options.home.empty()) {
    if (static_cast<int>(options.home.size()) != m.nq()) {
      throw InputError(fmt::format("{}: home: expected {} values for robot '{}', got {}", path.string(), m.nq(),
                                   robot.name, options.home.size()));
    }
    for (int i = 0; i < m.nq(); ++i) q[i] = options.home[i];
    CheckStart(robot, q, path.string() + ": home");
    return q;
  }
  for (int i = 0; i < m.nq(); ++i) {
    const auto& l = m.limits()[i];
    q[i] = std::isfinite(l.lower) && std::isfinite(l.upper) ? 0.5 * (l.lower + l.upper) : 0.0;
  }
  return q;
}

// ----------------------------------------------------------------------------------------------------- scenario

Scenario::Scenario(std::string name, const kinematics::Robot& robot, SceneSpec spec, double default_duration,
                   const WorkspaceOptions& workspace, const Eigen::VectorXd& q_start)
    : name_(std::move(name)),
      robot_(robot),
      checker_(robot_),
      spec_(std::move(spec)),
      default_duration_(default_duration),
      q_start_(q_start.size() == 0 ? ReadyConfiguration(robot) : q_start) {
  CheckStart(robot_, q_start_, "scenario '" + name_ + "'");
  workspace_ = MakeWorkspace(robot_, q_start_, workspace);
  obstacles_.resize(spec_.obstacles.size());
}

SceneSource::~SceneSource() = default;

Scenario::~Scenario() = default;

void Scenario::OnPathEnd(int j, std::mt19937_64& /*rng*/) {
  ObstacleState& o = obstacles_[j];
  o.s = o.path_length;
  o.speed = 0.0;
}

void Scenario::Reset(std::uint64_t seed, World& world) {
  const WorldModel& wm = world.model();
  const std::string where = fmt::format("scenario '{}': Reset", name_);
  if (wm.robot().name != robot_.name || wm.nq() != robot_.model.nq()) {
    throw InputError(fmt::format("{}: expected a world of robot '{}' ({} joints), got '{}' ({} joints)", where,
                                 robot_.name, robot_.model.nq(), wm.robot().name, wm.nq()));
  }
  if (wm.num_obstacles() != num_obstacles()) {
    throw InputError(fmt::format("{}: expected a world built from scene_spec() with {} obstacles, got {}", where,
                                 num_obstacles(), wm.num_obstacles()));
  }
  for (int j = 0; j < num_obstacles(); ++j) {
    const ObstacleSpec& a = spec_.obstacles[j];
    const ObstacleSpec& b = wm.scene().obstacles[j];
    const bool same = a.shape == b.shape && (a.shape == ObstacleShape::kBox ? a.half_size.isApprox(b.half_size, 1e-12)
                                                                           : std::abs(a.radius - b.radius) < 1e-12) &&
                      (a.shape != ObstacleShape::kCylinder || std::abs(a.half_length - b.half_length) < 1e-12);
    if (!same) {
      throw InputError(fmt::format("{}: obstacle {}: expected the shape and size of scene_spec(), got a different "
                                   "one (build the WorldModel from Scenario::scene_spec())", where, j));
    }
  }
  if (spec_.has_target && wm.target_mocap() < 0) {
    throw InputError(fmt::format("{}: expected a world with a target marker (SceneSpec.has_target), got none", where));
  }
  rng_.seed(seed);
  time_ = 0.0;
  target_ = TargetState{};
  target_.bounds = workspace_.box;
  std::fill(obstacles_.begin(), obstacles_.end(), ObstacleState{});
  Draw(rng_);
  world.Reset(q_start_);
  for (int j = 0; j < num_obstacles(); ++j) world.SetObstaclePose(j, obstacles_[j].p_WO(), obstacles_[j].R_WO);
  if (spec_.has_target) world.SetTargetPosition(target_.p_WT);
}

void Scenario::Advance(double dt, const ContactReport& contacts, World& world) {
  // impacts of the current state first: a colliding obstacle stays where it hit
  for (const CollidingPair& pair : contacts.colliding_pairs) {
    if (pair.other_kind != PartnerKind::kObstacle) continue;
    if (pair.other_index < 0 || pair.other_index >= num_obstacles()) continue;
    ObstacleState& o = obstacles_[pair.other_index];
    if (o.stop_on_impact && !o.stopped) {
      o.stopped = true;
      o.stop_time = world.time();
    }
  }
  time_ += dt;
  for (int j = 0; j < num_obstacles(); ++j) {
    ObstacleState& o = obstacles_[j];
    if (o.stopped || o.speed <= 0.0) continue;
    o.s += o.speed * dt;
    if (o.s > o.path_length) {
      if (o.wrap > 0.0) {
        o.s -= o.wrap;
        ++o.paths;
      } else {
        OnPathEnd(j, rng_);
      }
    }
    world.SetObstaclePose(j, o.p_WO(), o.R_WO);
  }
  if (spec_.has_target && !target_.v_WT.isZero(0.0)) {
    target_.p_WT += dt * target_.v_WT;
    const Eigen::Vector3d lo = target_.bounds.min(), hi = target_.bounds.max();
    for (int a = 0; a < 3; ++a) {
      if (!(hi[a] > lo[a])) {
        target_.p_WT[a] = lo[a];
        target_.v_WT[a] = 0.0;
        continue;
      }
      if (target_.p_WT[a] > hi[a]) {
        target_.p_WT[a] = 2.0 * hi[a] - target_.p_WT[a];
        target_.v_WT[a] = -std::abs(target_.v_WT[a]);
      } else if (target_.p_WT[a] < lo[a]) {
        target_.p_WT[a] = 2.0 * lo[a] - target_.p_WT[a];
        target_.v_WT[a] = std::abs(target_.v_WT[a]);
      }
      target_.p_WT[a] = std::clamp(target_.p_WT[a], lo[a], hi[a]);  // a step longer than the box
    }
    world.SetTargetPosition(target_.p_WT);
  }
}

rmp::Obstacle Scenario::ObstacleAsRmp(int j) const {
  const ObstacleSpec& spec = spec_.obstacles[j];
  const ObstacleState& o = obstacles_[j];
  Eigen::Isometry3d X_WO = Eigen::Isometry3d::Identity();
  X_WO.linear() = o.R_WO;
  X_WO.translation() = o.p_WO();
  return spec.AsRmp(X_WO, o.v_WO());
}

void Scenario::FillScene(rmp::Scene* scene) const {
  scene->obstacles.resize(obstacles_.size());
  for (int j = 0; j < num_obstacles(); ++j) scene->obstacles[j] = ObstacleAsRmp(j);
  scene->has_target = spec_.has_target;
  scene->p_WT = target_.p_WT;
  scene->v_WT = target_.v_WT;
  scene->q_T = joint_goal_;
}

Eigen::Vector3d Scenario::RandomDirection(std::mt19937_64& rng) const {
  if (workspace_.planar) {
    const double a = Uniform(rng, 0.0, 2.0 * M_PI);
    return {std::cos(a), std::sin(a), 0.0};
  }
  std::normal_distribution<double> n(0.0, 1.0);
  for (;;) {
    const Eigen::Vector3d v(n(rng), n(rng), n(rng));
    if (v.norm() > 1e-9) return v.normalized();
  }
}

Eigen::Vector3d Scenario::RandomWorkspacePoint(std::mt19937_64& rng) const {
  Eigen::Vector3d p;
  for (int a = 0; a < 3; ++a) {
    const double lo = workspace_.box.min()[a], hi = workspace_.box.max()[a];
    p[a] = hi > lo ? Uniform(rng, lo, hi) : lo;
  }
  return p;
}

TargetState Scenario::RandomMovingTarget(double speed, std::mt19937_64& rng) const {
  TargetState t;
  t.bounds = workspace_.box;
  t.p_WT = RandomWorkspacePoint(rng);
  t.v_WT = speed * RandomDirection(rng);
  return t;
}

double Scenario::RobotClearance(const Eigen::VectorXd& q, int j, const Eigen::Vector3d& p_WO) const {
  kinematics::Data data(robot_.model);
  kinematics::CalcForwardKinematics(robot_.model, q, &data);
  const ObstacleSpec& spec = spec_.obstacles[j];
  Eigen::Isometry3d X_WO = Eigen::Isometry3d::Identity();
  X_WO.linear() = obstacles_[j].R_WO;
  X_WO.translation() = p_WO;
  return RobotClearance(data, spec.AsRmp(X_WO));
}

double Scenario::RobotClearance(const kinematics::Data& at, const rmp::Obstacle& obstacle) const {
  collision::RobotCollisionData placed(checker_);
  collision::PlaceRobot(checker_, at, &placed);
  return collision::CalcObstacleClearance(checker_, placed, obstacle);
}

Eigen::Vector3d Scenario::EndEffectorAt(const Eigen::VectorXd& q) const {
  kinematics::Data data(robot_.model);
  kinematics::CalcForwardKinematics(robot_.model, q, &data);
  return EndEffector(robot_, data);
}

}  // namespace rmpmarl::sim
