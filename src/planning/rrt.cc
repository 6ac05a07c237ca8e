// The paper's RRT baseline (IEEE Access 2023, section IV.B–C): DLS IK goal, OMPL RRT-Connect in joint space,
// greedy shortcutting, constant-velocity timing and joint-space PD tracking; replanning at a fixed rate and on
// invalidation.
#include "rmpmarl/planning/rrt.h"

#include <fmt/format.h>
#include <ompl/base/PlannerTerminationCondition.h>
#include <ompl/base/ProblemDefinition.h>
#include <ompl/base/ScopedState.h>
#include <ompl/base/SpaceInformation.h>
#include <ompl/base/spaces/RealVectorStateSpace.h>
#include <ompl/geometric/PathGeometric.h>
#include <ompl/geometric/planners/rrt/RRTConnect.h>
#include <ompl/util/Console.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <string_view>
#include <utility>

#include "rmpmarl/common/error.h"
#include "rmpmarl/common/random.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::planning {
namespace {

namespace ob = ompl::base;
namespace og = ompl::geometric;

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kTimeEpsilon = 1e-9;  // [s] slack of the evaluated-time comparisons (calls × period)
constexpr int kStatsCapacity = 4096;   // planning_times_s entries reserved up front

// throws InputError "RrtOptions.<field>: expected <expected>, got <got>" unless ok (and got is a number).
void Require(bool ok, std::string_view field, std::string_view expected, double got) {
  if (!ok || std::isnan(got)) throw InputError(fmt::format("RrtOptions.{}: expected {}, got {}", field, expected, got));
}

// OMPL's uniform sampler with an instance seed (ompl::RNG::setLocalSeed) instead of one drawn from the process-wide
// seed generator: RRT-Connect's only random choice, so a plan is a function of (problem, seed).
class SeededSampler final : public ob::RealVectorStateSampler {
 public:
  SeededSampler(const ob::StateSpace* space, std::uint_fast32_t seed) : ob::RealVectorStateSampler(space) {
    rng_.setLocalSeed(seed);
  }
};

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

struct RrtPolicy::Impl {
  Impl(const kinematics::Robot& r, const RrtOptions& o)
      : robot(r), options(o), kin(robot.model), checker(robot, {o.check_floor, o.floor_height}), placed(checker) {}

