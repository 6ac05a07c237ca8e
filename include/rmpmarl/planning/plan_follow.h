#pragma once
/// Plan, then react: a global joint-space plan (RRT-Connect on the capsule model, shortcut — planning::RrtPolicy's
/// PlanPath) followed by a reactive layer (RMPflow, or the learned agents) as a moving target, behind the one
/// controller interface (control::AccelerationPolicy), as Isaac's cuMotion + RMPflow or MoveIt's OMPL + Servo pair
/// a global planner with a local one.
///
/// The goal is the scene's joint-space goal (rmp::Scene::q_T) when it has one, else an IK solution of its end-effector
/// target (RrtPolicy::SolveIk). The reactive layer follows the plan as a moving reference: at every call it sees the
/// scene with its target replaced by the plan's point q_c at arc length s_c — the end effector at q_c, moving with
/// J(q_c) q̇_c, and q_c as its C-space target (scene.q_T) moving with q̇_c (scene.qd_T) and accelerating with q̈_c
/// (scene.qdd_T, acceleration_feedforward), weighted by posture_metric.
/// s_c runs along the path as fast as the slowest joint allows at path_speed_fraction × its velocity limit, its speed
/// continuous in s: it slows down linearly over `lookahead` before each waypoint (whichever segment it is on) to pass
/// it with a velocity change of at most corner_velocity_jump and at most the slower of the two segments' speeds, and to
/// rest over the path's last `lookahead`, while it leads the arm's nearest point on the path (searched forward from
/// the last one, so progress never goes back) by less than lookahead / 2, slower beyond, and stops at a lead of
/// lookahead; it is never behind that point. So the reactive layer tracks the plan at the plan's speed where it can,
/// the reference waits where a dodge or the layer holds the arm back, and a dodge does not leave the plan behind; the
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
/// Plans beside the loop (options.plan_beside_loop): a plan runs on a worker thread, so the call that starts it returns
/// at once. Until the plan is ready the follower keeps to the path it has (with none, the reactive layer goes for the
/// scene's goal) and starts no other plan; the first call that finds it ready switches to it. A plan is the same
/// function of (start, goal, scene, seed) as when it runs inside the call; the path starts where the arm was when it
/// began, and the follower projects the arm onto it, forward from there. A run is then not reproducible: the plan
/// arrives when the machine has finished it.
///
/// Evaluate allocates nothing between plans; a plan allocates (OMPL's trees, the path; beside the loop, a copy of the
/// scene and the thread).
#include <Eigen/Core>
#include <filesystem>
#include <future>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/planning/rrt.h"

