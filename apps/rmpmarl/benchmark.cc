// `rmpmarl benchmark mbm --problems DIR`: MotionBenchMaker problems (MoveIt planning scenes + motion-plan requests)
// run by RRT-Connect open loop, RMPflow, the learned controller and the plan followed by either (docs/benchmarks.md).
// The benchmark lives in the experiments library, built with the training library.
#ifdef RMPMARL_HAS_TORCH
#include <fmt/format.h>
#include <fmt/ranges.h>

#include <chrono>
#include <sstream>
#include <thread>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/mbm.h"
#include "rmpmarl/experiments/mesh_collision.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/planning/plan_follow.h"

namespace rmpmarl::apps {
namespace {

struct MbmArgs {
  std::string problems, robot, urdf, collision, policy, follow, out = "mbm-results";
  std::vector<std::string> package_paths, methods, families;
  int limit = 0;
  int jobs = 2;
  double duration = 10.0, goal_tolerance = 0.02, planning_budget = 1.0, safety_margin = 0.01;
  int planning_iterations = 0;
  std::uint64_t seed = 0;
  int moving = 0;
  std::vector<double> speed{0.5, 1.5};
  std::uint64_t crossing_seed = 1;
  bool servo_feedforward = true;
  bool mesh_referee = true;
  double mesh_clearance_cap = 0.15;
};

std::string CommandLine(int argc, char** argv) {
  std::string s = "rmpmarl";
  for (int i = 1; i < argc; ++i) s += std::string(" ") + argv[i];
  return s;
}

void RunMbm(const MbmArgs& args, const std::string& command) {
  if (!args.robot.empty() && !args.urdf.empty()) throw InputError("benchmark mbm: --robot and --urdf: give one of them");
  if (!args.collision.empty() && args.urdf.empty()) throw InputError("benchmark mbm: --collision needs --urdf");
  const kinematics::Robot robot = args.urdf.empty()
                                      ? kinematics::LoadShippedRobot(args.robot.empty() ? "panda" : args.robot)
                                      : LoadUserRobot(args.urdf, args.collision, args.package_paths).robot;
  std::vector<experiments::MbmMethod> methods;
  for (const std::string& m : args.methods) methods.push_back(experiments::ParseMbmMethod(m));
  if (methods.empty()) methods = experiments::AllMbmMethods();
  const std::vector<experiments::MbmProblem> problems =
      experiments::FindMbmProblems(args.problems, args.families, args.limit);

  experiments::MbmOptions options;
  options.duration = args.duration;
  options.goal_tolerance = args.goal_tolerance;
  options.policy = args.policy.empty() ? ShippedDefaultPolicyPath() : std::filesystem::path(args.policy);
  options.plan.planner.retry_period = 0.5;
  if (!args.follow.empty()) options.plan = planning::LoadPlanFollowOptions(args.follow, options.plan);
  options.plan.planner.planning_time_budget = args.planning_budget;
  options.plan.planner.planning_iterations = args.planning_iterations;
  options.plan.planner.safety_margin = args.safety_margin;
  options.seed = args.seed;
  options.jobs = args.jobs;
  options.moving = args.moving;
  if (args.speed.empty() || args.speed.size() > 2) {
    throw InputError(fmt::format("--speed: expected one speed or a range MIN MAX [m/s], got {} values", args.speed.size()));
  }
  options.speed_min = args.speed.front();
  options.speed_max = args.speed.back();
  options.crossing_seed = args.crossing_seed;
  options.servo_feedforward = args.servo_feedforward;
  // the mesh referee: the URDF's collision meshes, or why not (said on the terminal and in the report)
  std::string referee;
  if (args.mesh_referee) {
    experiments::MeshCollisionOptions mesh_options;
    mesh_options.distance_cap = args.mesh_clearance_cap;
    for (const std::string& p : args.package_paths) mesh_options.package_paths.emplace_back(p);
    auto meshes = std::make_shared<const experiments::MeshCollisionModel>(robot, mesh_options);
    if (meshes->available()) {
      options.meshes = meshes;
      referee = fmt::format(" Mesh referee: {}, against the cell with FCL at every control step (clearances exact "
                            "within {:g} mm).", meshes->Summary(), 1e3 * mesh_options.distance_cap);
    } else if (meshes->geometry_missing()) {
      throw InputError(fmt::format("--mesh-referee: {} (the URDF's collision meshes judge the benchmark: give their "
                                   "packages' folder with --package-path, or --no-mesh-referee to judge on the "
                                   "capsules alone)", meshes->unavailable_reason()));
    } else {
      referee = fmt::format(" Mesh referee: OFF, {}: validity and collisions are judged on the capsule model alone.",
                            meshes->unavailable_reason());
      fmt::print("WARNING: no mesh referee: {}\n", meshes->unavailable_reason());
    }
  } else {
    referee = " Mesh referee: off (--no-mesh-referee): validity and collisions are judged on the capsule model alone.";
  }

  std::vector<std::string> names;
  for (experiments::MbmMethod m : methods) names.push_back(experiments::MbmMethodName(m));
  std::ostringstream setup;
  setup << fmt::format("Robot '{}' ({} joints, {} capsules; {}). {} problems from {}. Methods: {}. {:g} s per episode; "
                       "success: the end effector within {:g} mm of the goal's at the end and no collision event{}. "
                       "Learned controller: {}. Planner: RRT-Connect on the capsule model with shortcutting, {:g} s "
                       "budget{}, safety margin {:g} mm, seed {} + a key of the problem (its family and index). Plan follower: "
                       "{}. Simulated servos: PD{}. Worker threads: {} (of {} hardware threads here).",
                       robot.name, robot.model.nq(), robot.capsules.size(),
                       robot.urdf_path.empty() ? "built in" : robot.urdf_path.filename().string(), problems.size(),
                       args.problems, fmt::join(names, ", "), options.duration, 1e3 * options.goal_tolerance,
                       options.meshes ? " on the capsules or the meshes" : "", options.policy.filename().string(),
                       options.plan.planner.planning_time_budget,
                       args.planning_iterations > 0 ? fmt::format(" or {} iterations", args.planning_iterations) : "",
                       1e3 * options.plan.planner.safety_margin, options.seed,
                       args.follow.empty() ? "built in" : std::filesystem::path(args.follow).filename().string(),
                       options.servo_feedforward ? " with the inverse-dynamics feed-forward of the commanded acceleration"
                                                 : " alone",
                       options.jobs, std::max(1u, std::thread::hardware_concurrency()));
  setup << referee;
  if (options.moving > 0) {
    setup << fmt::format(" Dynamic variant: {} sphere{} of radius {:g} m cross each problem's open-loop plan at "
                         "{:g}–{:g} m/s (crossing seed {}), each {:g} m clear of the arm at the start and the goal.",
                         options.moving, options.moving == 1 ? "" : "s", options.moving_radius, options.speed_min,
                         options.speed_max, options.crossing_seed, options.crossing_clearance);
  }
  fmt::print("rmpmarl benchmark mbm: {}\n", setup.str());
  const auto start = std::chrono::steady_clock::now();
  const auto results = experiments::RunMbmBenchmark(robot, problems, methods, options, [&](int done) {
    if (done % 10 == 0 || done == static_cast<int>(problems.size())) {
      const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      fmt::print("  {} of {} problems ({:.0f} s)\n", done, problems.size(), s);
      std::fflush(stdout);
    }
  });
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  experiments::WriteMbmResults(results, args.out, command, setup.str());
  int episodes = 0;
  for (const experiments::MbmResult& r : results) episodes += r.valid && !r.rejected;
  fmt::print("\n{}\n{} episodes in {:.1f} s ({:.2f} s per episode on {} thread{})\nwrote {}/results.csv and "
             "{}/report.md\n", experiments::MbmSummaryTable(results), episodes, seconds,
             episodes > 0 ? seconds / episodes : 0.0, options.jobs, options.jobs == 1 ? "" : "s", args.out, args.out);
}

}  // namespace

void RegisterBenchmark(CLI::App& app, int argc, char** argv) {
  CLI::App* bench = app.add_subcommand("benchmark", "Run a benchmark problem set");
  bench->require_subcommand(1);
  auto args = std::make_shared<MbmArgs>();
  CLI::App* mbm = bench->add_subcommand(
      "mbm", "MotionBenchMaker problems (MoveIt planning scenes + motion-plan requests): per family success, "
             "collisions, time to the goal, path length and planning time of RRT-Connect open loop, RMPflow, the "
             "learned controller, plan + RMPflow and plan + learned");
  mbm->add_option("--problems", args->problems, "folder of family folders with sceneNNNN.yaml + requestNNNN.yaml")
      ->required();
  mbm->add_option("--robot", args->robot, "a shipped robot (default panda)");
  mbm->add_option("--urdf", args->urdf, "your robot's URDF (with --collision, or set up in memory)");
  mbm->add_option("--collision", args->collision, "the collision YAML of --urdf");
  mbm->add_option("--package-path", args->package_paths, "folders holding the packages of package:// meshes");
  mbm->add_option("--methods", args->methods,
                  "some of rrt-connect, rmpflow, learned, plan+rmpflow, plan+learned (default: all)")
      ->delimiter(',');
  mbm->add_option("--families", args->families, "only these families (e.g. box,cage)")->delimiter(',');
  mbm->add_option("--limit", args->limit, "the first N problems of each family (0: all)")->check(CLI::NonNegativeNumber);
  mbm->add_option("--duration", args->duration, "simulated seconds per episode")->check(CLI::Range(0.001, 1e4));
  mbm->add_option("--goal-tolerance", args->goal_tolerance, "success radius around the goal's end effector [m]")
      ->check(CLI::Range(1e-4, 1.0));
  mbm->add_option("--policy", args->policy, "the learned controller file (default: the shipped default)");
  mbm->add_option("--follow", args->follow,
                  "the plan follower's options (YAML, as configs/planning/follow.yaml; default: those values)");
  mbm->add_option("--planning-budget", args->planning_budget, "wall-clock budget of one RRT-Connect search [s]")
      ->check(CLI::Range(1e-4, 600.0));
  mbm->add_option("--planning-iterations", args->planning_iterations,
                  "at most this many RRT-Connect iterations per search (0: the time budget alone; > 0 makes runs "
                  "machine-independent)")
      ->check(CLI::NonNegativeNumber);
  mbm->add_option("--safety-margin", args->safety_margin,
                  "the planner's clearance from everything [m] (an end closer than it is planned with half its clearance)")
      ->check(CLI::Range(0.0, 0.5));
  mbm->add_option("--seed", args->seed, "planner seed (a problem uses seed + a key of its family and index)")->check(SeedCheck());
  mbm->add_option("--jobs", args->jobs, "worker threads")->check(CLI::Range(1, 256));
  mbm->add_option("--moving", args->moving, "the dynamic variant: this many spheres cross each problem's way, timed to "
                                            "meet the plan executed open loop (each clear of the arm at the start "
                                            "and the goal: avoidable); spheres of 5 cm, --speed and --crossing-seed "
                                            "say how fast and where")
      ->check(CLI::Range(0, 64))
      ->capture_default_str();
  mbm->add_option("--speed", args->speed, "the crossing spheres' speed, or a range MIN MAX drawn from [m/s]")
      ->expected(1, 2)
      ->check(CLI::Range(1e-3, 20.0))
      ->default_str("0.5 1.5");
  mbm->add_option("--crossing-seed", args->crossing_seed, "seed of the crossings (each problem its own draw)")
      ->check(SeedCheck())
      ->capture_default_str();
  mbm->add_flag("--servo-feedforward,!--no-servo-feedforward", args->servo_feedforward,
               "the simulated arm's servos add the inverse-dynamics feed-forward of the commanded acceleration, as a "
               "model-based joint controller does (default on; off: the PD alone)");
  mbm->add_flag("--mesh-referee,!--no-mesh-referee", args->mesh_referee,
               "judge validity and collisions on the URDF's collision meshes too (FCL, package:// meshes found with "
               "--package-path); default on, and said in the report when the URDF has no meshes to judge on");
  mbm->add_option("--mesh-clearance-cap", args->mesh_clearance_cap,
                  "the meshes' clearance is exact within this distance [m] (min_mesh_clearance_mm: nan beyond it); "
                  "a smaller cap costs less")
      ->check(CLI::Range(1e-3, 1.0));
  mbm->add_option("--out", args->out, "output folder (results.csv, report.md)");
  const std::string command = CommandLine(argc, argv);
  mbm->callback([args, command]() { RunMbm(*args, command); });
}

}  // namespace rmpmarl::apps
#endif  // RMPMARL_HAS_TORCH