  // smallest signed distance at q over the obstacles (and, unless obstacles_only, the floor and checked capsule
  // pairs); returns early, with a value <= stop_below, once one distance is that small. Exact for stop_below = −inf;
  // otherwise a value <= stop_below exactly when the clearance is (pairs that cannot come within stop_below are
  // skipped: a validity check needs no more). `pair` (optional) receives the pair attaining the value returned.
  double Clearance(const Eigen::Ref<const Eigen::VectorXd>& q, bool obstacles_only, double stop_below,
                   ClearancePair* pair = nullptr);
  // the floor and self-collision part of Clearance on the capsules it placed last, continuing from its distance d so
  // far (+inf: that part alone), with the same early return; `pair` as in Clearance, left as it is unless a pair
  // here comes closer than d
  double SelfClearance(double stop_below, double d = kInf, ClearancePair* pair = nullptr) const;
  // q valid for a PlanPath search: its obstacle distances beyond MarginAt(q), its floor and self distances beyond
  // self_margin (an arm that always keeps two of its links close, inside the margin, can still move)
  bool ValidRelaxed(const Eigen::Ref<const Eigen::VectorXd>& q, bool obstacles_only) {
    const double m = MarginAt(q);
    if (Clearance(q, /*obstacles_only=*/true, m) <= m) return false;
    return obstacles_only || SelfClearance(self_margin) > self_margin;
  }
  // q within the bounds of the current plan and every checked distance > margin.
  bool Valid(const Eigen::Ref<const Eigen::VectorXd>& q) { return InBounds(q) && Clearance(q, false, margin) > margin; }
  bool InBounds(const Eigen::Ref<const Eigen::VectorXd>& q) const { return Within(q, lower, upper); }
  // q within [lo, hi] to rounding
  static bool Within(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
    return ((q - lo).array() >= -1e-12).all() && ((hi - q).array() >= -1e-12).all();
  }
  // the states of segment a → b at most validity_resolution apart (excluding a, including b) are valid; with
  // obstacles_only, only the obstacle distances are checked (margin `margin`).
  bool SegmentValid(const Eigen::VectorXd& a, const Eigen::VectorXd& b, bool obstacles_only,
                    bool within_limits = false);
  // joint bounds of a plan starting at q: the limits, continuous joints within ±π of q.
  void SetBounds(const Eigen::Ref<const Eigen::VectorXd>& q);
  void SetObstacles(const rmp::Scene& scene) { obstacles = scene.obstacles; }
  bool ObstaclesChanged(const rmp::Scene& scene) const;
  Eigen::Vector3d EndEffector(const Eigen::Ref<const Eigen::VectorXd>& q);
  IkResult SolveIk(const Eigen::Ref<const Eigen::VectorXd>& q_start, const Eigen::Vector3d& p_WT);
  // one DLS run from q (in place); returns the final end-effector error.
  double RunDls(Eigen::VectorXd* q, const Eigen::Vector3d& p_WT);
  std::vector<Eigen::VectorXd> Plan(const Eigen::VectorXd& q_start, const Eigen::VectorXd& q_goal);
  void Shortcut(std::vector<Eigen::VectorXd>* path);
  // options.shortcut_iterations random shortcuts, drawn from `seed`
  void RandomShortcut(std::vector<Eigen::VectorXd>* path, std::uint64_t seed);
  // replans from q: IK goal, plan, adopt the new path unless the current one is as good (stats updated).
  void Replan(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);
  // adopts `waypoints` as the executed path from the current time, timed at the speed limits.
  void Adopt(std::vector<Eigen::VectorXd> waypoints, const Eigen::Vector3d& p_WE_goal);
  // joint-space length of the path still ahead of q: q → q_d(now) → the remaining waypoints.
  double RemainingLength(const Eigen::Ref<const Eigen::VectorXd>& q);
  // q_d(tau), q̇_d(tau) of the executed path.
  void Reference(double tau);
  bool RemainingPathValid(const Eigen::Ref<const Eigen::VectorXd>& q);
  void ResetEpisode();

  kinematics::Robot robot;
  RrtOptions options;
  std::uint64_t seed = 0;
  int nq = 0;
  kinematics::Data kin;
  Eigen::VectorXd limit_lower, limit_upper;  // the model's limits (±inf for continuous joints)
  Eigen::VectorXd lower, upper;              // bounds of the current plan
  Eigen::VectorXd v_path;                    // path_speed_fraction × velocity limits
  std::vector<char> continuous;
  collision::RobotCollisionModel checker;    // the robot's capsules, their link groups and checked pairs
  collision::RobotCollisionData placed;      // the capsules at the configuration checked last
  std::vector<rmp::Obstacle> obstacles;         // the snapshot planning and path checks use
  double margin = 0.0;                          // validity margin in use (safety_margin, or less from a tight start)
  // a PlanPath search with end_margin_distance > 0 from or to an end inside the safety margin: the obstacles' margin
  // MarginAt(q), relaxed near such an end (relaxed_ends), the floor and self-collision margin self_margin; otherwise
  // `margin` holds for every distance
  bool split_margins = false;
  struct RelaxedEnd {
    Eigen::VectorXd q;
    double margin = 0.0;
  };
  std::vector<RelaxedEnd> relaxed_ends;
  double self_margin = 0.0;
  // the obstacles' margin at q with split_margins: safety_margin, or near a relaxed end its margin growing linearly to
  // safety_margin over end_margin_distance
  double MarginAt(const Eigen::Ref<const Eigen::VectorXd>& q) const {
    double m = options.safety_margin;
    for (const RelaxedEnd& e : relaxed_ends) {
      const double f = std::min(1.0, (q - e.q).norm() / options.end_margin_distance);
      m = std::min(m, e.margin + (options.safety_margin - e.margin) * f);
    }
    return m;
  }

  // the executed path
  std::vector<Eigen::VectorXd> path;
  std::vector<double> path_times;  // arrival time at each waypoint, from the path's start [s]
  Eigen::Vector3d path_p_WE = Eigen::Vector3d::Zero();  // end effector at the path's goal
  double path_margin = 0.0;
  double path_start_time = 0.0;
  int segment = 0;
  Eigen::VectorXd q_d, qd_d, previous_goal;
  bool has_previous_goal = false;