namespace rmpmarl::planning {

/// Options of PlanFollowPolicy (times in seconds, joint distances in rad or m).
struct PlanFollowOptions {
  /// the planner: RRT-Connect budget, validity margin and resolution, path timing, the open-loop PD gains, the retry
  /// period and the clock (evaluation_period: the controller's substep, as for RrtPolicy).
  RrtOptions planner = [] {
    RrtOptions o;
    o.shortcut_iterations = 100;  // shorter paths than the greedy shortcut's alone (the cages' ~40 % shorter)
    o.range = 0.5;                // fewer searches that run out of time in shelves and cages than OMPL's 2.5 rad
    o.end_margin_distance = 0.3;  // a goal at a grasp relaxes the margin only near it
    return o;
  }();
  /// replan when progress stalls or the path ahead is blocked (false: plan once and never again; always false without
  /// a reactive layer).
  bool replan = true;
  /// plans run on a worker thread beside the control loop: no call waits for a plan (see the file comment). False:
  /// the call that starts a plan returns after it (reproducible runs: the benchmarks). Always false without a reactive
  /// layer.
  bool plan_beside_loop = false;
  /// the most the reference leads the arm's nearest path point by (arc length) [rad or m], > 0; also the distance
  /// over which the reference slows down before a waypoint (and speeds up after it)
  double lookahead = 0.3;
  /// at a waypoint the reference's joint velocity turns by at most this [rad/s or m/s], > 0: it slows down to pass a
  /// sharp corner of the path (the layer's lag would cut it, toward what the plan passes 1 cm from)
  double corner_velocity_jump = 1.0;
  /// the reference slows down to rest over this much of the path's end (arc length) [rad or m], > 0: the layer lags a
  /// decelerating reference, and a goal at a grasp is often close to the cell
  double approach_distance = 0.6;
  /// the layer is given the reference's acceleration too (rmp::Scene::qdd_T: where it speeds up after a waypoint or
  /// slows down before one), so that it does not trail a reference that changes speed
  bool acceleration_feedforward = true;
  /// the metric scalar of the reactive layer's C-space target toward the reference (rmp::Scene::q_T_metric) while
  /// nothing that moves is within yield_far of the arm, > 0: the plan, valid against the obstacles as they are,
  /// outweighs the layer's repulsion from the static cell it was planned around (a timid layer would hold off it)
  double posture_metric = 2.5e8;
  /// the same within yield_near of an obstacle that moves (velocity ≠ 0), in (0, posture_metric]: as much as RMPflow's
  /// end-effector target weighs at its least (target_rmp.min_metric_scalar), so the layer dodges what the plan did not
  /// know and still keeps the planned posture; between the two distances the metric goes geometrically from one to
  /// the other
  double yield_metric = 2500.0;
  double yield_near = 0.2;  ///< [m], >= 0
  double yield_far = 0.8;   ///< [m], > yield_near
  /// the reference slows down near what moves as the metric yields (stops within yield_near), so that the arm waits
  /// for a crossing obstacle to pass instead of meeting it on the path
  bool yield_slows = true;
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

/// `options` with the values a YAML file sets (configs/planning/follow.yaml lists every key: the follower's fields,
/// and under `planner:` path_speed_fraction, validity_resolution, retry_period, kp, kd); an unknown key, a value of the
/// wrong kind or out of range throws InputError naming the file and key.
PlanFollowOptions LoadPlanFollowOptions(const std::filesystem::path& path, PlanFollowOptions options = {});

/// How the last planning attempt ended.
enum class PlanOutcome {
  kNone,             ///< no attempt yet
  kPlanned,          ///< a path was found and is followed
  kNoGoal,           ///< no goal configuration: the scene has neither a joint goal nor a target, or IK found none
  kGoalInCollision,  ///< the goal configuration is in collision (or within the safety margin) in the capsule model
  kNoPath,           ///< no path within the planning budget
};

/// a short phrase for an outcome ("planned", "no goal configuration", "goal in collision", "no path within the
/// budget", "not yet")
const char* PlanOutcomeName(PlanOutcome outcome);

/// Counters since the last Reset.
struct PlanFollowStats {
  PlanOutcome last_outcome = PlanOutcome::kNone;  ///< of the last attempt
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
  /// its joint-space length [rad or m] (0: none).
  double path_length() const { return path_.empty() ? 0.0 : path_s_.back(); }
  /// the seed of the planner from the next Reset on (waits for a plan in flight, which keeps its seed).
  void set_seed(std::uint64_t seed) {
    if (pending_.valid()) pending_.wait();
    planner_.set_seed(seed);
  }
  /// a plan is running beside the loop (options.plan_beside_loop) and has not been switched to yet.
  bool planning() const { return pending_.valid(); }

