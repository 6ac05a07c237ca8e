#pragma once
/// Plan, then react: a global joint-space plan (RRT-Connect on the capsule model, shortcut — planning::RrtPolicy's
/// PlanPath) followed by a reactive layer (RMPflow, or the learned agents) as a moving target, behind the one
/// controller interface (control::AccelerationPolicy), as Isaac's cuMotion + RMPflow or MoveIt's OMPL + Servo pair
/// a global planner with a local one.
///
/// The goal is the scene's joint-space goal (rmp::Scene::q_T) when it has one, else an IK solution of its end-effector
/// target (RrtPolicy::SolveIk). The reactive layer follows the plan as a carrot: at every call it sees the scene with
/// its target replaced by the plan's point q_c a joint-space arc length `lookahead` beyond the arm's nearest point on
/// the path (searched forward from the last one, so progress never goes back) — the end effector at q_c, moving with
/// J(q_c) q̇_c where q̇_c runs along the path as fast as the slowest joint allows at path_speed_fraction × its velocity
/// limit (slowing down over the path's last `lookahead`), and q_c as its C-space target (scene.q_T) weighted by
/// posture_metric. The reactive layer moves as fast as it moves, and a dodge does not leave the plan behind; the
/// obstacles are the scene's, so whatever moves is dodged by the reactive layer.
///
/// Replans, from the measured configuration: when the nearest point has not advanced for stall_time while the arm is
/// not at the goal; when the rest of the path is no longer valid against the obstacles' current poses (checked every
/// check_period); and when the goal moved (a joint goal by more than goal_tolerance, an end-effector target by more
/// than goal_shift since it was planned for). A failed plan drops the path and is retried after the planner's
/// retry_period; meanwhile the reactive layer is given the scene's own goal.
///
/// Without a reactive layer the plan is executed open loop, timed as RrtPolicy times it (constant joint velocity per
/// segment at path_speed_fraction × the velocity limits), by the planner's joint PD law (q̈ = kp (q_d(t) − q) + kd
/// (q̇_d(t) − q̇)) on the clock, planned once: the RRT-Connect baseline of the benchmarks.
///
/// Evaluate allocates nothing between plans; a plan allocates (OMPL's trees, the path).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/planning/rrt.h"

namespace rmpmarl::planning {

/// Options of PlanFollowPolicy (times in seconds, joint distances in rad or m).
struct PlanFollowOptions {
  /// the planner: RRT-Connect budget, validity margin and resolution, path timing, the open-loop PD gains, the retry
  /// period and the clock (evaluation_period: the controller's substep, as for RrtPolicy).
  RrtOptions planner;
  /// replan when progress stalls or the path ahead is blocked (false: plan once and never again; always false without
  /// a reactive layer).
  bool replan = true;
  double lookahead = 0.3;     ///< the carrot's arc length beyond the arm's nearest path point [rad or m], > 0
  /// the metric scalar of the reactive layer's C-space target toward the carrot (rmp::Scene::q_T_metric), > 0: as
  /// much as RMPflow's end-effector target weighs at its least (target_rmp.min_metric_scalar), so the arm keeps the
  /// planned posture where the end-effector target alone would let a redundant arm fold another way
  double posture_metric = 2500.0;
  double stall_time = 1.0;    ///< no progress this long → replan, > 0
  double check_period = 0.1;  ///< the rest of the path is checked against the obstacles this often, > 0
  /// the goal counts as reached (no stall replans) within this of q_goal (max over joints) [rad or m], or with the end
  /// effector within this of the goal's [m], > 0
  double goal_tolerance = 0.02;
  /// an end-effector target that moved this far [m] since the plan was made for it is planned for anew, > 0
  double goal_shift = 0.05;
};

/// throws InputError (field, expected vs got) unless the options are valid.
void ValidatePlanFollowOptions(const PlanFollowOptions& options);

/// Counters since the last Reset.
struct PlanFollowStats {
  int plans_attempted = 0;
  int plans_succeeded = 0;
  int replans_stalled = 0;   ///< replans started because progress stalled
  int replans_blocked = 0;   ///< replans started because the path ahead became invalid
  int replans_moved = 0;     ///< replans started because the goal moved
  int goal_failures = 0;     ///< attempts without a valid goal configuration (IK failed, or q_T in collision)
  std::vector<double> planning_times_s;  ///< wall time of every attempt (goal + RRT-Connect + shortcut) [s]
  double first_path_length = 0.0;        ///< joint-space length of the first plan [rad or m] (0: none)
};

class PlanFollowPolicy final : public control::AccelerationPolicy {
 public:
  /// a plan follower for `robot` with the reactive layer `reactive` (null: open-loop execution, planned once).
  /// Throws InputError for bad options or a reactive layer of another joint count.
  PlanFollowPolicy(const kinematics::Robot& robot, std::unique_ptr<control::AccelerationPolicy> reactive,
                   const PlanFollowOptions& options);
  ~PlanFollowPolicy() override;

  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override;
  void BeginControlStep(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                        const rmp::Scene& scene) override;
  void Reset(const Eigen::Ref<const Eigen::VectorXd>& q0) override;
  /// "plan+<reactive layer's name>", or "rrt-connect" open loop.
  std::string name() const override;
  int nq() const override;