  long calls = 0;
  double time = 0.0;
  bool attempted = false;
  double last_attempt = 0.0;
  std::uint64_t plans = 0;
  std::mt19937_64 rng;
  RrtStats stats;
  Eigen::Matrix3Xd J_WE;
  Eigen::VectorXd scratch, q_now;
};

double RrtPolicy::Impl::Clearance(const Eigen::Ref<const Eigen::VectorXd>& q, bool obstacles_only,
                                  double stop_below, ClearancePair* pair) {
  collision::PlaceRobot(checker, q, &placed);
  const double d = collision::CalcObstacleClearance(checker, placed, obstacles, stop_below, kInf, pair);
  if (obstacles_only || d <= stop_below) return d;
  return SelfClearance(stop_below, d, pair);
}

double RrtPolicy::Impl::SelfClearance(double stop_below, double d, ClearancePair* pair) const {
  return collision::CalcSelfClearance(checker, placed, stop_below, d, pair);
}

bool RrtPolicy::Impl::SegmentValid(const Eigen::VectorXd& a, const Eigen::VectorXd& b, bool obstacles_only,
                                   bool within_limits) {
  const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / options.validity_resolution)));
  for (int k = 1; k <= n; ++k) {
    scratch = a + (static_cast<double>(k) / n) * (b - a);
    if (within_limits && !Within(scratch, limit_lower, limit_upper)) return false;
    if (split_margins) {
      if (!ValidRelaxed(scratch, obstacles_only)) return false;
    } else if (Clearance(scratch, obstacles_only, margin) <= margin) {
      return false;
    }
  }
  return true;
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

Eigen::Vector3d RrtPolicy::Impl::EndEffector(const Eigen::Ref<const Eigen::VectorXd>& q) {
  kinematics::CalcForwardKinematics(robot.model, q, &kin);
  return kinematics::CalcPointPosition(kin, robot.end_effector.link, robot.end_effector.X_LE.translation());
}

double RrtPolicy::Impl::RunDls(Eigen::VectorXd* q, const Eigen::Vector3d& p_WT) {
  const int link = robot.end_effector.link;
  const Eigen::Vector3d p_LE = robot.end_effector.X_LE.translation();
  const double lambda2 = options.ik_damping * options.ik_damping;
  const double converged = 0.1 * options.ik_tolerance;
  double error = kInf;
  for (int it = 0; it <= options.ik_iterations; ++it) {
    kinematics::CalcForwardKinematics(robot.model, *q, &kin);
    const Eigen::Vector3d e = p_WT - kinematics::CalcPointPosition(kin, link, p_LE);
    error = e.norm();
    if (error <= converged || it == options.ik_iterations) break;
    kinematics::CalcPointJacobian(robot.model, kin, link, p_LE, J_WE);
    // damped least squares (Wampler 1986): Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e
    const Eigen::Matrix3d A = J_WE * J_WE.transpose() + lambda2 * Eigen::Matrix3d::Identity();
    scratch.noalias() = J_WE.transpose() * A.ldlt().solve(e);
    const double largest = scratch.cwiseAbs().maxCoeff();
    if (largest > options.ik_max_step) scratch *= options.ik_max_step / largest;
    *q = (*q + scratch).cwiseMax(lower).cwiseMin(upper);
  }
  return error;
}

IkResult RrtPolicy::Impl::SolveIk(const Eigen::Ref<const Eigen::VectorXd>& q_start, const Eigen::Vector3d& p_WT) {
  SetBounds(q_start);
  IkResult best;
  double best_distance = kInf;
  Eigen::VectorXd q(nq);
  for (int s = 0; s < options.ik_seeds; ++s) {
    if (s == 0) {
      q = q_start.cwiseMax(lower).cwiseMin(upper);
    } else if (s == 1 && has_previous_goal) {
      for (int i = 0; i < nq; ++i) {  // the previous goal, continuous joints taken the short way from q_start
        q[i] = continuous[i] ? q_start[i] + std::remainder(previous_goal[i] - q_start[i], 2.0 * M_PI)
                             : previous_goal[i];
      }
      q = q.cwiseMax(lower).cwiseMin(upper);
    } else {
      for (int i = 0; i < nq; ++i) q[i] = std::uniform_real_distribution<double>(lower[i], upper[i])(rng);
    }
    const double error = RunDls(&q, p_WT);
    if (!Valid(q)) continue;
    const bool reached = error <= options.ik_tolerance;
    const double distance = (q - q_start).norm();
    // reached solutions beat unreached ones; among reached the closest to q_start, among unreached the most accurate
    const bool better = !best.found || (reached && !best.reached) ||
                        (reached && best.reached && distance < best_distance) ||
                        (!reached && !best.reached && error < best.error);
    if (better) {
      best = {true, reached, q, error};
      best_distance = distance;
    }
  }
  return best;
}

