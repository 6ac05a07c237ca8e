// `rmpmarl demo`: the README's main job — a robot tracks a moving target while obstacles cross its workspace, in
// MuJoCo: the shipped learned per-joint agents and RMPflow on the same episode (or RMPflow alone), summaries and videos.
#include <fmt/core.h>
#include <mujoco/mujoco.h>

#include <chrono>
#include <filesystem>
#include <optional>
#include <random>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/tasks/task_episode.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
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
  PerceptionArgs perception;
};

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

// what happened, in words that cannot mislead: reached (and how close), collision-free, both.
std::string DescribeOutcome(const sim::EpisodeMetrics& m, double reach_tolerance) {
  if (m.invalid) return "INVALID: the episode ended on a non-finite state";
  const std::string reach = m.reached ? fmt::format("reached the target (final error {:.1f} mm, within {:.0f} mm)",
                                                    1000.0 * m.final_tracking_error, 1000.0 * reach_tolerance)
                                      : fmt::format("did NOT reach the target (final error {:.1f} mm, more than {:.0f} mm)",
                                                    1000.0 * m.final_tracking_error, 1000.0 * reach_tolerance);
  const std::string contact = m.collisions == 0 ? "collision-free"
                                                : fmt::format("{} COLLISION events", m.collisions);
  return reach + "; " + contact;
}

sim::RenderOptions CameraFor(const sim::Workspace& ws, const DemoArgs& args) {
  return sim::CameraForWorkspace(ws, args.width, args.height);
}

sim::RenderOptions CameraFor(const sim::Scenario& scenario, const DemoArgs& args) {
  return CameraFor(scenario.workspace(), args);
}

void RunDemo(const DemoArgs& args) {
  const auto wall_start = std::chrono::steady_clock::now();
  const kinematics::Robot robot = !args.urdf.empty() ? LoadUserRobot(args.urdf, args.collision).robot
                                                     : kinematics::LoadShippedRobot(args.robot);
  sim::ScenarioOverrides overrides;
  overrides.obstacle_speed = args.obstacle_speed;
  overrides.target_speed = args.target_speed;
  overrides.num_obstacles = args.num_obstacles;
  std::unique_ptr<sim::Scenario> scenario = sim::MakeScenario(args.scenario, robot, overrides);
  auto world_model = std::make_shared<const sim::WorldModel>(robot, scenario->scene_spec());
  sim::World world(world_model);
  const auto config_path = rmp::RmpflowConfigPath(robot);
  auto policy = std::make_unique<control::RmpflowAccelerationPolicy>(robot, rmp::LoadRmpflowOptions(robot),
                                                                 ObstacleSlots(args, scenario->num_obstacles()));
  control::ReactiveController controller(world_model->servos(), std::move(policy));
  std::unique_ptr<sim::ObstacleSensor> sensor;
  if (UsesSensor(args.perception)) sensor = MakeSensorFactory(args.perception, args.seed)(*world_model);

  sim::EpisodeOptions episode;
  episode.duration = args.duration > 0.0 ? args.duration : scenario->default_duration();
  episode.seed = args.seed;
  episode.sensor = sensor.get();

  std::unique_ptr<sim::OffscreenRenderer> renderer;
  std::unique_ptr<sim::VideoWriter> video;
  std::vector<std::uint8_t> rgb;
  if (!args.video.empty()) {
    std::string why_not;
    renderer = sim::OffscreenRenderer::Create(world_model->mj_model(), CameraFor(*scenario, args), &why_not);
    if (renderer == nullptr) {
      fmt::print("video: offscreen rendering is not possible here ({}); running without video\n", why_not);
    } else {
      video = std::make_unique<sim::VideoWriter>(args.video, args.width, args.height, args.fps);
      episode.video_fps = args.fps;
    }
  }
  std::optional<viewer::Recorder> recorder;
  if (!args.record.empty()) {
    recorder.emplace(DemoHello(robot, *scenario, {{"RMPflow", "rmpflow"}}, 1.0 / controller.control_period(),
                               args.seed));
    episode.video_fps = args.fps;
  }
  sim::FrameCallback on_frame;
  if (video || recorder) {
    on_frame = [&](const sim::FrameInfo& frame) {
      if (video) {
        const Eigen::Matrix3Xd* points = frame.sensor != nullptr ? &frame.sensor->points() : nullptr;
        renderer->Render(frame.world->mj_data(), &rgb, points, 0.5 * args.perception.voxel);
        video->AddFrame(rgb);
      }
      if (recorder) {
        viewer::ArmView arm;
        arm.world = frame.world;
        arm.contacts = frame.contacts;
        recorder->AddFrame(viewer::ScenarioFrame(frame.index, frame.time, *frame.scenario, {arm}));
      }
    };
  }

  fmt::print("rmpmarl demo: {} ({} dof), scenario '{}' ({} obstacles), policy {}, seed {}, {:.1f} s simulated\n",
             robot.name, robot.model.nq(), scenario->name(), scenario->num_obstacles(), controller.policy().name(),
             args.seed, episode.duration);
  fmt::print("  RMPflow parameters: {}{}\n", config_path.string(), robot.home.size() > 0 ? " (home found in memory)" : "");
  fmt::print("  {}\n", DescribePerception(args.perception));
  const sim::EpisodeMetrics r = sim::RunEpisode(episode, world, controller, *scenario, on_frame);

  auto mm = [](double v) { return std::isfinite(v) ? fmt::format("{:.1f} mm", 1000.0 * v) : std::string("–"); };
  auto clearance = [](double v) {
    return std::isfinite(v) ? fmt::format("{:.1f} mm", 1000.0 * v) : std::string("none within 15 cm");
  };
  fmt::print("\n  tracking error      {} mean, {} settled (t >= {:g} s), {} max, final {}\n", mm(r.mean_tracking_error),
             mm(r.settled_tracking_error), episode.loop.settle_time, mm(r.max_tracking_error),
             mm(r.final_tracking_error));
  fmt::print("  min clearance       {} to obstacles, {} between links\n", clearance(r.min_clearance),
             clearance(r.min_self_clearance));
  fmt::print("  collisions          {} events ({} robot–obstacle, {} self), {:.2f} s in collision\n", r.collisions,
             r.obstacle_collisions, r.self_collisions, r.time_in_collision);
  fmt::print("  control step        {:.1f} µs mean, {:.1f} µs max ({} steps at {:.0f} Hz; physics {} steps)\n",
             r.mean_control_us, r.max_control_us, r.length, 1.0 / controller.control_period(), r.physics_steps);
  if (r.nonfinite_policy_outputs > 0) {
    fmt::print("  WARNING             {} non-finite policy outputs (position held)\n", r.nonfinite_policy_outputs);
  }
  if (r.invalid) fmt::print("  WARNING             the simulation diverged and the episode ended early\n");
  if (sensor) PrintSensorSummary(sensor->Summary(), "");
  fmt::print("  result              {}\n", DescribeOutcome(r, episode.loop.reach_tolerance));
  if (video) {
    const bool mp4 = video->writes_mp4();
    const auto written = video->Close();
    fmt::print("  video               {} ({} frames, {}x{}, renderer: {})\n", written.string(), video->frames(),
               args.width, args.height, renderer->gl_renderer());
    if (!mp4) fmt::print("                      ffmpeg not found: wrote PNG frames instead of an MP4\n");
  }
  if (recorder) {
    recorder->Write(args.record);
    fmt::print("  replay              {} ({} frames): rmpmarl view --replay {}\n", args.record, recorder->frames(),
               args.record);
  }
  fmt::print("  wall time           {:.1f} s\n",
             std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count());
}

