// Scenarios: workspace box, moving target, crossing / line-crossing / cluttered / static obstacles (the registry
// of them by name: scenario_registry.cc).
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
using internal::Uniform;

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

}  // namespace

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

// ------------------------------------------------------------------------------------------------- static-reach

namespace {
SceneSpec StaticReachScene(const StaticReachOptions& o) {
  SceneSpec spec;
  if (o.obstacle_on_path) {
    spec.obstacles.push_back(o.obstacle);
    spec.obstacles.back().X_WO = ParkedPose();
  }
  return spec;
}
}  // namespace

StaticReachScenario::StaticReachScenario(const kinematics::Robot& robot, const StaticReachOptions& options)
    : Scenario(options.obstacle_on_path ? "static-obstacle" : "static-reach", robot, StaticReachScene(options), 6.0,
               options.workspace, options.q_start),
      options_(options) {
  const std::string w = "StaticReachOptions";
  Require(std::isfinite(options.joint_spread) && options.joint_spread >= 0.0, w + ".joint_spread", ">= 0",
          options.joint_spread);
  Require(std::isfinite(options.limit_margin) && options.limit_margin >= 0.0, w + ".limit_margin", ">= 0",
          options.limit_margin);
  Require(std::isfinite(options.min_distance) && options.min_distance >= 0.0, w + ".min_distance", ">= 0",
          options.min_distance);
  Require(std::isfinite(options.min_singular_value) && options.min_singular_value >= 0.0,
          w + ".min_singular_value", ">= 0", options.min_singular_value);
  Require(std::isfinite(options.min_self_clearance), w + ".min_self_clearance", "a finite distance",
          options.min_self_clearance);
  Require(std::isfinite(options.min_height), w + ".min_height", "a finite height", options.min_height);
  Require(std::isfinite(options.obstacle_clearance), w + ".obstacle_clearance", "a finite distance",
          options.obstacle_clearance);
  Require(options.max_attempts >= 1, w + ".max_attempts", ">= 1", options.max_attempts);
  CheckWorldInputs(robot, spec_, WorldOptions{});
  q_goal_ = q_start_;
}

void StaticReachScenario::Draw(std::mt19937_64& rng) {
  const kinematics::Model& m = robot_.model;
  kinematics::Data data(m);
  const Eigen::Vector3d p_start = EndEffectorAt(q_start_);
  Eigen::Matrix3Xd J(3, m.nq());
  Eigen::VectorXd q(m.nq());
  for (int attempt = 0; attempt < options_.max_attempts; ++attempt) {
    for (int i = 0; i < m.nq(); ++i) {
      const auto& l = m.limits()[i];
      q[i] = q_start_[i] + Uniform(rng, -options_.joint_spread, options_.joint_spread);
      const double lo = std::isfinite(l.lower) ? l.lower + options_.limit_margin : -kInf;
      const double hi = std::isfinite(l.upper) ? l.upper - options_.limit_margin : kInf;
      q[i] = lo <= hi ? std::clamp(q[i], lo, hi) : 0.5 * (l.lower + l.upper);
    }
    kinematics::CalcForwardKinematics(m, q, &data);
    const Eigen::Vector3d p = EndEffector(robot_, data);
    if ((p - p_start).norm() < options_.min_distance) continue;
    kinematics::CalcPointJacobian(m, data, robot_.end_effector.link, robot_.end_effector.X_LE.translation(), J);
    // planar arms: the z row is zero, judge the in-plane singular values only
    const Eigen::MatrixXd J_used = workspace_.planar ? Eigen::MatrixXd(J.topRows(2)) : Eigen::MatrixXd(J);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(J_used);
    if (svd.singularValues().minCoeff() < options_.min_singular_value) continue;
    if (MinSelfClearance(checker_, data) < options_.min_self_clearance) continue;
    if (!workspace_.planar && LowestMovingPoint(robot_, data) < options_.min_height) continue;
    if (options_.obstacle_on_path) {
      const Eigen::Vector3d mid = 0.5 * (p_start + p);
      if (RobotClearance(q_start_, 0, mid) < options_.obstacle_clearance) continue;
      if (RobotClearance(q, 0, mid) < options_.obstacle_clearance) continue;
      obstacles_[0].p_start = mid;
    }
    q_goal_ = q;
    target_.p_WT = p;
    target_.v_WT.setZero();
    return;
  }
  throw InputError(fmt::format("scenario '{}' (robot '{}'): found no target satisfying StaticReachOptions in {} "
                               "draws; expected looser options", name_, robot_.name, options_.max_attempts));
}

// ------------------------------------------------------------------------------------------------------- static

namespace {
SceneSpec StaticScene(const StaticSceneOptions& o) {
  SceneSpec spec;
  spec.obstacles = o.obstacles;
  for (const LinearMotion& m : o.moving) spec.obstacles.push_back(m.spec);
  return spec;
}
}  // namespace

