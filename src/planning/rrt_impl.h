#pragma once
// The RRT baseline's state (planning/rrt.h), shared by its parts: rrt.cc (options, the replanning policy and its
// public calls), rrt_search.cc (validity through the robot collision checker, RRT-Connect, shortcutting) and
// rrt_ik.cc (the goal configuration by damped least squares).
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include "rmpmarl/collision/checker.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/planning/rrt.h"

namespace rmpmarl::planning {

namespace rrt_internal {
inline constexpr double kInf = std::numeric_limits<double>::infinity();
}  // namespace rrt_internal

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
  double SelfClearance(double stop_below, double d = rrt_internal::kInf, ClearancePair* pair = nullptr) const;
  // q valid for a PlanPath search: its obstacle distances beyond MarginAt(q), its floor and self distances beyond
  // self_margin (an arm that always keeps two of its links close, inside the margin, can still move)
  // (both place only the capsules their check reaches: `placed` is then partly placed, Clearance places it whole)
  bool ValidRelaxed(const Eigen::Ref<const Eigen::VectorXd>& q, bool obstacles_only) {
    return collision::CheckConfigCollisionFree(checker, q, prepared, MarginAt(q), self_margin, obstacles_only,
                                               &placed);
  }
  // every checked distance at q (only the obstacles' with obstacles_only) > margin
  bool CollisionFree(const Eigen::Ref<const Eigen::VectorXd>& q, bool obstacles_only) {
    return collision::CheckConfigCollisionFree(checker, q, prepared, margin, margin, obstacles_only, &placed);
  }
  // q within the bounds of the current plan and every checked distance > margin.
  bool Valid(const Eigen::Ref<const Eigen::VectorXd>& q) { return InBounds(q) && CollisionFree(q, false); }
  bool InBounds(const Eigen::Ref<const Eigen::VectorXd>& q) const { return Within(q, lower, upper); }
  // q within [lo, hi] to rounding
  static bool Within(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::VectorXd& lo, const Eigen::VectorXd& hi) {
    return ((q - lo).array() >= -1e-12).all() && ((hi - q).array() >= -1e-12).all();
  }
  // the states of segment a → b at most validity_resolution apart (excluding a, including b; checked coarse to
  // fine) are valid; with
  // obstacles_only, only the obstacle distances are checked (margin `margin`).
  bool SegmentValid(const Eigen::VectorXd& a, const Eigen::VectorXd& b, bool obstacles_only,
                    bool within_limits = false);
  // joint bounds of a plan starting at q: the limits, continuous joints within ±π of q.
  void SetBounds(const Eigen::Ref<const Eigen::VectorXd>& q);
  void SetObstacles(const rmp::Scene& scene) {
    obstacles = scene.obstacles;
    prepared.Assign(obstacles);
  }
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
  collision::PreparedObstacles prepared;        // the same, with their bounds for the validity checks
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

}  // namespace rmpmarl::planning
