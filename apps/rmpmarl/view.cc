// `rmpmarl view`: the live viewer (docs/viewer.md) — a simulation in real time, served to browsers that watch and
// steer it; or a recorded episode played back.
#include <fmt/core.h>

#include <atomic>
#include <csignal>
#include <optional>
#include <filesystem>
#include <thread>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/planning/planning_scene.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/viewer/live_sim.h"
#include "rmpmarl/viewer/realtime.h"
#include "rmpmarl/viewer/recording.h"
#include "rmpmarl/viewer/server.h"
#include "rmpmarl/viewer/visuals.h"

namespace rmpmarl::apps {
namespace {

struct ViewArgs {
  std::string robot = "panda";
  std::string urdf, collision;
  std::string policy;  // "" the shipped default, "rmpflow" RMPflow alone, else a controller file
  std::string scenario = std::string(sim::kDefaultScenario);
  std::uint64_t seed = 0;
  bool side_by_side = false;
  bool plan = false;
  bool plan_beside_loop = false;
  std::optional<double> obstacle_speed, target_speed;
  std::optional<int> num_obstacles;
  std::string host = "127.0.0.1";
  int port = 8080;
  double fps = 30.0;
  std::string replay;
  std::string scene, request;  // a MoveIt planning scene and motion-plan request instead of the scenario
  std::vector<std::string> package_paths;  // where package:// meshes are looked up
  std::string web_root;
  double duration = 0.0;  // wall seconds to serve; 0: until interrupted
  bool paused = false;
};

std::atomic<bool> g_interrupted{false};
void OnSignal(int) { g_interrupted = true; }

void RunView(const ViewArgs& args) {
  std::unique_ptr<viewer::FrameSource> source;
  std::string what;
  std::map<std::string, std::string> extra_files;  // the robot's meshes
  if (!args.replay.empty()) {
    auto replay = std::make_unique<viewer::ReplaySource>(args.replay);
    what = fmt::format("replay of '{}' ({} frames)", args.replay, replay->num_frames());
    source = std::move(replay);
  } else {
    const kinematics::Robot robot = !args.urdf.empty()
                                        ? LoadUserRobot(args.urdf, args.collision, args.package_paths).robot
                                        : kinematics::LoadShippedRobot(args.robot);
    std::shared_ptr<const control::PolicyFile> file;
    std::string policy_path;
    if (args.policy != "rmpflow") {
      policy_path = !args.policy.empty() ? args.policy : ShippedDefaultPolicyPath().string();
      file = std::make_shared<const control::PolicyFile>(control::LoadPolicyFile(policy_path));
    }
    viewer::VisualOptions visual_options;
    visual_options.package_paths = args.package_paths;
    viewer::RobotVisuals visuals = viewer::LoadRobotVisuals(robot, visual_options);
    for (const std::string& w : visuals.warnings) fmt::print("rmpmarl view: visuals: {}\n", w);
    extra_files = std::move(visuals.files);
    viewer::LiveSimOptions options;
    options.visuals = std::move(visuals.shapes);
    options.scenario = args.scenario;
    options.seed = args.seed;
    options.overrides.obstacle_speed = args.obstacle_speed;
    options.overrides.target_speed = args.target_speed;
    options.overrides.num_obstacles = args.num_obstacles;
    options.controller = file ? "learned" : "rmpflow";
    options.side_by_side = args.side_by_side;
    options.plan = args.plan || args.plan_beside_loop;
    options.plan_beside_loop = args.plan_beside_loop;
    std::string scene_name = fmt::format("scenario '{}'", args.scenario);
    if (!args.scene.empty()) {
      const planning::PlanningScene scene = planning::ReadPlanningScene(args.scene, robot.model.link(0).name);
      std::optional<planning::MotionPlanRequest> request;
      if (!args.request.empty()) request = planning::ReadMotionPlanRequest(args.request);
      options.scene = sim::StaticSceneOf(robot, scene, request ? &*request : nullptr, args.request);
      options.max_obstacles = static_cast<int>(options.scene->obstacles.size()) + 8;
      scene_name = fmt::format("scene '{}' ({} objects, {} primitives){}", args.scene, scene.objects.size(),
                               options.scene->obstacles.size(),
                               request ? fmt::format(", start and goal of '{}'", args.request) : std::string());
      for (const std::string& ignored : scene.ignored) fmt::print("rmpmarl view: {}: not shown\n", ignored);
    }
    auto live = std::make_unique<viewer::LiveSim>(robot, file, policy_path, options);
    what = fmt::format("{} ({} dof), {}, {}{}", robot.name, robot.model.nq(), scene_name,
                       file ? policy_path : std::string("RMPflow"), args.side_by_side ? " beside RMPflow" : "");
    source = std::move(live);
  }

  viewer::RealtimeOptions loop_options;
  loop_options.fps = args.fps;
  loop_options.start_paused = args.paused;
  viewer::Server* server_ptr = nullptr;
  viewer::Realtime loop(
      *source, loop_options,
      [&](std::shared_ptr<const std::string> frame) {
        if (server_ptr != nullptr) server_ptr->Broadcast(std::move(frame), /*droppable=*/true);
      },
      [&](std::shared_ptr<const std::string> hello) {
        if (server_ptr != nullptr) server_ptr->Broadcast(std::move(hello), /*droppable=*/false);
      });
  viewer::ServerOptions server_options;
  server_options.host = args.host;
  server_options.port = args.port;
  server_options.web_root = viewer::DefaultWebRoot(args.web_root);
  server_options.extra_files = std::move(extra_files);
  viewer::Server server(server_options, loop);
  server_ptr = &server;
  server.Start();
  fmt::print("rmpmarl view: {}\n", what);
  fmt::print("rmpmarl view: serving {} (open it in a browser; Ctrl-C stops)\n", server.url());
  if (args.host != "127.0.0.1" && args.host != "::1") {
    fmt::print("rmpmarl view: listening on {} — other machines can reach this viewer and steer the simulation\n",
               args.host);
  }
  std::fflush(stdout);

  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  std::thread sim([&] {
    try {
      loop.Run();
    } catch (const std::exception& e) {
      fmt::print(stderr, "rmpmarl view: the simulation stopped on an error: {}\n", e.what());
      g_interrupted = true;
    }
  });
  const auto start = std::chrono::steady_clock::now();
  while (!g_interrupted) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    if (args.duration > 0.0 &&
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() >= args.duration) {
      break;
    }
  }
  loop.Stop();
  sim.join();
  server.Stop();
  const viewer::ServerCounters s = server.counters();
  const viewer::RealtimeCounters& c = loop.counters();
  fmt::print("rmpmarl view: stopped at t = {:.2f} s simulated; {} frames, {} messages applied, {} refused, {} "
             "overruns; {} pages connected, {} frames dropped for slow pages, {} bad HTTP requests\n",
             source->time(), c.frames.load(), c.accepted.load(), c.refused.load(), c.overruns.load(), s.connections,
             s.dropped_frames, s.bad_requests);
}

}  // namespace