StaticSceneOptions StaticSceneOf(const kinematics::Robot& robot, const planning::PlanningScene& scene,
                                 const planning::MotionPlanRequest* request, std::string_view source) {
  StaticSceneOptions o;
  o.q_start = ReadyConfiguration(robot);
  Eigen::VectorXd q_target = o.q_start;
  if (request != nullptr) {
    o.q_start = planning::JointVector(robot, request->start, fmt::format("{}: start_state", source));
    o.q_goal = planning::JointVector(robot, request->goal.joints, fmt::format("{}: goal_constraints", source));
    q_target = o.q_goal;
  }
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q_target, &data);
  o.p_WT = kinematics::CalcPointPosition(data, robot.end_effector.link, robot.end_effector.X_LE.translation());
  for (const rmp::Obstacle& obstacle : scene.Obstacles()) o.obstacles.push_back(ObstacleSpec::Of(obstacle));
  return o;
}

StaticScenario::StaticScenario(const kinematics::Robot& robot, const StaticSceneOptions& options)
    : Scenario("static", robot, StaticScene(options), 6.0, WorkspaceOptions{}, options.q_start), options_(options) {
  if (!options.p_WT.allFinite()) throw InputError("StaticSceneOptions.p_WT: expected a finite position");
  if (options.q_goal.size() > 0) kinematics::CheckJointVector(robot.model, options.q_goal, "StaticSceneOptions.q_goal");
  for (size_t k = 0; k < options.moving.size(); ++k) {
    if (!options.moving[k].p_W0.allFinite() || !options.moving[k].v_W.allFinite()) {
      throw InputError(fmt::format("StaticSceneOptions.moving[{}]: expected a finite start and velocity", k));
    }
  }
  CheckWorldInputs(robot, spec_, WorldOptions{});
}

void StaticScenario::Draw(std::mt19937_64& /*rng*/) {
  target_.p_WT = options_.p_WT;
  target_.v_WT.setZero();
  joint_goal_ = options_.q_goal;
  const int fixed = static_cast<int>(options_.obstacles.size());
  for (int j = 0; j < fixed; ++j) {
    obstacles_[j].p_start = options_.obstacles[j].X_WO.translation();
    obstacles_[j].R_WO = options_.obstacles[j].X_WO.linear();
  }
  for (int j = fixed; j < num_obstacles(); ++j) {
    const LinearMotion& m = options_.moving[j - fixed];
    ObstacleState& o = obstacles_[j];
    o = ObstacleState{};
    o.p_start = m.p_W0;
    o.R_WO = m.spec.X_WO.linear();
    o.speed = m.v_W.norm();
    o.direction = o.speed > 0.0 ? Eigen::Vector3d(m.v_W / o.speed) : Eigen::Vector3d::UnitX();
    o.path_length = std::numeric_limits<double>::infinity();  // on its line for the whole episode
  }
}

// ----------------------------------------------------------------------------------------------------- crossing

CrossingScenario::CrossingScenario(const kinematics::Robot& robot, const CrossingOptions& options)
    : Scenario("crossing", robot, CubeScene(std::max(0, options.num_obstacles), options.obstacle_side), 10.0,
               options.workspace, options.q_start),
      options_(options) {
  const std::string w = "CrossingOptions";
  Require(options.num_obstacles >= 0, w + ".num_obstacles", ">= 0", options.num_obstacles);
  Require(std::isfinite(options.obstacle_side) && options.obstacle_side > 0.0, w + ".obstacle_side", "> 0",
          options.obstacle_side);
  Require(std::isfinite(options.obstacle_speed) && options.obstacle_speed >= 0.0, w + ".obstacle_speed", ">= 0",
          options.obstacle_speed);
  Require(std::isfinite(options.obstacle_speed_max) && options.obstacle_speed_max >= 0.0,
          w + ".obstacle_speed_max", ">= 0", options.obstacle_speed_max);
  Require(std::isfinite(options.target_speed) && options.target_speed >= 0.0, w + ".target_speed", ">= 0",
          options.target_speed);
  Require(std::isfinite(options.min_base_distance) && options.min_base_distance >= 0.0,
          w + ".min_base_distance", ">= 0", options.min_base_distance);
  Require(std::isfinite(options.spawn_margin) && options.spawn_margin >= 0.0, w + ".spawn_margin", ">= 0",
          options.spawn_margin);
}

