// `rmpmarl demo`: the README's main job — a robot tracks a moving target while obstacles cross its workspace, in
// MuJoCo: the shipped learned per-joint agents and RMPflow on the same episode of the same scene (or RMPflow alone),
// through the one episode loop (tasks::ControllerEpisodes); summaries in words, videos and a replay.
#include <fmt/core.h>
#include <fmt/ranges.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/math/statistics.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/tasks/task_context.h"
#include "rmpmarl/tasks/task_episode.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/planning/plan_follow.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/render.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/sim/world.h"
#include "rmpmarl/viewer/recording.h"

namespace rmpmarl::apps {
namespace {

struct DemoArgs {
  std::string robot = "panda";
  std::string urdf, collision;  // a user robot instead of a shipped one
  std::string scenario = std::string(sim::kDefaultScenario);
  std::uint64_t seed = 0;
  double duration = 0.0;  // 0: the scenario's default
  std::string video;      // empty: no video
  double fps = 30.0;
  int width = 960, height = 720;
  std::optional<double> obstacle_speed, target_speed;
  std::optional<int> num_obstacles;
  std::string policy;  // a controller file (.rmpp) beside RMPflow, or "rmpflow" alone
  std::string record;  // a replay file for `rmpmarl view --replay` ("" none)
  bool plan = false;   // both controllers follow an RRT-Connect plan (planning::PlanFollowPolicy)
  int episodes = 1;    // > 1: that many episodes per controller (seeds seed, seed + 1, ...) and a success table
  PerceptionArgs perception;
};

// the controller's policy, behind a plan follower with --plan
std::unique_ptr<control::AccelerationPolicy> MaybePlanned(const DemoArgs& args, const kinematics::Robot& robot,
                                                          std::unique_ptr<control::AccelerationPolicy> policy,
                                                          const control::ControllerOptions& controller) {
  if (!args.plan) return policy;
  return planning::MakePlanFollower(robot, std::move(policy), controller);
}

// obstacle slots of the controllers: the scene's, or the sensor's clusters with --perception depth
int ObstacleSlots(const DemoArgs& args, int scene_obstacles) {
  return UsesSensor(args.perception) ? std::max(scene_obstacles, control::CloudObstacleOptions{}.max_obstacles)
                                     : scene_obstacles;
}

void PrintSensorSummary(const sim::SensorSummary& s, const std::string& label) {
  fmt::print("  camera {:<20} {} frames, {:.0f} µs per frame (render, back-project, cloud), {:.0f} points ({:.0f} "
             "remembered while hidden) and {:.1f} obstacles per frame; velocity error {:.3f} m/s mean, {:.3f} m/s p90 ({} matches), {:.3f} m/s mean "
             "over obstacles followed for 2 frames or more ({} matches)\n",
             label, s.updates, s.update_mean_us, s.points_mean, s.hidden_mean, s.obstacles_mean, s.velocity_error_mean,
             s.velocity_error_p90, s.velocity_samples, s.velocity_error_tracked_mean, s.velocity_samples_tracked);
}

// the hello of a recorded demo episode
std::string DemoHello(const kinematics::Robot& robot, const sim::Scenario& scenario, std::vector<viewer::ArmLabel> arms,
                      double control_rate, std::uint64_t seed) {
  viewer::HelloInfo info;
  info.mode = "replay";
  info.arms = std::move(arms);
  info.controller = info.arms.front().controller;
  info.side_by_side = info.arms.size() > 1;
  info.workspace_min = scenario.workspace().box.min();
  info.workspace_max = scenario.workspace().box.max();
  info.control_rate = control_rate;
  info.scenario = scenario.name();
  info.seed = seed;
  return viewer::EncodeHello(robot, info);
}

sim::RenderOptions CameraFor(const sim::Workspace& ws, const DemoArgs& args) {
  return sim::CameraForWorkspace(ws, args.width, args.height);
}

// What one controller did in the demo's episode.
struct DemoRun {
  std::string label;
  tasks::EpisodeMetrics metrics;
  std::string video;     // written file ("" none)
  std::optional<sim::SensorSummary> sensor;
  std::vector<std::string> frames;  // recorded frames (--record)
};

// runs the demo's episode (seeded with args.seed: every controller of the demo sees the same episode) with
// `runner`'s controller; renders it to `video_path` when given and records its frames when `record`.
DemoRun RunDemoEpisode(tasks::ControllerEpisodes& runner, const std::string& label, const std::string& video_path,
                       const DemoArgs& args, bool record, control::LearnedController* const* learned = nullptr) {
  std::mt19937_64 rng(args.seed);
  std::unique_ptr<sim::OffscreenRenderer> renderer;
  std::unique_ptr<sim::VideoWriter> video;
  std::vector<std::uint8_t> rgb;
  bool render = !video_path.empty();
  DemoRun run{label, {}, "", std::nullopt, {}};
  tasks::RunOptions options;
  if (render || record) {
    options.video_fps = args.fps;
    options.on_frame = [&](const sim::FrameInfo& frame) {
      if (render && !renderer) {  // at the first frame, when the episode's scene is drawn
        std::string why_not;
        renderer = sim::OffscreenRenderer::Create(frame.world->mj_model(),
                                                  CameraFor(frame.scenario->workspace(), args), &why_not);
        if (renderer == nullptr) {
          fmt::print("video: offscreen rendering is not possible here ({}); running without video\n", why_not);
          render = false;
        } else {
          video = std::make_unique<sim::VideoWriter>(video_path, args.width, args.height, args.fps);
        }
      }
      if (video) {
        const Eigen::Matrix3Xd* points = frame.sensor != nullptr ? &frame.sensor->points() : nullptr;
        renderer->Render(frame.world->mj_data(), &rgb, points, 0.5 * args.perception.voxel);
        video->AddFrame(rgb);
      }
      if (record) {
        viewer::ArmView arm;
        arm.world = frame.world;
        arm.warnings = frame.warnings;
        arm.learned = learned != nullptr ? *learned : nullptr;  // made with the controller at the episode's start
        run.frames.push_back(viewer::ScenarioFrame(frame.index, frame.time, *frame.scenario, {arm}));
      }
    };
  }
  run.metrics = runner.Run(rng, options);
  if (runner.sensor() != nullptr) run.sensor = runner.sensor()->Summary();
  if (video) {
    const bool mp4 = video->writes_mp4();
    run.video = video->Close().string();
    if (!mp4) run.video += " (ffmpeg not found: PNG frames instead of an MP4)";
  }
  return run;
}

// The demo's task: the scene of --scenario on the demo's robot, the same for every controller. The arm tasks' scenes
// (crossing, line-crossing, cluttered) come with the controller file's task moved there (RMPflow alone runs the
// shipped default's, so `--policy rmpflow` sees the scene the comparison shows); the other scenes run on the
// reach-avoid task's clock with the registered scene in place of the task's.
struct DemoTask {
  tasks::TaskConfig config;
  tasks::ScenarioMaker scenario;  // empty: the task's own scene
  std::optional<control::PolicyFile> file;  // the learned controller's, when one runs
};

DemoTask MakeDemoTask(const DemoArgs& args, const std::optional<std::string>& policy_path) {
  DemoTask t;
  const std::string robot = !args.urdf.empty() ? args.urdf : args.robot;
  const bool task_scene = tasks::IsArmTaskScene(args.scenario);
  if (policy_path) {
    t.file = control::LoadPolicyFile(*policy_path);
    if (!t.file->has_task()) {
      throw InputError(fmt::format("--policy {}: the file carries no task (a policy of a task outside the manipulator "
                                   "tasks), so demo has no scene to run it in; evaluate it on its task with "
                                   "`rmpmarl eval {} --task NAME`", *policy_path, *policy_path));
    }
  }
  const std::string config_source = policy_path ? *policy_path : ShippedDefaultPolicyPath().string();
  if (task_scene && (policy_path || std::filesystem::exists(config_source))) {
    const control::PolicyFile file = policy_path ? *t.file : control::LoadPolicyFile(config_source);
    rl::TaskMove move;
    move.robot = robot;
    move.collision = args.collision;
    move.scene = args.scenario;
    if (args.obstacle_speed) move.obstacle_speed = *args.obstacle_speed;
    t.config = rl::PolicyTaskConfig(file, config_source, move);
  } else {
    if (!sim::HasScenario(args.scenario)) {
      throw InputError(fmt::format("--scenario {}: expected one of the scenes {}", args.scenario,
                                   fmt::join(sim::ScenarioNames(), ", ")));
    }
    if (policy_path) {  // a learned controller runs in the arm tasks' scenes only: says so
      rl::TaskMove move;
      move.scene = args.scenario;
      rl::PolicyTaskConfig(*t.file, *policy_path, move);
    }
    t.config = tasks::LoadShippedTaskConfig(task_scene ? std::string(tasks::TaskKindName(
                                                             tasks::TaskOfScene(args.scenario)))
                                                       : std::string("reach-avoid"));
    t.config.robot = robot;
    t.config.collision = args.collision;
    t.config.randomization.initial_q_spread = 0.0;
    t.config.randomization.initial_qd_fraction = 0.0;
    if (!task_scene) {
      sim::ScenarioOverrides overrides{args.obstacle_speed, args.target_speed, args.num_obstacles};
      t.scenario = [name = args.scenario, overrides](const kinematics::Robot& r) {
        return sim::MakeScenario(name, r, overrides);
      };
    }
  }
  tasks::TaskConfig& config = t.config;
  if (!t.scenario) {
    if (args.num_obstacles) {
      if (config.task != tasks::TaskKind::kReachAvoid) {
        throw InputError(fmt::format("--obstacles: the number of obstacles is set in the crossing scene only (the {} "
                                     "scene has its own)", args.scenario));
      }
      config.scenario.crossing.num_obstacles = *args.num_obstacles;
    }
    if (args.target_speed) {
      if (config.task != tasks::TaskKind::kReachAvoid) {
        throw InputError(fmt::format("--target-speed: the crossing scene only (the {} scene's target is set by the "
                                     "scene)", args.scenario));
      }
      config.scenario.crossing.target_speed = *args.target_speed;
    }
    if (args.obstacle_speed && !policy_path && !std::filesystem::exists(config_source)) {
      config.scenario.crossing.obstacle_speed = *args.obstacle_speed;
      config.scenario.line_speeds = {*args.obstacle_speed};
    }
  }
  double duration = args.duration;
  if (!(duration > 0.0) && t.scenario) duration = t.scenario(tasks::NominalTaskRobot(config))->default_duration();
  if (duration > 0.0) {
    config.episode.max_steps = std::max(1, static_cast<int>(std::lround(duration * config.episode.control_rate)));
  }
  config.observation.max_obstacles = std::max(config.observation.max_obstacles, 6);
  config.randomization.variants = 1;  // the nominal robot
  return t;
}

// what happened, one column per controller, in words that cannot mislead: reached (and how close), collision-free.
void PrintDemoTable(const std::vector<DemoRun>& runs, const tasks::TaskConfig& config) {
  auto mm = [](double v) { return std::isfinite(v) ? fmt::format("{:.1f} mm", 1000.0 * v) : std::string("–"); };
  auto row = [&](const std::string& name, const auto& cell) {
    std::string line = fmt::format("  {:<26}", name);
    for (const DemoRun& r : runs) line += fmt::format("{:>24}", cell(r.metrics));
    fmt::print("{}\n", line);
  };
  const double tolerance = tasks::TaskLoopOptions(config).reach_tolerance;
  fmt::print("\n");
  std::string header = fmt::format("  {:<26}", "");
  for (const DemoRun& r : runs) header += fmt::format("{:>24}", r.label);
  fmt::print("{}\n", header);
  using M = tasks::EpisodeMetrics;
  row("tracking error (mean)", [&](const M& m) { return mm(m.mean_tracking_error); });
  row(fmt::format("settled (t >= {:g} s)", tasks::kSettleTime), [&](const M& m) { return mm(m.settled_tracking_error); });
  row("final error", [&](const M& m) { return mm(m.final_tracking_error); });
  row("min clearance", [&](const M& m) {
    return std::isfinite(m.min_clearance) ? mm(m.min_clearance) : std::string("none within 15 cm");
  });
  row("collision events", [](const M& m) { return fmt::format("{} ({} self)", m.collisions, m.self_collisions); });
  row("control step", [](const M& m) { return fmt::format("{:.1f} µs", m.mean_control_us); });
  row(fmt::format("reached (within {:.0f} mm)", 1000.0 * tolerance), [](const M& m) {
    return m.invalid ? std::string("INVALID") : m.reached ? std::string("yes") : std::string("NO");
  });
  row("collision-free", [](const M& m) {
    return m.collisions == 0 ? std::string("yes") : fmt::format("NO ({} events)", m.collisions);
  });
  for (const DemoRun& r : runs) {
    if (r.metrics.nonfinite_policy_outputs > 0) {
      fmt::print("  WARNING {}: {} non-finite policy outputs (position held)\n", r.label,
                 r.metrics.nonfinite_policy_outputs);
    }
    if (r.metrics.invalid) fmt::print("  WARNING {}: the episode ended early on a non-finite state\n", r.label);
  }
}

// Many episodes of each controller (seeds args.seed, args.seed + 1, …: the same episodes for every controller): a
// success — the goal reached without a collision, as the benchmarks count it — with its Wilson 95 % interval, and
// the medians of what the successes took.
struct DemoSeries {
  std::string label;
  std::vector<tasks::EpisodeMetrics> episodes;
  std::string video;  // of the first episode
};

void PrintDemoSeries(const std::vector<DemoSeries>& series, const tasks::TaskConfig& config) {
  const double tolerance = tasks::TaskLoopOptions(config).reach_tolerance;
  auto row = [&](const std::string& name, const auto& cell) {
    std::string line = fmt::format("  {:<30}", name);
    for (const DemoSeries& s : series) line += fmt::format("{:>30}", cell(s));
    fmt::print("{}\n", line);
  };
  auto succeeded = [](const tasks::EpisodeMetrics& m) { return m.reached && m.collisions == 0 && !m.invalid; };
  fmt::print("\n");
  std::string header = fmt::format("  {:<30}", "");
  for (const DemoSeries& s : series) header += fmt::format("{:>30}", s.label);
  fmt::print("{}\n", header);
  row(fmt::format("success [95 % CI]"), [&](const DemoSeries& s) {
    const int n = static_cast<int>(s.episodes.size());
    const int k = static_cast<int>(std::count_if(s.episodes.begin(), s.episodes.end(), succeeded));
    const math::Interval ci = math::WilsonInterval(k, n);
    return fmt::format("{}/{} {:.0f} % [{:.0f}, {:.0f}]", k, n, 100.0 * k / n, 100.0 * ci.low, 100.0 * ci.high);
  });
  row(fmt::format("reached (within {:.0f} mm)", 1000.0 * tolerance), [](const DemoSeries& s) {
    return fmt::format("{}", std::count_if(s.episodes.begin(), s.episodes.end(),
                                           [](const tasks::EpisodeMetrics& m) { return m.reached; }));
  });
  row("with a collision", [](const DemoSeries& s) {
    return fmt::format("{}", std::count_if(s.episodes.begin(), s.episodes.end(),
                                           [](const tasks::EpisodeMetrics& m) { return m.collisions > 0; }));
  });
  row("time to reach (median, successes)", [&](const DemoSeries& s) {
    std::vector<double> t;
    for (const tasks::EpisodeMetrics& m : s.episodes) {
      if (succeeded(m)) t.push_back(m.time_to_reach);
    }
    const double v = math::FiniteMedian(t);
    return std::isfinite(v) ? fmt::format("{:.2f} s", v) : std::string("–");
  });
  row("control step (mean)", [](const DemoSeries& s) {
    double sum = 0.0;
    for (const tasks::EpisodeMetrics& m : s.episodes) sum += m.mean_control_us;
    return fmt::format("{:.1f} µs", sum / static_cast<double>(s.episodes.size()));
  });
}

// the demo: one episode of the scene, with the learned agents of a controller file and RMPflow side by side (or
// RMPflow alone), each through tasks::ControllerEpisodes on the same task; summaries, videos and a replay.
void RunDemo(const DemoArgs& args, const std::optional<std::string>& policy_path) {
  const auto wall_start = std::chrono::steady_clock::now();
  if (!args.urdf.empty()) LoadUserRobot(args.urdf, args.collision);  // says how it was loaded (fitted in memory?)
  const DemoTask task = MakeDemoTask(args, policy_path);
  const tasks::TaskConfig& config = task.config;
  const auto context = tasks::MakeTaskContext(config, task.scenario);
  const kinematics::Robot& robot = context->variant(0).world_model->robot();
  const std::unique_ptr<sim::Scenario> scene = context->MakeScenario(0, 0);
  const int slots = ObstacleSlots(args, context->num_obstacles());
  const double seconds = config.episode.max_steps / config.episode.control_rate;
  fmt::print("rmpmarl demo: {} ({} dof), scenario '{}' ({} obstacle{}), task '{}', seed {}, {:.1f} s simulated: {}\n",
             robot.name, context->nq(), scene->name(), scene->num_obstacles(), scene->num_obstacles() == 1 ? "" : "s",
             tasks::TaskKindName(config.task),
             args.seed, seconds,
             policy_path ? fmt::format("the learned per-joint agents ({}) and RMPflow on the same episode", *policy_path)
                         : std::string("RMPflow alone"));
  fmt::print("  RMPflow parameters: {}{}\n", rmp::RmpflowConfigPath(robot).string(),
             robot.home.size() > 0 ? " (home found in memory)" : "");
  if (policy_path) {
    fmt::print("  the learned controller: {} agents on the {} basic layer{}{}\n",
               tasks::InterfaceModeName(config.interface),
               config.basic_layer.resolve == rmp::LayerResolve::kCoupled ? "coupled" : "per-joint",
               config.observation.lookahead > 0.0 ? fmt::format(", look-ahead {:g} s", config.observation.lookahead) : "",
               config.options.TargetGated()
                   ? fmt::format(", hand gate under the target stiffness at {:g} m", config.options.target_gate_clearance)
                   : "");
  }
  fmt::print("  {}\n", DescribePerception(args.perception));
  if (args.plan) {
    fmt::print("  plan, then react: each controller follows RRT-Connect joint paths to the target (replanned when "
               "stalled, blocked or the target moved)\n");
  }

  // one video per controller: the path given for one, <stem>-<controller><ext> beside it for two
  const bool two = policy_path.has_value() || args.plan;
  auto video_for = [&](const std::string& suffix) {
    if (args.video.empty() || !two) return args.video;
    const std::filesystem::path v(args.video);
    return (v.parent_path() / (v.stem().string() + "-" + suffix + v.extension().string())).string();
  };
  const bool record = !args.record.empty();
  std::vector<DemoRun> runs;
  std::vector<viewer::ArmLabel> arms;
  const std::string prefix = args.plan ? "plan + " : "";
  std::vector<DemoSeries> series;
  // --episodes N: N episodes of `runner`, the video of the first
  auto run_series = [&](tasks::ControllerEpisodes& runner, const std::string& label, const std::string& video) {
    DemoSeries s{label, {}, ""};
    for (int k = 0; k < args.episodes; ++k) {
      DemoArgs episode = args;
      episode.seed = args.seed + static_cast<std::uint64_t>(k);
      DemoRun run = RunDemoEpisode(runner, label, k == 0 ? video : std::string(), episode, false);
      if (k == 0) s.video = run.video;
      s.episodes.push_back(run.metrics);
    }
    series.push_back(std::move(s));
  };
  if (policy_path) {
    const std::string label = prefix + std::filesystem::path(*policy_path).stem().string();
    control::LearnedController* learned_policy = nullptr;  // owned by the runner's controller
    tasks::ControllerMaker agents;
    agents.options = config.controller;
    agents.make_sensor = MakeSensorFactory(args.perception, args.seed);
    agents.make_policy = [&](const kinematics::Robot& r) -> std::unique_ptr<control::AccelerationPolicy> {
      auto policy = control::MakeLearnedController(r, *task.file, *policy_path, slots);
      learned_policy = policy.get();
      control::ControllerOptions options = config.controller;
      options.control_rate = config.episode.control_rate;
      return MaybePlanned(args, r, std::move(policy), options);
    };
    tasks::ControllerEpisodes runner(context, agents);
    const std::string video = video_for(std::filesystem::path(*policy_path).stem().string());
    if (args.episodes > 1) {
      run_series(runner, label, video);
    } else {
      runs.push_back(RunDemoEpisode(runner, label, video, args, record, &learned_policy));
    }
    arms.push_back({label, "learned"});
  }
  tasks::ControllerMaker rmpflow;
  rmpflow.make_sensor = MakeSensorFactory(args.perception, args.seed);
  rmpflow.make_policy = [&](const kinematics::Robot& r) -> std::unique_ptr<control::AccelerationPolicy> {
    control::ControllerOptions options = rmpflow.options;
    options.control_rate = config.episode.control_rate;
    return MaybePlanned(args, r,
                        std::make_unique<control::RmpflowAccelerationPolicy>(r, rmp::LoadRmpflowOptions(r), slots),
                        options);
  };
  tasks::ControllerEpisodes rmpflow_runner(context, rmpflow);
  if (args.episodes > 1) {
    run_series(rmpflow_runner, prefix + "RMPflow", video_for("rmpflow"));
  } else {
    runs.push_back(RunDemoEpisode(rmpflow_runner, prefix + "RMPflow", video_for("rmpflow"), args, record));
  }
  arms.push_back({prefix + "RMPflow", "rmpflow"});
  if (args.plan) {
    // the plan alone, executed open loop (the RRT-Connect baseline of the benchmarks)
    tasks::ControllerMaker open_loop;
    open_loop.make_policy = [&](const kinematics::Robot& r) -> std::unique_ptr<control::AccelerationPolicy> {
      control::ControllerOptions options = open_loop.options;
      options.control_rate = config.episode.control_rate;
      return planning::MakePlanFollower(r, nullptr, options);
    };
    tasks::ControllerEpisodes open_loop_runner(context, open_loop);
    if (args.episodes > 1) {
      run_series(open_loop_runner, "plan, open loop", video_for("open-loop"));
    } else {
      runs.push_back(RunDemoEpisode(open_loop_runner, "plan, open loop", video_for("open-loop"), args, record));
    }
    arms.push_back({"plan, open loop", "rmpflow"});
  }
  if (!series.empty()) {
    PrintDemoSeries(series, config);
    for (const DemoSeries& s : series) {
      if (!s.video.empty()) fmt::print("  video {:<24}{} (the first episode)\n", s.label, s.video);
    }
    fmt::print("  wall time           {:.1f} s\n",
               std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count());
    return;
  }

  std::optional<viewer::Recorder> recorder;
  if (record) {
    // one replay of every run side by side, over the frames all have (an episode can end early on a collision)
    recorder.emplace(DemoHello(robot, *scene, arms, config.episode.control_rate, args.seed));
    std::size_t n = runs.front().frames.size();
    for (const DemoRun& r : runs) n = std::min(n, r.frames.size());
    for (std::size_t i = 0; i < n; ++i) {
      std::string frame = runs.front().frames[i];
      for (std::size_t k = 1; k < runs.size(); ++k) frame = viewer::MergeFrameArms(frame, runs[k].frames[i]);
      recorder->AddFrame(frame);
    }
    recorder->Write(args.record);
  }
  PrintDemoTable(runs, config);
  for (const DemoRun& r : runs) {
    if (r.sensor) PrintSensorSummary(*r.sensor, r.label);
  }
  for (const DemoRun& r : runs) {
    if (!r.video.empty()) fmt::print("  video {:<20}{}\n", r.label, r.video);
  }
  if (recorder) {
    fmt::print("  replay {:<21}{} ({} frames{}): rmpmarl view --replay {}\n", "", args.record, recorder->frames(),
               runs.size() > 1 ? ", the runs side by side" : "", args.record);
  }
  fmt::print("  wall time           {:.1f} s\n",
             std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count());
}

}  // namespace

void RegisterDemo(CLI::App& app) {
  auto* cmd = app.add_subcommand("demo", "A robot tracks a moving target among moving obstacles (MuJoCo), with video");
  static DemoArgs args;
  AddRobotAndScenarioOptions(cmd, &args.robot, &args.urdf, &args.collision, &args.scenario, &args.seed);
  cmd->add_option("--duration", args.duration, "simulated seconds (default: the scenario's)")
      ->check(CLI::Range(0.001, 3600.0));
  cmd->add_option("--video", args.video,
                  "write an MP4 here (PNG frames when ffmpeg is absent); with the learned controller beside RMPflow, "
                  "one per controller beside it: <stem>-<controller>.mp4");
  cmd->add_option("--record", args.record, "write the episode as a replay file (rmpmarl view --replay FILE)");
  cmd->add_option("--fps", args.fps, "video and replay frame rate")->check(CLI::Range(1.0, 240.0))->capture_default_str();
  cmd->add_option("--width", args.width, "video width [px]")->check(CLI::Range(16, 4096))->capture_default_str();
  cmd->add_option("--height", args.height, "video height [px]")->check(CLI::Range(16, 4096))->capture_default_str();
  cmd->add_option("--obstacle-speed", args.obstacle_speed, "obstacle speed [m/s]")->check(CLI::Range(0.0, 20.0));
  cmd->add_option("--target-speed", args.target_speed, "target speed [m/s]")->check(CLI::Range(0.0, 5.0));
  cmd->add_option("--obstacles", args.num_obstacles, "number of obstacles")->check(CLI::Range(0, 64));
  cmd->add_flag("--plan", args.plan, "plan, then react: both controllers follow an RRT-Connect joint path to the "
                                     "target, replanned when stalled, blocked or the target moved (docs/benchmarks.md)");
  cmd->add_option("--episodes", args.episodes,
                  "run this many episodes of each controller (seeds --seed, --seed + 1, ...: the same for all) and "
                  "print their success rates with 95 % intervals instead of one episode's details; --video shows the "
                  "first")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  cmd->add_option("--policy", args.policy,
                  "a controller file (.rmpp): its learned agents and RMPflow on the same episode (default: the shipped "
                  "models/policies/marl-rmp-residual.rmpp); rmpflow: RMPflow alone (also the static-reach and "
                  "static-obstacle scenarios)");
  AddPerceptionOptions(cmd, &args.perception);
  cmd->add_option("--cloud", args.perception.cloud,
                  "replay a recorded point cloud (.ply/.pcd in the robot's base frame, metres; or a folder of them "
                  "played at --camera-rate): the controllers know only its obstacles");
  cmd->callback([] {
    if (args.urdf.empty() && !args.collision.empty()) throw InputError("--collision needs --urdf");
    if (args.episodes > 1 && !args.record.empty()) {
      throw InputError("--record: one episode only (it replays the controllers side by side); drop --episodes");
    }
    if (!args.policy.empty() && args.policy != "rmpflow" && !std::filesystem::exists(args.policy)) {
      throw InputError(fmt::format("--policy {}: no such controller file (expected a .rmpp file, or `rmpflow` for "
                                   "RMPflow alone)", args.policy));
    }
    std::optional<std::string> policy;
    if (!args.policy.empty() && args.policy != "rmpflow") policy = args.policy;
    const bool learned_scene = tasks::IsArmTaskScene(args.scenario);
    if (args.policy.empty() && learned_scene && std::filesystem::exists(ShippedDefaultPolicyPath())) {
      policy = ShippedDefaultPolicyPath().string();
    }
    RunDemo(args, policy);
  });
}

}  // namespace rmpmarl::apps