std::vector<Eigen::VectorXd> RrtPolicy::Impl::Plan(const Eigen::VectorXd& q_start, const Eigen::VectorXd& q_goal) {
  SetBounds(q_start);
  if (!Valid(q_start) || !Valid(q_goal)) return {};
  if (SegmentValid(q_start, q_goal, false)) return {q_start, q_goal};

  auto space = std::make_shared<ob::RealVectorStateSpace>(nq);
  ob::RealVectorBounds bounds(nq);
  for (int i = 0; i < nq; ++i) {
    bounds.setLow(i, lower[i]);
    bounds.setHigh(i, upper[i]);
  }
  space->setBounds(bounds);
  const auto sampler_seed = static_cast<std::uint_fast32_t>(SplitMix64(seed ^ SplitMix64(plans)) & 0xffffffffULL);
  space->setStateSamplerAllocator(
      [sampler_seed](const ob::StateSpace* s) { return std::make_shared<SeededSampler>(s, sampler_seed); });
  auto si = std::make_shared<ob::SpaceInformation>(space);
  si->setStateValidityChecker([this](const ob::State* state) {
    const double* v = state->as<ob::RealVectorStateSpace::StateType>()->values;
    const Eigen::Map<const Eigen::VectorXd> q(v, nq);
    return split_margins ? ValidRelaxed(q, false) : Clearance(q, false, margin) > margin;
  });
  si->setStateValidityCheckingResolution(options.validity_resolution / space->getMaximumExtent());
  si->setup();

  auto to_state = [&](const Eigen::VectorXd& q, ob::ScopedState<ob::RealVectorStateSpace>* s) {
    for (int i = 0; i < nq; ++i) (*s)[i] = q[i];
  };
  ob::ScopedState<ob::RealVectorStateSpace> start(space), goal(space);
  to_state(q_start, &start);
  to_state(q_goal, &goal);
  auto pdef = std::make_shared<ob::ProblemDefinition>(si);
  pdef->setStartAndGoalStates(start, goal, 1e-9);
  og::RRTConnect planner(si);
  if (options.range > 0.0) planner.setRange(options.range);
  planner.setProblemDefinition(pdef);
  planner.setup();
  ob::PlannerTerminationCondition budget = ob::timedPlannerTerminationCondition(options.planning_time_budget);
  if (options.planning_iterations > 0) {
    // RRT-Connect evaluates the condition once per iteration
    budget = ob::plannerOrTerminationCondition(
        budget, ob::PlannerTerminationCondition([n = options.planning_iterations, calls = 0]() mutable {
          return ++calls > n;
        }));
  }
  const ob::PlannerStatus status = planner.solve(budget);
  if (status != ob::PlannerStatus::EXACT_SOLUTION) return {};

  const auto& states = std::static_pointer_cast<og::PathGeometric>(pdef->getSolutionPath())->getStates();
  std::vector<Eigen::VectorXd> path;
  path.reserve(states.size() + 1);
  for (const ob::State* s : states) {
    path.emplace_back(Eigen::Map<const Eigen::VectorXd>(s->as<ob::RealVectorStateSpace::StateType>()->values, nq));
  }
  path.back() = q_goal;  // exact goal (the goal threshold lets RRT-Connect stop a hair away)
  Shortcut(&path);
  if (options.shortcut_iterations > 0) RandomShortcut(&path, SplitMix64(sampler_seed ^ 0x5348525443555453ULL));
  return path;
}