// What one method did in the comparison demo's episode.
struct DemoRun {
  std::string label;
  tasks::EpisodeMetrics metrics;
  double step_us = 0.0;  // policy + controller per control step
  std::string video;     // written file ("" none)
  std::optional<sim::SensorSummary> sensor;
};

// runs one episode of the task with `runner`'s controller (seeded with args.seed, so every controller of the same
// task sees the same episode); renders it when a video path is given, records frames when `frames` is set.
DemoRun RunDemoEpisode(tasks::ControllerEpisodes& runner, const std::string& label, const std::string& video_path,
                       const DemoArgs& args, control::LearnedController* const* learned = nullptr,
                       std::vector<std::string>* frames = nullptr) {
  std::mt19937_64 rng(args.seed);
  std::unique_ptr<sim::OffscreenRenderer> renderer;
  std::unique_ptr<sim::VideoWriter> video;
  std::vector<std::uint8_t> rgb;
  bool render = !video_path.empty();
  tasks::RunOptions options;
  if (render || frames != nullptr) {
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
      if (frames != nullptr) {
        viewer::ArmView arm;
        arm.world = frame.world;
        arm.learned = learned != nullptr ? *learned : nullptr;  // made with the controller at the episode's start
        frames->push_back(viewer::ScenarioFrame(frame.index, frame.time, *frame.scenario, {arm}));
      }
    };
  }
  DemoRun run{label, {}, 0.0, "", std::nullopt};
  run.metrics = runner.Run(rng, options);
  if (runner.sensor() != nullptr) run.sensor = runner.sensor()->Summary();
  run.step_us = run.metrics.mean_control_us;  // the whole controller: sensing, network and basic layer
  if (video) run.video = video->Close().string();
  return run;
}