 private:
  // what a planning attempt needs of the follower, copied when it starts (a plan beside the loop reads nothing of the
  // follower's; it gets its own copy of the scene too)
  struct PlanRequest {
    Eigen::VectorXd q;            // plan from here
    Eigen::VectorXd q_reference;  // then, if that fails, from the reference (empty: not tried)
    bool has_goal = false;        // the goal known before (kept when the scene names none)
    Eigen::VectorXd q_goal;
  };
  // what it found
  struct PlanResult {
    bool has_goal = false;
    Eigen::VectorXd q_goal;
    std::vector<Eigen::VectorXd> path;  // empty: none
    double margin = 0.0;                // the margin the path was planned with
    PlanOutcome outcome = PlanOutcome::kNone;
    int goal_failures = 0;
  };
  // the goal, then the path (uses planner_ and nothing else of this object: it may run on the worker thread)
  PlanResult ComputePlan(const PlanRequest& request, const rmp::Scene& scene);
  // takes a finished attempt's result: the new path, or none
  void AdoptPlan(PlanResult result, double seconds);
  // counts an attempt and records what it was started for
  void BeginAttempt(const rmp::Scene& scene);
  // plans now, or starts a plan beside the loop
  void StartPlan(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);
  // a plan beside the loop: switches to it when it is ready
  void PollPlan();
  // waits for a plan beside the loop and drops it
  void DropPlan();
  // plans from q toward the scene's goal when due; keeps the reference time
  bool GoalMoved(const rmp::Scene& scene) const;
  void Advance(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene, bool control_step);
  void PointAt(double s);                       // q_d_ at arc length s, q̇_d_ at the path speed
  void CornerSpeeds();                          // path_segment_speed_ and path_corner_speed_ of a new path
  // the speed limit `distance` from a waypoint of speed `corner`: up to path_top_speed_ over `length`
  double Ramp(double corner, double distance, double length) const;
  void Reference();                             // q_d_, q̇_d_ of the reference (after Project)
  Eigen::Vector3d EndEffectorAt(const Eigen::Ref<const Eigen::VectorXd>& q);  // uses kin_
  void Project(const Eigen::Ref<const Eigen::VectorXd>& q);  // s_near_: the arm's nearest path point, forward only
  bool RestValid(const rmp::Scene& scene);      // the path from the arm's nearest point on, at the resolution
  void FillFollowScene(const rmp::Scene& scene);
  // the arm's smallest distance at q to an obstacle that moves (∞: none) [m]
  double MovingClearance(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);
  // 0 within yield_near of what moves, 1 beyond yield_far, linear between
  double Yield(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);

  kinematics::Robot robot_;
  std::unique_ptr<control::AccelerationPolicy> reactive_;
  PlanFollowOptions options_;
  RrtPolicy planner_;
  kinematics::Data kin_;
  collision::RobotCollisionModel checker_;
  collision::RobotCollisionData placed_;
  Eigen::VectorXd v_path_;
  PlanFollowStats stats_;

  std::vector<Eigen::VectorXd> path_;
  std::vector<double> path_times_;   // arrival time at each waypoint (open loop) [s]
  std::vector<double> path_s_;       // arc length at each waypoint [rad or m]
  std::vector<double> path_segment_speed_;  // each segment's arc-length speed: its slowest joint at the path speed
  double path_top_speed_ = 0.0;             // the fastest segment's
  std::vector<double> path_corner_speed_;   // the reference's arc-length speed limit at each waypoint
  Eigen::VectorXd q_goal_, q_d_, qd_d_, qdd_d_, q_check_;
  Eigen::VectorXd planned_q_T_;                       // the scene's joint goal when planned (empty: none)
  Eigen::Vector3d planned_p_WT_ = Eigen::Vector3d::Zero();  // its end-effector target then
  Eigen::Vector3d p_WG_ = Eigen::Vector3d::Zero();          // the end effector at q_goal_
  Eigen::Matrix3Xd J_WE_;
  rmp::Scene follow_;         // the reactive layer's scene
  double time_ = 0.0;         // policy clock [s]
  double tau_ = 0.0;          // path time [s] (open loop)
  double s_near_ = 0.0;       // arc length of the arm's nearest path point (reactive)
  double s_ref_ = 0.0;        // arc length of the reference (reactive)
  double yield_ = 1.0;        // Yield() at the last call
  int segment_ = 0;           // the segment holding it
  double last_progress_ = 0.0, last_check_ = 0.0, last_attempt_ = -1e9;
  double plan_margin_ = 0.0;  // the margin the current path was planned with
  // a plan running beside the loop: its result and its wall time [s]
  std::future<std::pair<PlanResult, double>> pending_;
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
