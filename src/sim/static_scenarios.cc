// The static scenes: a reach among obstacles drawn at rest (static-reach) and a fixed scene (a planning scene
// and request, or obstacles given in code).
#include "rmpmarl/sim/scenario.h"

#include <fmt/format.h>

#include <Eigen/SVD>
#include <algorithm>
#include <limits>

#include "rmpmarl/common/error.h"
#include "scenario_internal.h"

namespace rmpmarl::sim {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

using internal::EndEffector;
using internal::LowestMovingPoint;
using internal::MinSelfClearance;
using internal::Require;
using internal::Uniform;

}  // namespace

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

}  // namespace rmpmarl::sim