void Scenario::DrawHorizontalCrossing(int j, const HorizontalCrossing& c, std::mt19937_64& rng) {
  ObstacleState& o = obstacles_[j];
  const double r_spawn = workspace_.horizontal_reach + c.spawn_margin;
  for (int attempt = 0; attempt < 10000; ++attempt) {
    const Eigen::Vector3d P = RandomWorkspacePoint(rng);
    const double yaw = Uniform(rng, 0.0, 2.0 * M_PI);
    const Eigen::Vector3d d(std::cos(yaw), std::sin(yaw), 0.0);
    if (BaseDistance(P, d) < c.min_base_distance) continue;
    const HorizontalPath path = CutToSpawnDisc(P, d, r_spawn);
    o.p_start = path.p_start;
    o.direction = d;
    o.path_length = path.length;
    // a speed is drawn only for a range, so fixed-speed scenes keep their random streams
    o.speed = c.speed_max > c.speed ? Uniform(rng, c.speed, c.speed_max) : c.speed;
    o.s = 0.0;
    o.wrap = 0.0;
    return;
  }
  throw InputError(fmt::format("scenario '{}' (robot '{}'): no path passes {} m from the base through the workspace; "
                               "expected a smaller {}", name_, robot_.name, c.min_base_distance,
                               c.min_base_distance_key));
}

void CrossingScenario::DrawPath(int j, std::mt19937_64& rng) {
  DrawHorizontalCrossing(j,
                         {options_.min_base_distance, options_.spawn_margin, options_.obstacle_speed,
                          options_.obstacle_speed_max, "CrossingOptions.min_base_distance"},
                         rng);
}

void CrossingScenario::Draw(std::mt19937_64& rng) {
  target_ = RandomMovingTarget(options_.target_speed, rng);
  for (int j = 0; j < num_obstacles(); ++j) {
    DrawPath(j, rng);
    // staggered arrivals: start up to half a path length before the spawn circle
    obstacles_[j].s = -Uniform(rng, 0.0, 0.5) * obstacles_[j].path_length;
  }
}

void CrossingScenario::OnPathEnd(int j, std::mt19937_64& rng) {
  const int paths = obstacles_[j].paths;
  DrawPath(j, rng);
  obstacles_[j].paths = paths + 1;
}

// ------------------------------------------------------------------------------------------------ line-crossing

namespace {
double LineDuration(const Workspace& w, const LineCrossingOptions& o) {
  const double path = 2.0 * (w.horizontal_reach + o.spawn_margin);
  const bool along = o.arrangement == LineArrangement::kAlongMotion;
  const double train = along ? std::max(0, o.num_obstacles - 1) * o.spacing : 0.0;
  const double pass = (path + train) / std::max(o.speed, 1e-3);
  return std::clamp(pass, 5.0, 60.0);
}
}  // namespace

LineCrossingScenario::LineCrossingScenario(const kinematics::Robot& robot, const LineCrossingOptions& options)
    : Scenario("line-crossing", robot, CubeScene(std::max(0, options.num_obstacles), options.obstacle_side), 10.0,
               options.workspace, options.q_start),
      options_(options) {
  const std::string w = "LineCrossingOptions";
  Require(options.num_obstacles >= 1, w + ".num_obstacles", ">= 1", options.num_obstacles);
  Require(std::isfinite(options.obstacle_side) && options.obstacle_side > 0.0, w + ".obstacle_side", "> 0",
          options.obstacle_side);
  Require(std::isfinite(options.spacing) && options.spacing > 0.0, w + ".spacing", "> 0", options.spacing);
  Require(std::isfinite(options.speed) && options.speed > 0.0, w + ".speed", "> 0 m/s", options.speed);
  Require(std::isfinite(options.target_speed) && options.target_speed >= 0.0, w + ".target_speed", ">= 0",
          options.target_speed);
  Require(std::isfinite(options.max_yaw_deg) && options.max_yaw_deg >= 0.0 && options.max_yaw_deg <= 90.0,
          w + ".max_yaw_deg", "a value in [0, 90]", options.max_yaw_deg);
  Require(std::isfinite(options.min_base_distance) && options.min_base_distance >= 0.0,
          w + ".min_base_distance", ">= 0", options.min_base_distance);
  Require(std::isfinite(options.spawn_margin) && options.spawn_margin >= 0.0, w + ".spawn_margin", ">= 0",
          options.spawn_margin);
  if (options.through && !options.through->allFinite()) {
    throw InputError("LineCrossingOptions.through: expected a finite point, got non-finite entries");
  }
  default_duration_ = LineDuration(workspace_, options);
}

