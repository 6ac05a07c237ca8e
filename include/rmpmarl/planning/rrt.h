#pragma once
/// The paper's sampling-based baseline (Wang, Sagawa & Yoshiyasu, IEEE Access 2023, section IV.B–C, Fig. 6b): a
/// joint-space RRT-Connect planner (Kuffner & LaValle, ICRA 2000; OMPL's ompl::geometric::RRTConnect) run as a
/// reactive replanner behind the same control::AccelerationPolicy interface as RMPflow, so control::ReactiveController drives
/// it unchanged.
///
/// One replan: (1) goal configuration by damped-least-squares IK of the end-effector position onto the target
/// (Wampler, IEEE SMC 1986; Nakamura & Hanafusa, J. Dyn. Sys. 1986), from several seeds, keeping collision-free ones;
/// (2) the straight joint-space segment to it when that is collision-free, else RRT-Connect within a wall-clock budget,
/// then shortcutting (Geraerts & Overmars, IJRR 2007) in a deterministic greedy form: from each kept waypoint jump to
/// the farthest later one that a valid straight segment reaches;
/// (3) execution: the path is timed with a constant joint velocity per segment (each segment as fast as the slowest
/// joint allows at path_speed_fraction × its URDF velocity limit) and tracked by the joint-space PD law
///   q̈ = kp (q_d(t) − q) + kd (q̇_d(t) − q̇).
/// Replans happen at the first Evaluate after Reset (Reset sees no scene), whenever replan_period of policy time has
/// passed since the last attempt, and — rate-limited by retry_period — when the current path stops being valid against
/// the obstacles' current poses (re-checked whenever they moved), or after a failed plan. A successful replan replaces
/// the current path unless that one is still valid, still ends within ik_tolerance of the target and is no longer
/// (so fixed-rate replanning does not swap equivalent random paths). Obstacle velocities are ignored (the planner
/// sees a snapshot). A start closer than safety_margin to something (an obstacle came close) is planned from with
/// half its clearance as the margin, so the robot can move away; from a start in penetration no plan is made.
///
/// Validity of a configuration q: the robot collision checker (collision/checker.h) finds every capsule–obstacle,
/// capsule–floor and checked capsule–capsule distance above the margin.
///
/// Continuous joints (±inf limits) are planned within [q_i − π, q_i + π] around the configuration at the start of each
/// plan: every angle is reachable once, the short way round.
///
/// Determinism: RRT-Connect's only random choice is its uniform state sampler (its GNAT nearest-neighbour trees use
/// randomness for their structure only; their answers are exact); the sampler here is a
/// RealVectorStateSampler whose ompl::RNG gets a local seed (RNG::setLocalSeed) derived from `seed` and the plan
/// index, so plans do not depend on OMPL's process-wide seed (RNG::setSeed, settable once per process) nor on other
/// instances. IK seeds come from a std::mt19937_64 re-seeded at every Reset. A run is reproducible as long as every
/// plan finishes within planning_time_budget (a plan cut by the wall clock depends on the machine's speed).
///
/// Evaluate allocates nothing between replans; a replan allocates (OMPL's trees, the new path). Constructing an
/// RrtPolicy raises OMPL's process-wide log level to warnings (OMPL logs every plan at info level).
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/collision/checker.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/planning/path_timing.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/control/controller.h"