void RegisterView(CLI::App& app) {
  auto* cmd = app.add_subcommand("view", "Watch and steer a controller live in the browser (docs/viewer.md)");
  static ViewArgs args;
  AddRobotAndScenarioOptions(cmd, &args.robot, &args.urdf, &args.collision, &args.scenario, &args.seed);
  cmd->add_option("--policy", args.policy,
                  "a controller file (.rmpp) (default: the shipped models/policies/marl-rmp-residual.rmpp); rmpflow: "
                  "RMPflow alone");
  cmd->add_flag("--side-by-side", args.side_by_side, "the learned controller and RMPflow on two arms, same scene");
  cmd->add_flag("--plan", args.plan, "plan, then react: the controllers follow RRT-Connect joint paths to the target "
                                     "(docs/benchmarks.md)");
  cmd->add_flag("--plan-beside-loop", args.plan_beside_loop,
                "--plan with the plans made on a worker thread: a long plan does not hold the live view (the arms go "
                "for the goal alone until their plan is ready; not reproducible step for step)");
  cmd->add_option("--obstacle-speed", args.obstacle_speed, "obstacle speed [m/s]")->check(CLI::Range(0.0, 20.0));
  cmd->add_option("--target-speed", args.target_speed, "target speed [m/s]")->check(CLI::Range(0.0, 5.0));
  cmd->add_option("--obstacles", args.num_obstacles, "number of scenario obstacles")->check(CLI::Range(0, 16));
  cmd->add_option("--host", args.host, "IP address to listen on (0.0.0.0: every interface)")->capture_default_str();
  cmd->add_option("--port", args.port, "port (0: any free one)")->check(CLI::Range(0, 65535))->capture_default_str();
  cmd->add_option("--fps", args.fps, "frames sent per second")->check(CLI::Range(1.0, 120.0))->capture_default_str();
  cmd->add_option("--replay", args.replay, "play back a replay file (rmpmarl demo --record, or the page's record)");
  cmd->add_option("--scene", args.scene, "a MoveIt planning scene (YAML: world.collision_objects with box, sphere and "
                                         "cylinder primitives) instead of the scenario");
  cmd->add_option("--package-path", args.package_paths,
                  "with --urdf: folders holding the packages of its package:// meshes (as benchmark mbm takes them)");
  cmd->add_option("--request", args.request, "with --scene: a MoveIt motion-plan request whose start the arm takes "
                                             "and whose goal's end effector is the target");
  cmd->add_option("--web-root", args.web_root, "directory of the built page (default: the build's or installed one)");
  cmd->add_option("--duration", args.duration, "stop after this many wall seconds (0: at Ctrl-C)")
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_flag("--paused", args.paused, "start paused");
  cmd->callback([] {
    if (args.urdf.empty() && !args.collision.empty()) throw InputError("--collision needs --urdf");
    if (!args.replay.empty() && (args.side_by_side || !args.policy.empty() || !args.urdf.empty())) {
      throw InputError("--replay plays a recorded episode: --policy, --urdf and --side-by-side do not apply");
    }
    if (!args.request.empty() && args.scene.empty()) throw InputError("--request needs --scene");
    if (!args.scene.empty() && !args.replay.empty()) throw InputError("--scene and --replay: give one of them");
    if (args.side_by_side && args.policy == "rmpflow") {
      throw InputError("--side-by-side shows the learned controller beside RMPflow: give it a controller file, not "
                       "--policy rmpflow");
    }
    RunView(args);
  });
}

}  // namespace rmpmarl::apps
