// The paper's RRT baseline (IEEE Access 2023, section IV.B–C): its options and the replanning policy — the DLS IK goal
// (rrt_ik.cc), RRT-Connect and shortcutting (rrt_search.cc), constant-velocity timing (path_timing.cc) and joint-space
// PD tracking; replanning at a fixed rate and on invalidation.
#include "rmpmarl/planning/rrt.h"

#include <fmt/format.h>
#include <ompl/util/Console.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string_view>
#include <utility>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"
#include "rrt_impl.h"

namespace rmpmarl::planning {
namespace {

using rrt_internal::kInf;
constexpr double kTimeEpsilon = 1e-9;  // [s] slack of the evaluated-time comparisons (calls × period)
constexpr int kStatsCapacity = 4096;   // planning_times_s entries reserved up front

// throws InputError "RrtOptions.<field>: expected <expected>, got <got>" unless ok (and got is a number).
void Require(bool ok, std::string_view field, std::string_view expected, double got) {
  if (!ok || std::isnan(got)) throw InputError(fmt::format("RrtOptions.{}: expected {}, got {}", field, expected, got));
}


bool SameObstacle(const rmp::Obstacle& a, const rmp::Obstacle& b) {
  if (a.shape != b.shape) return false;
  if (a.shape == rmp::ObstacleShape::kSphere) {
    return a.sphere.p_WC == b.sphere.p_WC && a.sphere.radius == b.sphere.radius;
  }
  // a point set's index is rebuilt in place by its owner: never the same obstacle twice
  if (a.shape == rmp::ObstacleShape::kPoints) return false;
  if (a.shape == rmp::ObstacleShape::kCylinder) {
    return a.cylinder.X_WC.matrix() == b.cylinder.X_WC.matrix() && a.cylinder.radius == b.cylinder.radius &&
           a.cylinder.half_length == b.cylinder.half_length;
  }
  return a.box.X_WB.matrix() == b.box.X_WB.matrix() && a.box.half_size == b.box.half_size;
}

}  // namespace

void ValidateRrtOptions(const RrtOptions& o) {
  auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  Require(positive(o.evaluation_period), "evaluation_period", "a finite period > 0 s", o.evaluation_period);
  Require(positive(o.replan_period), "replan_period", "a finite period > 0 s", o.replan_period);
  Require(std::isfinite(o.retry_period) && o.retry_period >= 0.0, "retry_period", "a finite period >= 0 s",
          o.retry_period);
  Require(positive(o.planning_time_budget), "planning_time_budget", "a finite budget > 0 s", o.planning_time_budget);
  Require(o.planning_iterations >= 0, "planning_iterations", "an integer >= 0 (0: no limit)", o.planning_iterations);
  Require(o.ik_seeds >= 1, "ik_seeds", "an integer >= 1", o.ik_seeds);
  Require(o.ik_iterations >= 1, "ik_iterations", "an integer >= 1", o.ik_iterations);
  Require(positive(o.ik_damping), "ik_damping", "a finite damping > 0 m", o.ik_damping);
  Require(positive(o.ik_max_step), "ik_max_step", "a finite step > 0", o.ik_max_step);
  Require(positive(o.ik_tolerance), "ik_tolerance", "a finite tolerance > 0 m", o.ik_tolerance);
  Require(std::isfinite(o.floor_height), "floor_height", "a finite height", o.floor_height);
  Require(std::isfinite(o.safety_margin) && o.safety_margin >= 0.0, "safety_margin", "a finite margin >= 0 m",
          o.safety_margin);
  Require(positive(o.validity_resolution), "validity_resolution", "a finite step > 0", o.validity_resolution);
  Require(std::isfinite(o.range) && o.range >= 0.0, "range", "a finite extension >= 0 (0: OMPL's own)", o.range);
  Require(std::isfinite(o.end_margin_distance) && o.end_margin_distance >= 0.0, "end_margin_distance",
          "a finite distance >= 0 (0: the whole path)", o.end_margin_distance);
  Require(o.shortcut_iterations >= 0 && o.shortcut_iterations <= 1000000, "shortcut_iterations",
          "an integer in [0, 1e6]", o.shortcut_iterations);
  Require(positive(o.path_speed_fraction) && o.path_speed_fraction <= 1.0, "path_speed_fraction",
          "a fraction in (0, 1]", o.path_speed_fraction);
  Require(positive(o.kp), "kp", "a finite gain > 0", o.kp);
  Require(positive(o.kd), "kd", "a finite gain > 0", o.kd);
}

void RrtPolicy::Impl::SetBounds(const Eigen::Ref<const Eigen::VectorXd>& q) {
  for (int i = 0; i < nq; ++i) {
    lower[i] = continuous[i] ? q[i] - M_PI : limit_lower[i];
    upper[i] = continuous[i] ? q[i] + M_PI : limit_upper[i];
  }
}

bool RrtPolicy::Impl::ObstaclesChanged(const rmp::Scene& scene) const {
  if (scene.obstacles.size() != obstacles.size()) return true;
  for (size_t j = 0; j < obstacles.size(); ++j) {
    if (!SameObstacle(scene.obstacles[j], obstacles[j])) return true;
  }
  return false;
}

void RrtPolicy::Impl::Adopt(std::vector<Eigen::VectorXd> waypoints, const Eigen::Vector3d& p_WE_goal) {
  path = std::move(waypoints);
  path_times = PathArrivalTimes(path, v_path);
  path_p_WE = p_WE_goal;
  path_margin = margin;
  path_start_time = time;
  segment = 0;
  previous_goal = path.back();
  has_previous_goal = true;
}

void RrtPolicy::Impl::Reference(double tau) {
  const int last = static_cast<int>(path.size()) - 1;
  while (segment < last && tau >= path_times[segment + 1]) ++segment;
  if (segment >= last) {
    q_d = path[last];
    qd_d.setZero();
    return;
  }
  const double duration = path_times[segment + 1] - path_times[segment];
  const double s = std::clamp((tau - path_times[segment]) / duration, 0.0, 1.0);
  q_d = path[segment] + s * (path[segment + 1] - path[segment]);
  qd_d = (path[segment + 1] - path[segment]) / duration;
}

double RrtPolicy::Impl::RemainingLength(const Eigen::Ref<const Eigen::VectorXd>& q) {
  Reference(time - path_start_time);
  double length = (q_d - q).norm();
  if (segment + 1 < static_cast<int>(path.size())) {
    length += (path[segment + 1] - q_d).norm();
    for (size_t k = segment + 2; k < path.size(); ++k) length += (path[k] - path[k - 1]).norm();
  }
  return length;
}

bool RrtPolicy::Impl::RemainingPathValid(const Eigen::Ref<const Eigen::VectorXd>& q) {
  margin = path_margin;
  Reference(time - path_start_time);
  q_now = q;
  if (!CollisionFree(q_now, /*obstacles_only=*/true)) return false;
  if (!SegmentValid(q_now, q_d, true)) return false;
  const Eigen::VectorXd* from = &q_d;
  for (size_t k = segment + 1; k < path.size(); ++k) {
    if (!SegmentValid(*from, path[k], true)) return false;
    from = &path[k];
  }
  return true;
}

void RrtPolicy::Impl::Replan(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene) {
  const auto t0 = std::chrono::steady_clock::now();
  ++stats.plans_attempted;
  attempted = true;
  last_attempt = time;
  SetObstacles(scene);
  const Eigen::VectorXd q_start = q;
  // from a start inside the safety margin (an obstacle came close) plan with half its clearance as the margin, so the
  // robot can still move away; in penetration there is nothing valid to start from
  margin = options.safety_margin;
  SetBounds(q_start);
  const double start_clearance = Clearance(q_start, false, -kInf);
  if (start_clearance <= options.safety_margin) margin = 0.5 * start_clearance;
  std::vector<Eigen::VectorXd> waypoints;
  IkResult ik;
  if (margin > 0.0) {
    ik = SolveIk(q_start, scene.p_WT);
    if (!ik.reached) ++stats.ik_failures;
    if (ik.found) waypoints = Plan(q_start, ik.q);
    ++plans;
  }
  if (!waypoints.empty()) {
    ++stats.plans_succeeded;
    const Eigen::Vector3d p_WE_goal = EndEffector(ik.q);
    // keep the current path when it is still valid (obstacles are checked every Evaluate), still ends at the target
    // and is no longer than the new one: fixed-rate replanning then does not swap equivalent random paths
    double new_length = 0.0;
    for (size_t k = 1; k < waypoints.size(); ++k) new_length += (waypoints[k] - waypoints[k - 1]).norm();
    const bool keep = !path.empty() && (path_p_WE - scene.p_WT).norm() <= options.ik_tolerance &&
                      RemainingLength(q_start) <= new_length;
    if (!keep) Adopt(std::move(waypoints), p_WE_goal);
  }
  stats.planning_times_s.push_back(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
}

void RrtPolicy::Impl::ResetEpisode() {
  path.clear();
  path_times.clear();
  has_previous_goal = false;
  calls = 0;
  time = 0.0;
  attempted = false;
  last_attempt = 0.0;
  plans = 0;
  rng.seed(seed);
  stats.plans_attempted = stats.plans_succeeded = stats.ik_failures = stats.invalidations = 0;
  stats.planning_times_s.clear();
}

RrtPolicy::RrtPolicy(const kinematics::Robot& robot, const RrtOptions& options) {
  ValidateRrtOptions(options);
  impl_ = std::make_unique<Impl>(robot, options);
  Impl& m = *impl_;
  const kinematics::Model& model = m.robot.model;
  m.nq = model.nq();
  m.seed = options.seed;
  m.limit_lower = model.LowerLimits();
  m.limit_upper = model.UpperLimits();
  m.lower = m.limit_lower;
  m.upper = m.limit_upper;
  m.v_path.resize(m.nq);
  m.continuous.resize(m.nq);
  for (int i = 0; i < m.nq; ++i) {
    const double v = model.limits()[i].velocity;
    if (!std::isfinite(v) || !(v > 0.0)) {
      throw InputError(fmt::format("RrtPolicy: robot '{}' joint '{}': expected a finite velocity limit > 0, got {}",
                                   m.robot.name, model.dof_name(i), v));
    }
    m.v_path[i] = options.path_speed_fraction * v;
    m.continuous[i] = !std::isfinite(m.limit_lower[i]) || !std::isfinite(m.limit_upper[i]);
  }
  m.obstacles.reserve(64);
  m.prepared.Reserve(64);
  m.q_d.setZero(m.nq);
  m.qd_d.setZero(m.nq);
  m.previous_goal.setZero(m.nq);
  m.J_WE.setZero(3, m.nq);
  m.scratch.setZero(m.nq);
  m.q_now.setZero(m.nq);
  m.stats.planning_times_s.reserve(kStatsCapacity);
  m.margin = options.safety_margin;
  // OMPL logs every plan at LOG_INFO; keep warnings and errors (the level is process-wide in OMPL)
  if (ompl::msg::getLogLevel() < ompl::msg::LOG_WARN) ompl::msg::setLogLevel(ompl::msg::LOG_WARN);
  m.ResetEpisode();
}

RrtPolicy::~RrtPolicy() = default;

void RrtPolicy::Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                         const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) {
  Impl& m = *impl_;
  m.time = static_cast<double>(m.calls++) * m.options.evaluation_period;
  if (!scene.has_target || !scene.p_WT.allFinite()) {
    qdd = -m.options.kd * qd;
    return;
  }
  // the path ahead is re-checked whenever the obstacles moved; an invalid one is dropped (the robot brakes)
  if (!m.path.empty() && m.ObstaclesChanged(scene)) {
    m.SetObstacles(scene);
    if (!m.RemainingPathValid(q)) {
      ++m.stats.invalidations;
      m.path.clear();
    }
  }
  const double since = m.time - m.last_attempt;
  const bool periodic = since >= m.options.replan_period - kTimeEpsilon;
  const bool retry = m.path.empty() && since >= m.options.retry_period - kTimeEpsilon;
  if (!m.attempted || periodic || retry) m.Replan(q, scene);

  if (m.path.empty()) {
    qdd = -m.options.kd * qd;
    return;
  }
  m.Reference(m.time - m.path_start_time);
  qdd = m.options.kp * (m.q_d - q) + m.options.kd * (m.qd_d - qd);
}

void RrtPolicy::Reset(const Eigen::Ref<const Eigen::VectorXd>& q0) {
  kinematics::CheckJointVector(impl_->robot.model, q0, "q0");
  impl_->ResetEpisode();
}

int RrtPolicy::nq() const { return impl_->nq; }
const RrtOptions& RrtPolicy::options() const { return impl_->options; }
const RrtStats& RrtPolicy::stats() const { return impl_->stats; }
void RrtPolicy::set_seed(std::uint64_t seed) { impl_->seed = seed; }
const std::vector<Eigen::VectorXd>& RrtPolicy::path() const { return impl_->path; }

double RrtPolicy::Clearance(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene) {
  return ClearanceWithPair(q, scene).distance;
}

ClearancePair RrtPolicy::ClearanceWithPair(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene) {
  kinematics::CheckJointVector(impl_->robot.model, q, "q");
  impl_->SetObstacles(scene);
  ClearancePair pair;
  impl_->Clearance(q, false, -kInf, &pair);
  return pair;
}

bool RrtPolicy::IsStateValid(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene) {
  return IsStateValid(q, scene, impl_->options.safety_margin);
}

bool RrtPolicy::IsStateValid(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene, double margin) {
  kinematics::CheckJointVector(impl_->robot.model, q, "q");
  Impl& m = *impl_;
  m.SetObstacles(scene);
  m.margin = margin;
  m.SetBounds(q);
  return m.Valid(q);
}

bool RrtPolicy::IsSegmentValid(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const rmp::Scene& scene,
                               double margin) {
  kinematics::CheckJointVector(impl_->robot.model, a, "a");
  kinematics::CheckJointVector(impl_->robot.model, b, "b");
  Impl& m = *impl_;
  m.SetObstacles(scene);
  m.margin = margin;
  return m.SegmentValid(a, b, /*obstacles_only=*/false, /*within_limits=*/true);
}

double RrtPolicy::last_plan_margin() const { return impl_->margin; }

IkResult RrtPolicy::SolveIk(const Eigen::Ref<const Eigen::VectorXd>& q_start, const rmp::Scene& scene) {
  kinematics::CheckJointVector(impl_->robot.model, q_start, "q_start");
  Impl& m = *impl_;
  m.SetObstacles(scene);
  m.margin = m.options.safety_margin;
  return m.SolveIk(q_start, scene.p_WT);
}

std::vector<Eigen::VectorXd> RrtPolicy::PlanPath(const Eigen::Ref<const Eigen::VectorXd>& q_start,
                                                 const Eigen::Ref<const Eigen::VectorXd>& q_goal,
                                                 const rmp::Scene& scene) {
  kinematics::CheckJointVector(impl_->robot.model, q_start, "q_start");
  kinematics::CheckJointVector(impl_->robot.model, q_goal, "q_goal");
  Impl& m = *impl_;
  m.SetObstacles(scene);
  // an end inside the safety margin (a goal configuration at a grasp, a start beside what the arm just dodged) is
  // planned with half its clearance as the margin: the whole path with the smaller end's, or with end_margin_distance
  // > 0 only near that end; an end in penetration has no path
  // (obstacle distances only: an arm that keeps two links inside the margin everywhere, e.g. a hand's fitted capsules,
  // has its floor and self-collision margin relaxed on the whole path, as without end_margin_distance)
  const double safety = m.options.safety_margin;
  const double start_obstacles = m.Clearance(q_start, true, -kInf), start_self = m.SelfClearance(-kInf);
  const double goal_obstacles = m.Clearance(q_goal, true, -kInf), goal_self = m.SelfClearance(-kInf);
  const double ends = std::min({start_obstacles, start_self, goal_obstacles, goal_self});
  if (!(ends > 0.0)) return {};
  m.margin = ends <= safety ? 0.5 * ends : safety;
  m.relaxed_ends.clear();
  m.split_margins = m.options.end_margin_distance > 0.0 && m.margin < safety;
  if (m.split_margins) {
    const double self = std::min(start_self, goal_self);
    m.self_margin = self <= safety ? 0.5 * self : safety;
    if (start_obstacles <= safety) m.relaxed_ends.push_back({q_start, 0.5 * start_obstacles});
    if (goal_obstacles <= safety) m.relaxed_ends.push_back({q_goal, 0.5 * goal_obstacles});
  }
  std::vector<Eigen::VectorXd> path = m.Plan(q_start, q_goal);
  m.split_margins = false;
  m.relaxed_ends.clear();
  ++m.plans;
  return path;
}

}  // namespace rmpmarl::planning