// a controller file's learned agents and RMPflow on the SAME episode of its task, moved to the demo's robot, scene
// and obstacle speed: both drive the env through the one controller interface (control::AccelerationPolicy), the agents
// as control::LearnedController (Eigen runtime, no libtorch); summaries side by side and a video of each.
void RunComparisonDemo(const DemoArgs& args, const std::string& policy_path) {
  const auto wall_start = std::chrono::steady_clock::now();
  const control::PolicyFile file = control::LoadPolicyFile(policy_path);
  rl::TaskMove move;
  move.robot = !args.urdf.empty() ? args.urdf : args.robot;
  move.collision = args.collision;
  move.scene = args.scenario;
  if (args.obstacle_speed) move.obstacle_speed = *args.obstacle_speed;
  tasks::TaskConfig config = rl::PolicyTaskConfig(file, policy_path, move);
  if (!args.urdf.empty()) LoadUserRobot(args.urdf, args.collision);  // says how it was loaded (fitted in memory?)
  if (args.num_obstacles) {
    if (config.task != tasks::TaskKind::kReachAvoid) {
      throw InputError(fmt::format("--obstacles: the number of obstacles is set in the crossing scene only (the {} "
                                   "scene has its own)", tasks::TaskKindName(config.task)));
    }
    config.scenario.crossing.num_obstacles = *args.num_obstacles;
  }
  if (args.target_speed) {
    if (config.task != tasks::TaskKind::kReachAvoid) {
      throw InputError(fmt::format("--target-speed: the crossing scene only (the {} scene's target is set by the "
                                   "scene)", tasks::TaskKindName(config.task)));
    }
    config.scenario.crossing.target_speed = *args.target_speed;
  }
  if (args.duration > 0.0) {
    config.episode.max_steps = std::max(1, static_cast<int>(std::lround(args.duration * config.episode.control_rate)));
  }
  config.observation.max_obstacles = std::max(config.observation.max_obstacles, 6);
  config.randomization.variants = 1;  // the nominal robot
  const auto context = tasks::MakeTaskContext(config);
  auto video_for = [&](const std::string& suffix) {
    if (args.video.empty()) return std::string();
    const std::filesystem::path v(args.video);
    return (v.parent_path() / (v.stem().string() + "-" + suffix + v.extension().string())).string();
  };
  const std::string label = std::filesystem::path(policy_path).stem().string();
  const kinematics::Robot& robot = context->variant(0).world_model->robot();
  fmt::print("rmpmarl demo: {} ({} dof), task '{}', seed {}, {:.1f} s: the learned per-joint agents ({}) and "
             "RMPflow on the same episode\n", robot.name, context->nq(), tasks::TaskKindName(config.task), args.seed,
             config.episode.max_steps / config.episode.control_rate, policy_path);
  fmt::print("  RMPflow parameters: {}{}\n", rmp::RmpflowConfigPath(robot).string(),
             robot.home.size() > 0 ? " (home found in memory)" : "");
  fmt::print("  the learned controller: {} agents on the {} basic layer{}{}\n", tasks::InterfaceModeName(config.interface),
             config.basic_layer.resolve == rmp::LayerResolve::kCoupled ? "coupled" : "per-joint",
             config.observation.lookahead > 0.0 ? fmt::format(", look-ahead {:g} s", config.observation.lookahead) : "",
             config.options.TargetGated()
                 ? fmt::format(", hand gate under the target stiffness at {:g} m", config.options.target_gate_clearance)
                 : "");
  tasks::ControllerMaker agents;
  control::LearnedController* learned_policy = nullptr;  // owned by the runner's controller
  const int slots = ObstacleSlots(args, context->num_obstacles());
  fmt::print("  {}\n", DescribePerception(args.perception));
  agents.make_sensor = MakeSensorFactory(args.perception, args.seed);
  agents.make_policy = [&](const kinematics::Robot& robot) {
    auto policy = control::MakeLearnedController(robot, file, policy_path, slots);
    learned_policy = policy.get();
    return policy;
  };
  agents.options = config.controller;
  tasks::ControllerEpisodes learned_env(context, agents);
  const bool record = !args.record.empty();
  std::vector<std::string> learned_frames, rmpflow_frames;
  const DemoRun learned = RunDemoEpisode(learned_env, label, video_for(label), args, &learned_policy,
                                         record ? &learned_frames : nullptr);
  tasks::ControllerMaker rmpflow;
  rmpflow.make_sensor = MakeSensorFactory(args.perception, args.seed);
  rmpflow.make_policy = [&](const kinematics::Robot& robot) {
    return std::make_unique<control::RmpflowAccelerationPolicy>(robot, slots);
  };
  tasks::ControllerEpisodes rmpflow_env(context, rmpflow);
  const DemoRun baseline = RunDemoEpisode(rmpflow_env, "RMPflow", video_for("rmpflow"), args, nullptr,
                                          record ? &rmpflow_frames : nullptr);
  std::optional<viewer::Recorder> recorder;
  if (record) {
    // one replay of both runs side by side, over the frames both have (an episode can end early on a collision)
    recorder.emplace(DemoHello(robot, learned_env.episode().scenario(), {{label, "learned"}, {"RMPflow", "rmpflow"}},
                               config.episode.control_rate, args.seed));
    const std::size_t n = std::min(learned_frames.size(), rmpflow_frames.size());
    for (std::size_t i = 0; i < n; ++i) recorder->AddFrame(viewer::MergeFrameArms(learned_frames[i], rmpflow_frames[i]));
    recorder->Write(args.record);
  }

  auto mm = [](double v) { return std::isfinite(v) ? fmt::format("{:.1f} mm", 1000.0 * v) : std::string("–"); };
  auto row = [](const std::string& name, const std::string& a, const std::string& b) {
    fmt::print("  {:<26}{:>24}{:>24}\n", name, a, b);
  };
  fmt::print("\n");
  row("", learned.label, baseline.label);
  row("tracking error (mean)", mm(learned.metrics.mean_tracking_error), mm(baseline.metrics.mean_tracking_error));
  row(fmt::format("settled (t >= {:g} s)", tasks::kSettleTime), mm(learned.metrics.settled_tracking_error),
      mm(baseline.metrics.settled_tracking_error));
  row("final error", mm(learned.metrics.final_tracking_error), mm(baseline.metrics.final_tracking_error));
  auto clearance = [&](const tasks::EpisodeMetrics& m) {
    return std::isfinite(m.min_clearance) ? mm(m.min_clearance) : std::string("none within 15 cm");
  };
  row("min clearance", clearance(learned.metrics), clearance(baseline.metrics));
  row("collision events", std::to_string(learned.metrics.collisions), std::to_string(baseline.metrics.collisions));
  row("control step", fmt::format("{:.1f} µs", learned.step_us), fmt::format("{:.1f} µs", baseline.step_us));
  const double tolerance = std::isfinite(config.episode.success_max_final_error) ? config.episode.success_max_final_error
                                                                                 : sim::LoopOptions{}.reach_tolerance;
  auto reached = [&](const tasks::EpisodeMetrics& m) {
    return m.invalid ? std::string("INVALID") : m.reached ? std::string("yes") : std::string("NO");
  };
  auto free = [](const tasks::EpisodeMetrics& m) {
    return m.collisions == 0 ? std::string("yes") : fmt::format("NO ({} events)", m.collisions);
  };
  row(fmt::format("reached (within {:.0f} mm)", 1000.0 * tolerance), reached(learned.metrics),
      reached(baseline.metrics));
  row("collision-free", free(learned.metrics), free(baseline.metrics));
  for (const DemoRun* r : {&learned, &baseline}) {
    if (r->sensor) PrintSensorSummary(*r->sensor, r->label);
  }
  for (const DemoRun* r : {&learned, &baseline}) {
    if (!r->video.empty()) fmt::print("  video {:<20}{}\n", r->label, r->video);
  }
  if (recorder) {
    fmt::print("  replay {:<21}{} ({} frames, both runs side by side): rmpmarl view --replay {}\n", "", args.record,
               recorder->frames(), args.record);
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
      ->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--video", args.video, "write an MP4 here (PNG frames when ffmpeg is absent)");
  cmd->add_option("--record", args.record, "write the episode as a replay file (rmpmarl view --replay FILE)");
  cmd->add_option("--fps", args.fps, "video and replay frame rate")->check(CLI::Range(1.0, 240.0))->capture_default_str();
  cmd->add_option("--width", args.width, "video width [px]")->check(CLI::Range(16, 4096))->capture_default_str();
  cmd->add_option("--height", args.height, "video height [px]")->check(CLI::Range(16, 4096))->capture_default_str();
  cmd->add_option("--obstacle-speed", args.obstacle_speed, "obstacle speed [m/s]")->check(CLI::Range(0.0, 20.0));
  cmd->add_option("--target-speed", args.target_speed, "target speed [m/s]")->check(CLI::Range(0.0, 5.0));
  cmd->add_option("--obstacles", args.num_obstacles, "number of obstacles")->check(CLI::Range(0, 64));
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
    std::optional<std::string> policy;
    if (!args.policy.empty() && args.policy != "rmpflow") policy = args.policy;
    const bool learned_scene = args.scenario == "crossing" || args.scenario == "line-crossing" ||
                               args.scenario == "cluttered";
    if (args.policy.empty() && learned_scene && std::filesystem::exists(ShippedDefaultPolicyPath())) {
      policy = ShippedDefaultPolicyPath().string();
    }
    if (policy) {
      RunComparisonDemo(args, *policy);
    } else {
      RunDemo(args);
    }
  });
}

}  // namespace rmpmarl::apps
