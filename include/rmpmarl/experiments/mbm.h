#pragma once
/// The MotionBenchMaker benchmark (`rmpmarl benchmark mbm`, docs/benchmarks.md): problems of a MotionBenchMaker-style
/// set — per family folder, sceneNNNN.yaml (a MoveIt planning scene) and requestNNNN.yaml (a motion-plan request with
/// a start state and a joint goal) — each run in MuJoCo for a fixed time by every method behind the one controller
/// interface: RRT-Connect planned once and executed open loop, RMPflow alone, the learned controller alone, and the
/// plan followed by RMPflow or by the learned controller (planning::PlanFollowPolicy). Every controller is given the
/// joint goal (rmp::Scene::q_T) and its end effector as the target (p_WT).
///
/// A problem is valid when the robot's capsule model is collision-free (against the scene and itself) at its start
/// and goal; an invalid one is reported, not run. Success: the end effector within goal_tolerance of the goal's at the
/// end, and no collision event (a capsule entering a primitive, or two checked links) during the episode.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/planning/plan_follow.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::experiments {

/// One problem: its family (the folder's name without a trailing `_<robot>`), its number and its two files.
struct MbmProblem {
  std::string family;
  int index = 0;
  std::filesystem::path scene, request;
};

/// the problems under `dir` in family then number order: every <folder>/sceneNNNN.yaml that has a requestNNNN.yaml
/// beside it. `families` (empty: all) selects by family name; `limit` > 0 keeps the first `limit` of each family.
/// Throws InputError naming the folder when it holds no problem or a requested family is absent.
std::vector<MbmProblem> FindMbmProblems(const std::filesystem::path& dir, const std::vector<std::string>& families = {},
                                        int limit = 0);

/// The methods, by their command-line names.
enum class MbmMethod { kRrtConnect, kRmpflow, kLearned, kPlanRmpflow, kPlanLearned };
/// "rrt-connect", "rmpflow", "learned", "plan+rmpflow", "plan+learned".
std::string MbmMethodName(MbmMethod method);
/// the method of a name; throws InputError listing the names.
MbmMethod ParseMbmMethod(const std::string& name);
/// every method, in the report's order.
std::vector<MbmMethod> AllMbmMethods();

struct MbmOptions {
  double duration = 10.0;        ///< simulated time per episode [s], > 0
  double goal_tolerance = 0.02;  ///< success: the end effector within this of the goal's [m], > 0
  std::filesystem::path policy;  ///< the learned controller's file (.rmpp)
  /// the plan follower and its planner (budget, margin, timing); evaluation_period is set from the controller
  planning::PlanFollowOptions plan{};
  std::uint64_t seed = 0;        ///< planner seed of a problem: seed + MbmProblemKey (the same for every method)
  int jobs = 1;                  ///< worker threads; results do not depend on it
  /// the simulated arm's servos add the inverse-dynamics feed-forward of the commanded acceleration
  /// (sim::ServoOptions::inverse_dynamics_feedforward), as a model-based joint controller does; false: the PD alone,
  /// which trails a command that turns a corner at speed by centimetres — through a plan's 1 cm margin to a shelf
  bool servo_feedforward = true;
  /// the dynamic variant: this many spheres cross the way of each problem (0: the static problems). Each crosses the
  /// path RRT-Connect plans for the problem (the open-loop method's, same seed), timed as it is executed: at a time
  /// drawn in [0.25, 0.75] of the path's duration its centre passes through the end effector's position then, on a
  /// horizontal line in a drawn direction, at a speed drawn in [speed_min, speed_max] — so the plan executed open
  /// loop meets it. Drawn from crossing_seed and MbmProblemKey (the same for every method and selection). Each is
  /// avoidable: its way over the episode keeps crossing_clearance from the arm at the start and at the goal (the
  /// time and direction are drawn again until it does, 64 draws in all at most, else the clearest is kept), so that no sphere crosses
  /// the part of the arm that no joint moves (its base, a link on the first joint's axis), and an arm that waited at
  /// the start until the spheres had gone, then went, would meet none.
  int moving = 0;
  double speed_min = 0.5, speed_max = 1.5;  ///< [m/s]
  double moving_radius = 0.05;              ///< [m]
  double crossing_clearance = 0.02;         ///< [m], >= 0
  std::uint64_t crossing_seed = 1;
};

/// What one method did on one problem.
struct MbmResult {
  std::string family;
  int index = 0;
  std::string method;
  bool valid = true;
  std::string invalid_reason;     ///< why not valid ("" when valid)
  bool success = false;
  bool reached = false;           ///< the end effector within goal_tolerance at the end
  int collisions = 0;             ///< collision events
  double time_to_goal = -1.0;     ///< first time the end effector was within goal_tolerance [s]; −1: never
  double final_error = 0.0;       ///< end-effector distance to the goal's at the end [m]
  double joint_error = 0.0;       ///< max_i |q_i − q_goal,i| at the end [rad or m]
  double path_length = 0.0;       ///< joint-space length of the executed motion [rad or m]
  /// the arm's smallest signed distance to the cell or a moving sphere at a control step [m] (+inf: never within
  /// 0.15 m): how close the executed motion passed
  double min_clearance = std::numeric_limits<double>::infinity();
  double planning_time = -1.0;    ///< wall time of the first plan [s]; −1: no planner
  int plans = 0;                  ///< plans attempted
  double control_us = 0.0;        ///< mean controller time per control step [µs]
};

/// a number of the problem's family and index (the same whichever problems a run selects): the planner's and the
/// crossings' seeds of the problem are drawn from it.
std::uint64_t MbmProblemKey(const MbmProblem& problem);

/// the set-up every method of `problem` runs on: its start, joint goal and cell, and the dynamic variant's crossing
/// spheres (options.moving). Throws InputError for options out of range, or when the problem is not valid (start or
/// goal in collision), with why.
sim::StaticSceneOptions MbmProblemScene(const kinematics::Robot& robot, const MbmProblem& problem,
                                        const MbmOptions& options);

/// runs one method on one problem.
MbmResult RunMbmProblem(const kinematics::Robot& robot, const MbmProblem& problem, MbmMethod method,
                        const MbmOptions& options);

/// every method on every problem, on options.jobs threads; `progress` (optional) is called after each problem
/// with the number done. Results are in problem then method order.
std::vector<MbmResult> RunMbmBenchmark(const kinematics::Robot& robot, const std::vector<MbmProblem>& problems,
                                       const std::vector<MbmMethod>& methods, const MbmOptions& options,
                                       const std::function<void(int)>& progress = {});

/// results.csv (one line per problem × method) and report.md (per family and method: success, collisions, time to
/// the goal, path length, planning time) in `out`; `command` and `setup` head the report.
void WriteMbmResults(const std::vector<MbmResult>& results, const std::filesystem::path& out,
                     const std::string& command, const std::string& setup);

/// the per family × method table of report.md (markdown).
std::string MbmSummaryTable(const std::vector<MbmResult>& results);

}  // namespace rmpmarl::experiments