  const PlanFollowStats& stats() const { return stats_; }
  /// the path being followed (empty: none).
  const std::vector<Eigen::VectorXd>& path() const { return path_; }
  /// the seed of the planner from the next Reset on.
  void set_seed(std::uint64_t seed) { planner_.set_seed(seed); }

 private:
  // plans from q toward the scene's goal when due; keeps the reference time
  bool GoalMoved(const rmp::Scene& scene) const;
  void Advance(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene, bool control_step);
  bool Plan(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);
  void PointAt(double s);                       // q_d_ at arc length s (carrot)
  Eigen::Vector3d EndEffectorAt(const Eigen::Ref<const Eigen::VectorXd>& q);  // uses kin_
  void Project(const Eigen::Ref<const Eigen::VectorXd>& q);  // s_near_: the arm's nearest path point, forward only
  bool RestValid(const rmp::Scene& scene);      // the path from the arm's nearest point on, at the resolution
  void FillFollowScene(const rmp::Scene& scene);

  kinematics::Robot robot_;
  std::unique_ptr<control::AccelerationPolicy> reactive_;
  PlanFollowOptions options_;
  RrtPolicy planner_;
  kinematics::Data kin_;
  Eigen::VectorXd v_path_;
  PlanFollowStats stats_;

  std::vector<Eigen::VectorXd> path_;
  std::vector<double> path_times_;   // arrival time at each waypoint (open loop) [s]
  std::vector<double> path_s_;       // arc length at each waypoint [rad or m]
  Eigen::VectorXd q_goal_, q_d_, qd_d_, q_check_;
  Eigen::VectorXd planned_q_T_;                       // the scene's joint goal when planned (empty: none)
  Eigen::Vector3d planned_p_WT_ = Eigen::Vector3d::Zero();  // its end-effector target then
  Eigen::Vector3d p_WG_ = Eigen::Vector3d::Zero();          // the end effector at q_goal_
  Eigen::Matrix3Xd J_WE_;
  rmp::Scene follow_;         // the reactive layer's scene
  double time_ = 0.0;         // policy clock [s]
  double tau_ = 0.0;          // path time [s] (open loop)
  double s_near_ = 0.0;       // arc length of the arm's nearest path point (reactive)
  int segment_ = 0;           // the segment holding it
  double last_progress_ = 0.0, last_check_ = 0.0, last_attempt_ = -1e9;
  double plan_margin_ = 0.0;  // the margin the current path was planned with
  bool planned_once_ = false;
  bool has_goal_ = false;
};

/// a plan follower whose clock is the substep of a ReactiveController with `controller` options (the planner's
/// evaluation_period set from them): the way to put one behind a controller.
std::unique_ptr<PlanFollowPolicy> MakePlanFollower(const kinematics::Robot& robot,
                                                   std::unique_ptr<control::AccelerationPolicy> reactive,
                                                   const control::ControllerOptions& controller,
                                                   PlanFollowOptions options = {});

}  // namespace rmpmarl::planning