namespace rmpmarl::planning {

/// Options of RrtPolicy (times in seconds, distances in metres, joint distances in rad or m).
struct RrtOptions {
  /// time between Evaluate calls [s]: the controller's substep (ReactiveController::substep()) under
  /// PolicyInput::kCommanded, its control period under kMeasured. The policy's clock is calls × this.
  double evaluation_period = 0.01;
  /// fixed replanning period [s] of policy time (the paper's baseline replans at a fixed rate).
  double replan_period = 0.2;
  /// least time [s] between a failed or invalidated plan and the next attempt (the robot brakes meanwhile).
  double retry_period = 0.05;
  /// wall-clock budget of one RRT-Connect search [s] (OMPL planner termination condition).
  double planning_time_budget = 0.05;
  /// the most RRT-Connect iterations of one search (0: no limit but the time budget); a search ends at whichever
  /// budget runs out first. With a time budget that never runs out, a search is the same on any machine.
  int planning_iterations = 0;
  /// IK starts per replan: the current q, the previous goal (when there is one), then uniform random configurations.
  int ik_seeds = 8;
  /// damped-least-squares iterations per seed.
  int ik_iterations = 100;
  /// damping λ [m] of the DLS step Δq = Jᵀ (J Jᵀ + λ² I)⁻¹ e.
  double ik_damping = 0.05;
  /// largest |Δq_i| of one DLS step [rad or m]; longer steps are scaled down.
  double ik_max_step = 0.2;
  /// an IK solution counts when its end effector is within this of the target [m].
  double ik_tolerance = 0.005;
  /// check the capsules against the floor plane z = floor_height (turn off for planar arms in the z = 0 plane).
  bool check_floor = true;
  double floor_height = 0.0;  ///< [m]
  /// a configuration is valid when every checked signed distance exceeds this [m], ≥ 0.
  double safety_margin = 0.01;
  /// PlanPath from or to an end inside safety_margin plans with half that end's clearance as the margin: 0 the whole
  /// path, > 0 only within this joint-space distance of that end [rad or m], the margin growing linearly back to
  /// safety_margin over it (a goal at a grasp then does not let the whole path graze the shelf).
  double end_margin_distance = 0.0;
  /// motion checks test states at most this far apart along straight joint-space segments (Euclidean norm in q)
  /// [rad or m]; OMPL gets it as its longest-valid-segment fraction.
  double validity_resolution = 0.01;
  /// the path is timed at this fraction of the URDF velocity limits, in (0, 1].
  double path_speed_fraction = 0.5;
  /// after the greedy shortcut over the waypoints, this many random shortcuts between two points drawn on the path
  /// (kept when the straight segment between them is valid), ≥ 0; drawn from the plan's seed, so a plan stays a
  /// function of (problem, seed).
  int shortcut_iterations = 0;
  /// RRT-Connect's longest extension [rad or m], >= 0 (0: OMPL's own, a fifth of the joint space's diagonal,
  /// ≈ 2.5 rad on a 7-joint arm; shorter steps find their way out of shelves and cages more often).
  double range = 0.0;
  double kp = 100.0;  ///< PD stiffness of path tracking [1/s²], > 0
  double kd = 20.0;   ///< PD damping [1/s], > 0 (critical for kp = 100); also the braking gain when there is no path
  std::uint64_t seed = 0;  ///< IK seeds and RRT sampling (see the file comment on determinism)
};

/// throws InputError (field, expected vs got) unless every option is finite and in range.
void ValidateRrtOptions(const RrtOptions& options);

/// Counters since the last Reset.
struct RrtStats {
  int plans_attempted = 0;   ///< replans started (IK + planning)
  int plans_succeeded = 0;   ///< replans that produced a path (adopted or not)
  int ik_failures = 0;       ///< replans where no valid IK solution reached the target within ik_tolerance
  int invalidations = 0;     ///< times the current path became invalid against moved obstacles
  std::vector<double> planning_times_s;  ///< wall time of every replan (IK + RRT + shortcut) [s]
};

/// Result of SolveIk.
struct IkResult {
  bool found = false;        ///< some seed ended in a valid configuration
  bool reached = false;      ///< ... with the end effector within ik_tolerance of the target
  Eigen::VectorXd q;         ///< the chosen configuration (closest to q_start among the reached, else smallest error)
  double error = 0.0;        ///< its end-effector distance to the target [m]
};

/// The pair of shapes that attains a configuration's clearance (RrtPolicy::ClearanceWithPair).
using ClearancePair = collision::ClearancePair;

/// The RRT baseline as an acceleration policy (see the file comment).
class RrtPolicy final : public control::AccelerationPolicy {
 public:
  /// a planner for (a copy of) `robot`. Throws InputError for bad options (ValidateRrtOptions) or a dof without a
  /// finite velocity limit > 0.
  RrtPolicy(const kinematics::Robot& robot, const RrtOptions& options = {});
  ~RrtPolicy() override;
  RrtPolicy(const RrtPolicy&) = delete;
  RrtPolicy& operator=(const RrtPolicy&) = delete;

  /// q̈ for the joint state (q, q̇) in `scene`: PD tracking of the current path, −kd q̇ without one (or without a
  /// target). Replans when due (see the file comment).
  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override;
  /// starts an episode: drops the path, zeroes the clock and the statistics, re-seeds the RNGs; the first Evaluate
  /// plans.
  void Reset(const Eigen::Ref<const Eigen::VectorXd>& q0) override;
  std::string name() const override { return "rrt"; }
  int nq() const override;

  const RrtOptions& options() const;
  const RrtStats& stats() const;
  /// the seed used from the next Reset on (e.g. the episode seed).
  void set_seed(std::uint64_t seed);
  /// waypoints of the path being executed, from its start to its goal (empty: none).
  const std::vector<Eigen::VectorXd>& path() const;

  // The building blocks, for tests and tools (not real-time). Each takes the obstacles from `scene` (as a replan
  // would) and checks with safety_margin.

  /// smallest signed distance [m] at q over the capsule–obstacle, capsule–floor and checked capsule–capsule pairs.
  double Clearance(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);
  /// the same clearance with the pair attaining it (the first pair found at that distance), for messages that say
  /// what touches what.
  ClearancePair ClearanceWithPair(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);
  /// Clearance(q, scene) > safety_margin, and q within the joint limits.
  bool IsStateValid(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene);
  /// the same with another margin (e.g. last_plan_margin(), to check a path against what it was planned with).
  bool IsStateValid(const Eigen::Ref<const Eigen::VectorXd>& q, const rmp::Scene& scene, double margin);
  /// every state of the straight segment a → b at most validity_resolution apart (a excluded, b included) lies within
  /// the joint limits and has a clearance above `margin`: IsStateValid(state, scene, margin) for each.
  bool IsSegmentValid(const Eigen::VectorXd& a, const Eigen::VectorXd& b, const rmp::Scene& scene, double margin);
  /// the margin the last PlanPath planned with (safety_margin, or half the smaller end clearance).
  double last_plan_margin() const;
  /// a valid configuration whose end effector is at scene.p_WT, IK seeded from q_start (then random seeds).
  IkResult SolveIk(const Eigen::Ref<const Eigen::VectorXd>& q_start, const rmp::Scene& scene);
  /// a valid path q_start → q_goal (straight when possible, else RRT-Connect + shortcutting): its waypoints with
  /// straight segments checked at validity_resolution; empty when none was found within the budget or an end is
  /// invalid. An end closer than safety_margin to something (but not touching it) is planned with half the smaller
  /// end clearance as the margin.
  std::vector<Eigen::VectorXd> PlanPath(const Eigen::Ref<const Eigen::VectorXd>& q_start,
                                        const Eigen::Ref<const Eigen::VectorXd>& q_goal, const rmp::Scene& scene);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rmpmarl::planning
