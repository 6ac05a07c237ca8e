#pragma once
/// The MotionBenchMaker benchmark (`rmpmarl benchmark mbm`, docs/benchmarks.md): problems of a MotionBenchMaker-style
/// set — per family folder, sceneNNNN.yaml (a MoveIt planning scene) and requestNNNN.yaml (a motion-plan request with
/// a start state and a joint goal) — each run in MuJoCo for a fixed time by every method behind the one controller
/// interface: RRT-Connect planned once and executed open loop, RMPflow alone, the learned controller alone, and the
/// plan followed by RMPflow or by the learned controller (planning::PlanFollowPolicy). Every controller is given the
/// joint goal (rmp::Scene::q_T) and its end effector as the target (p_WT).
///
/// Two referees judge collisions. The capsules: MuJoCo's contacts of the capsule model the controllers run on (a
/// capsule entering a primitive, or two checked links). The meshes (MbmOptions::meshes): the robot's URDF collision
/// meshes against the scene's primitives with FCL (MeshCollisionModel), at every control step — the field's referee
/// (MotionBenchMaker, MoveIt, VAMP judge on the meshes), independent of the model under test.
///
/// Validity, with the mesh referee: a problem is valid when the meshes are clear of the scene at its start and goal;
/// an invalid one is reported with the pair and depth, not run, and leaves the denominator. A valid problem whose start
/// or goal the capsule model puts in collision (with the scene or itself) is "rejected by the model": not run, a
/// failure of every method, counted in the denominator. Without the mesh referee the capsule model decides validity
/// (and the report says so). Success: the end effector within goal_tolerance of the goal's at the end, no collision
/// event on the capsules and, with the mesh referee, no control step with a mesh in collision.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/experiments/mesh_collision.h"
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
  /// the mesh referee: the robot's collision meshes, checked against the cell (and the crossing spheres) at the start
  /// and goal of every problem and at every control step; it must be available() and of the benchmark's robot. Null:
  /// the capsules alone judge validity and collisions.
  std::shared_ptr<const MeshCollisionModel> meshes;
};

/// What one method did on one problem.
struct MbmResult {
  std::string family;
  int index = 0;
  std::string method;
  bool valid = true;
  /// valid, but the capsule model puts the start or the goal in collision: not run, a failure (mesh referee only)
  bool rejected = false;
  /// why not valid, or why rejected by the model ("" when run): the ends in collision, the pair and the depth
  std::string reason;
  bool success = false;
  bool reached = false;           ///< the end effector within goal_tolerance at the end
  int collisions = 0;             ///< collision events on the capsules (MuJoCo's contacts)
  /// control steps at which a collision mesh was in collision with the cell or a crossing sphere (FCL; the start's
  /// state included); −1: not judged on the meshes (no mesh referee)
  int mesh_collisions = -1;
  /// the meshes' smallest signed distance to the cell or a crossing sphere over the control steps [m], negative in
  /// penetration (+inf: never within MeshCollisionOptions::distance_cap, or not judged on the meshes)
  double min_mesh_clearance = std::numeric_limits<double>::infinity();
  std::string min_mesh_pair;      ///< where min_mesh_clearance was attained: "<link> – <obstacle>" ("" when none)
  double mesh_check_us = 0.0;     ///< mean wall time of the mesh referee per control step [µs]
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
/// spheres (options.moving). Throws InputError for options out of range, or when the problem is not run (not valid,
/// or rejected by the model), with why.
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

/// results.csv (one line per problem × method) and report.md (per family and method: success, collisions on either
/// referee, time to the goal, path length, planning time; the problems not run and why) in `out`; `command` and
/// `setup` head the report, then which referees judged.
void WriteMbmResults(const std::vector<MbmResult>& results, const std::filesystem::path& out,
                     const std::string& command, const std::string& setup);

/// the per family × method table of report.md (markdown): valid problems, the successes among them, those rejected
/// by the model, the episodes with collisions on the capsules and on the meshes.
std::string MbmSummaryTable(const std::vector<MbmResult>& results);

}  // namespace rmpmarl::experiments