void RrtPolicy::Impl::RandomShortcut(std::vector<Eigen::VectorXd>* path, std::uint64_t seed) {
  std::mt19937_64 draw(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<double> s = PathArcLengths(*path);
  // the point at arc length t and the index of the segment holding it
  auto at = [&](double t, Eigen::VectorXd* q) {
    const PathLocation where = LocateOnPath(s, t);
    const size_t k = static_cast<size_t>(where.segment);
    *q = (*path)[k] + where.fraction * ((*path)[k + 1] - (*path)[k]);
    return k;
  };
  Eigen::VectorXd a, b;
  for (int it = 0; it < options.shortcut_iterations && path->size() >= 3; ++it) {
    double ta = unit(draw) * s.back(), tb = unit(draw) * s.back();
    if (ta > tb) std::swap(ta, tb);
    const size_t ka = at(ta, &a), kb = at(tb, &b);
    if (kb <= ka) continue;  // on one segment: straight already
    // a → b replaces the waypoints ka+1 … kb when it is valid and shorter
    if ((b - a).norm() >= tb - ta - 1e-9 || !SegmentValid(a, b, false)) continue;
    std::vector<Eigen::VectorXd> out;
    out.reserve(path->size() + 2);
    out.insert(out.end(), path->begin(), path->begin() + static_cast<std::ptrdiff_t>(ka) + 1);
    if ((a - out.back()).norm() > 1e-12) out.push_back(a);
    if ((b - (*path)[kb + 1]).norm() > 1e-12) out.push_back(b);
    out.insert(out.end(), path->begin() + static_cast<std::ptrdiff_t>(kb) + 1, path->end());
    *path = std::move(out);
    s = PathArcLengths(*path);
  }
}

void RrtPolicy::Impl::Shortcut(std::vector<Eigen::VectorXd>* path) {
  // greedy: from each kept waypoint jump to the farthest later one that a straight valid segment reaches
  std::vector<Eigen::VectorXd> out;
  out.reserve(path->size());
  out.push_back(path->front());
  size_t i = 0;
  while (i + 1 < path->size()) {
    size_t j = path->size() - 1;
    while (j > i + 1 && !SegmentValid((*path)[i], (*path)[j], false)) --j;
    out.push_back((*path)[j]);
    i = j;
  }
  *path = std::move(out);
}

std::vector<double> PathArrivalTimes(const std::vector<Eigen::VectorXd>& path, const Eigen::VectorXd& speeds) {
  std::vector<double> times(path.size(), 0.0);
  for (size_t k = 1; k < path.size(); ++k) {
    const double duration = ((path[k] - path[k - 1]).cwiseAbs().cwiseQuotient(speeds)).maxCoeff();
    times[k] = times[k - 1] + std::max(duration, 1e-6);
  }
  return times;
}

std::vector<double> PathArcLengths(const std::vector<Eigen::VectorXd>& path) {
  std::vector<double> s(path.size(), 0.0);
  for (size_t k = 1; k < path.size(); ++k) s[k] = s[k - 1] + (path[k] - path[k - 1]).norm();
  return s;
}

PathLocation LocateOnPath(const std::vector<double>& knots, double x) {
  RMPMARL_ASSERT(knots.size() >= 2, "LocateOnPath: a path of at least two waypoints");
  const int last = static_cast<int>(knots.size()) - 1;
  PathLocation at;
  at.segment =
      std::clamp(static_cast<int>(std::upper_bound(knots.begin(), knots.end(), x) - knots.begin()) - 1, 0, last - 1);
  const double length = knots[at.segment + 1] - knots[at.segment];
  at.fraction = length > 0.0 ? std::clamp((x - knots[at.segment]) / length, 0.0, 1.0) : 0.0;
  return at;
}

void SamplePath(const std::vector<Eigen::VectorXd>& path, const std::vector<double>& times, double t,
                Eigen::VectorXd* q_d, Eigen::VectorXd* qd_d) {
  RMPMARL_ASSERT(!path.empty() && times.size() == path.size(), "SamplePath: a path and its times");
  const int last = static_cast<int>(path.size()) - 1;
  if (t >= times[last]) {
    *q_d = path[last];
    qd_d->setZero(path[last].size());
    return;
  }
  const PathLocation at = LocateOnPath(times, t);  // every segment lasts > 0 (PathArrivalTimes)
  const int segment = at.segment;
  *q_d = path[segment] + at.fraction * (path[segment + 1] - path[segment]);
  *qd_d = (path[segment + 1] - path[segment]) / (times[segment + 1] - times[segment]);
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
  if (Clearance(q_now, true, margin) <= margin) return false;
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