void LineCrossingScenario::Draw(std::mt19937_64& rng) {
  target_ = RandomMovingTarget(options_.target_speed, rng);
  const double r_spawn = workspace_.horizontal_reach + options_.spawn_margin;
  const double max_yaw = options_.max_yaw_deg * M_PI / 180.0;
  for (int attempt = 0; attempt < 10000; ++attempt) {
    const Eigen::Vector3d P = options_.through ? *options_.through : RandomWorkspacePoint(rng);
    const double sign = std::bernoulli_distribution(0.5)(rng) ? 1.0 : -1.0;
    const double yaw = Uniform(rng, -max_yaw, max_yaw);
    // sideways (± lateral) turned by yaw about z
    const Eigen::Vector3d d = sign * (std::cos(yaw) * workspace_.lateral() + std::sin(yaw) * workspace_.front);
    if (BaseDistance(P, d) < options_.min_base_distance) continue;
    const HorizontalPath path = CutToSpawnDisc(P, d, std::max(r_spawn, P.head<2>().norm() + options_.spawn_margin));
    const int n = num_obstacles();
    const bool along = options_.arrangement == LineArrangement::kAlongMotion;
    const Eigen::Vector3d across(-d.y(), d.x(), 0.0);
    for (int j = 0; j < n; ++j) {
      ObstacleState& o = obstacles_[j];
      o.direction = d;
      o.path_length = path.length;
      o.speed = options_.speed;
      if (along) {
        o.p_start = path.p_start;
        o.s = -j * options_.spacing;  // one behind the other, the first at the start of the path
        o.wrap = options_.repeat ? std::max(n * options_.spacing, path.length + options_.spacing) : 0.0;
      } else {
        // side by side, centred on the line; the shifted starts lie even further from the base axis
        o.p_start = path.p_start + (j - 0.5 * (n - 1)) * options_.spacing * across;
        o.s = 0.0;
        o.wrap = options_.repeat ? path.length + options_.spacing : 0.0;
      }
      o.stop_on_impact = options_.stop_on_impact;
    }
    return;
  }
  throw InputError(fmt::format("scenario 'line-crossing' (robot '{}'): no line passes {} m from the base; expected a "
                               "smaller LineCrossingOptions.min_base_distance or another `through` point",
                               robot_.name, options_.min_base_distance));
}

// ---------------------------------------------------------------------------------------------------- cluttered

ClutteredScenario::ClutteredScenario(const kinematics::Robot& robot, const ClutteredOptions& options)
    : Scenario("cluttered", robot, CubeScene(std::max(0, options.num_obstacles), options.obstacle_side), 10.0,
               options.workspace, options.q_start),
      options_(options) {
  const std::string w = "ClutteredOptions";
  Require(options.num_obstacles >= 0, w + ".num_obstacles", ">= 0", options.num_obstacles);
  Require(std::isfinite(options.obstacle_side) && options.obstacle_side > 0.0, w + ".obstacle_side", "> 0",
          options.obstacle_side);
  Require(std::isfinite(options.min_distance) && options.min_distance >= 0.0, w + ".min_distance", ">= 0",
          options.min_distance);
  Require(std::isfinite(options.max_distance) && options.max_distance >= options.min_distance,
          w + ".max_distance", ">= min_distance", options.max_distance);
  Require(std::isfinite(options.target_speed) && options.target_speed >= 0.0, w + ".target_speed", ">= 0",
          options.target_speed);
  Require(std::isfinite(options.start_clearance), w + ".start_clearance", "a finite distance",
          options.start_clearance);
  Require(std::isfinite(options.target_clearance), w + ".target_clearance", "a finite distance",
          options.target_clearance);
  Require(options.max_attempts >= 1, w + ".max_attempts", ">= 1", options.max_attempts);
}

void ClutteredScenario::Draw(std::mt19937_64& rng) {
  target_ = RandomMovingTarget(options_.target_speed, rng);
  const Eigen::Vector3d p_E0 = EndEffectorAt(q_start_);
  const double half = 0.5 * options_.obstacle_side;
  const double bounding = half * std::sqrt(3.0);
  for (int j = 0; j < num_obstacles(); ++j) {
    bool placed = false;
    for (int attempt = 0; attempt < options_.max_attempts && !placed; ++attempt) {
      const Eigen::Vector3d c =
          p_E0 + Uniform(rng, options_.min_distance, options_.max_distance) * RandomDirection(rng);
      if (!workspace_.planar && c.z() - half < 0.0) continue;  // below the base plane
      if ((c - target_.p_WT).norm() - bounding < options_.target_clearance) continue;
      bool overlaps = false;
      for (int k = 0; k < j && !overlaps; ++k) overlaps = (c - obstacles_[k].p_start).norm() < 2.0 * bounding;
      if (overlaps) continue;
      if (RobotClearance(q_start_, j, c) < options_.start_clearance) continue;
      obstacles_[j].p_start = c;
      placed = true;
    }
    if (!placed) {
      throw InputError(fmt::format("scenario 'cluttered' (robot '{}'): could not place obstacle {} in {} draws; "
                                   "expected fewer or smaller obstacles", robot_.name, j, options_.max_attempts));
    }
  }
}

}  // namespace rmpmarl::sim
