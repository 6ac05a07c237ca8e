// `rmpmarl eval POLICY [--episodes N]`: success rate, tracking error, clearance and collisions of a checkpoint
// (.ckpt, libtorch) or a controller file (.rmpp, the torch-free runtime) on its own task, or moved to another robot,
// URDF, scene or obstacle speed;
// `rmpmarl export-policy CHECKPOINT OUTPUT`: the actor of a checkpoint as a runtime policy file.
#include "commands.h"

#ifdef RMPMARL_HAS_TORCH
#include <fmt/core.h>

#include <cmath>
#include <filesystem>
#include <memory>
#include <optional>
#include <random>
#include <string>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/tasks/task_episode.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::apps {

namespace {

void PrintEvalResult(const rl::EvalResult& r) {
  fmt::print("  success rate      {:.1f} %\n", 100.0 * r.success_rate);
  fmt::print("  tracking error    {:.1f} ± {:.1f} mm (episode means; final {:.1f} mm)\n", r.tracking_error_mean_mm,
             r.tracking_error_std_mm, r.final_tracking_error_mean_mm);
  if (std::isfinite(r.settled_tracking_error_mean_mm)) {
    fmt::print("  settled           {:.1f} mm (mean end-effector–target distance over t >= {:g} s)\n",
               r.settled_tracking_error_mean_mm, tasks::kSettleTime);
  } else {
    fmt::print("  settled           – (no episode lasted {:g} s)\n", tasks::kSettleTime);
  }
  if (std::isfinite(r.min_clearance_mean_m)) {
    fmt::print("  clearance         {:.1f} mm (mean of the episodes' minimum robot–obstacle distance)\n",
               1000.0 * r.min_clearance_mean_m);
  } else {
    fmt::print("  clearance         – (no obstacle came within the warning distance)\n");
  }
  fmt::print("  collisions        {:.2f} per episode, {:.1f} % of episodes collision-free\n", r.collisions_per_episode,
             100.0 * r.collision_free_rate);
  fmt::print("  return            {:.2f} (mean episode length {:.1f} steps)\n", r.mean_return, r.mean_length);
}

}  // namespace

void RegisterEval(CLI::App& app) {
  struct Args {
    std::string policy;
    std::string task, task_config, interface, overrides;
    std::string robot, urdf, collision, scenario;
    double obstacle_speed = -1.0;
    bool as_controller = false;
    PerceptionArgs perception;
    int episodes = 100;
    int envs = 8;
    int env_threads = 1;
    std::uint64_t seed = 1000003;
    bool stochastic = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("eval", "Evaluate a trained policy: success rate, tracking error mean ± std, "
                                         "clearance, collisions");
  cmd->add_option("policy", args->policy, "checkpoint (.ckpt) or exported policy (.rmpp)")->required();
  cmd->add_option("--task", args->task, "task name (default: the checkpoint's or the controller file's own task)");
  cmd->add_option("--robot", args->robot, "run a controller file on this shipped arm instead of its own");
  cmd->add_option("--urdf", args->urdf, "run a controller file on your robot (collision YAML beside the URDF as "
                                       "<stem>.collision.yaml or collision.yaml, else capsules fitted in memory)");
  cmd->add_option("--collision", args->collision, "the collision YAML of --urdf");
  cmd->add_option("--scenario", args->scenario, "run a controller file in this scene: crossing (reach-avoid), "
                                               "line-crossing, cluttered");
  cmd->add_option("--obstacle-speed", args->obstacle_speed, "every obstacle at this speed [m/s] (controller files)")
      ->check(CLI::Range(0.0, 20.0));
  cmd->add_flag("--as-controller", args->as_controller,
                "run the controller file as a user's loop runs it (control::LearnedController: warnings from the capsules "
                "and the scene's obstacles) instead of as agents in the env (warnings from MuJoCo's contacts)");
  cmd->add_option("--task-config", args->task_config, "task YAML (default: the checkpoint's, else the shipped one)");
  cmd->add_option("--interface", args->interface, "interface mode (default: the checkpoint's)");
  cmd->add_option("--overrides", args->overrides, "YAML map of task overrides, e.g. '{episode: {max_steps: 200}}'");
  cmd->add_option("--episodes", args->episodes, "episodes to run (default 100)")->check(CLI::Range(1, 1000000));
  cmd->add_option("--envs", args->envs, "parallel envs (default 8)")->check(CLI::Range(1, 4096));
  cmd->add_option("--env-threads", args->env_threads, "env worker threads (default 1)")->check(CLI::Range(1, 256));
  cmd->add_option("--seed", args->seed, "seed of the evaluation envs")->check(SeedCheck());
  AddPerceptionOptions(cmd, &args->perception);
  cmd->add_flag("--stochastic", args->stochastic, "sample actions (default: deterministic modes)");
  cmd->callback([args] {
    rl::TaskSelection task;
    const bool is_checkpoint = args->policy.size() >= 5 && args->policy.substr(args->policy.size() - 5) == ".ckpt";
    const bool depth = UsesDepth(args->perception);
    if (depth && !args->as_controller) {
      throw InputError("eval: --perception depth runs the agents as a user's loop does: add --as-controller");
    }
    const bool moved = !args->robot.empty() || !args->urdf.empty() || !args->scenario.empty() ||
                       args->obstacle_speed >= 0.0 || args->as_controller;
    if (!args->robot.empty() && !args->urdf.empty()) throw InputError("eval: --robot and --urdf: give one of them");
    if (!args->collision.empty() && args->urdf.empty()) throw InputError("eval: --collision needs --urdf");
    if (!is_checkpoint && args->task.empty() && args->task_config.empty() && args->interface.empty()) {
      // a controller file on its own task, or moved
      const control::PolicyFile file = control::LoadPolicyFile(args->policy);
      rl::TaskMove move;
      move.robot = args->urdf.empty() ? args->robot : args->urdf;
      move.collision = args->collision;
      move.scene = args->scenario;
      move.obstacle_speed = args->obstacle_speed;
      move.overrides_yaml = args->overrides;
      const tasks::TaskConfig config = rl::PolicyTaskConfig(file, args->policy, move);
      const auto context = tasks::MakeTaskContext(config);
      rl::EvalResult r;
      if (args->as_controller) {
        if (args->stochastic) {
          throw InputError("eval: --stochastic and --as-controller: a controller acts on its deterministic modes");
        }
        // the moved task (scene, robot, --overrides) is the controller's task too
        const int slots = std::max(context->num_obstacles(),
                                   depth ? DepthOptions(args->perception, 0).cloud.max_obstacles : 0);
        tasks::ControllerMaker learned = tasks::LearnedControllerMaker(
            config, file.weights, std::filesystem::path(args->policy).stem().string(), slots);
        learned.make_sensor = MakeSensorFactory(args->perception, args->seed);
        // the episodes the env evaluation runs (rl::Evaluate): env k of --envs draws its episodes from a generator
        // seeded seed + k, and runs its share of them one after the other
        tasks::ControllerEpisodes runner(context, learned);
        std::vector<tasks::EpisodeMetrics> episodes;
        const std::vector<int> shares = rl::EvaluationShares(args->episodes, args->envs);
        for (int k = 0; k < args->envs; ++k) {
          std::mt19937_64 rng(args->seed + static_cast<std::uint64_t>(k));
          for (int e = 0; e < shares[k]; ++e) episodes.push_back(runner.Run(rng));
        }
        r = rl::SummarizeEpisodes(episodes);
      } else {
        r = rl::Evaluate(args->policy, tasks::MakeManipulatorEnvFactory(context),
                         {.episodes = args->episodes, .num_envs = args->envs, .env_threads = args->env_threads,
                          .seed = args->seed, .stochastic = args->stochastic});
      }
      fmt::print("eval {} on {} / {} / {}{} ({} episodes, {} actions)\n", args->policy,
                 tasks::TaskKindName(config.task), config.robot, tasks::InterfaceModeName(config.interface),
                 args->as_controller ? ", as a controller in a user's loop" : "", r.episodes,
                 args->stochastic ? "sampled" : "deterministic");
      fmt::print("{}\n", DescribePerception(args->perception));
      PrintEvalResult(r);
      return;
    }
    if (moved) {
      throw InputError("eval: --robot, --urdf, --scenario, --obstacle-speed and --as-controller move a controller "
                       "file's own task; with a checkpoint or --task use --overrides");
    }
    if (is_checkpoint) task = rl::ReadCheckpointConfig(args->policy).task;
    if (!args->task.empty()) {
      if (args->task != task.name) task = rl::TaskSelection{};
      task.name = args->task;
    }
    if (!args->task_config.empty()) task.config = args->task_config;
    if (!args->interface.empty()) task.interface = args->interface;
    if (!args->overrides.empty()) task.overrides_yaml = args->overrides;
    if (task.name.empty()) throw InputError("eval: --task is required for a policy file (.rmpp)");
    const rl::EvalResult r = rl::Evaluate(args->policy, rl::MakeTaskFactory(task),
                                          {.episodes = args->episodes, .num_envs = args->envs,
                                           .env_threads = args->env_threads, .seed = args->seed,
                                           .stochastic = args->stochastic});
    fmt::print("eval {} on {}{} ({} episodes, {} actions)\n", args->policy, task.name,
               task.interface.empty() ? "" : " / " + task.interface, r.episodes,
               args->stochastic ? "sampled" : "deterministic");
    PrintEvalResult(r);
  });
}

void RegisterExportPolicy(CLI::App& app) {
  struct Args {
    std::string checkpoint, output;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("export-policy", "Write the actor of a checkpoint as a policy file for the "
                                                  "torch-free runtime (docs/learning.md)");
  cmd->add_option("checkpoint", args->checkpoint, "checkpoint (.ckpt)")->required();
  cmd->add_option("output", args->output, "policy file to write (.rmpp)")->required();
  cmd->callback([args] {
    rl::ExportCheckpointPolicy(args->checkpoint, args->output);
    fmt::print("wrote {}\n", args->output);
  });
}

void RegisterUpgradeCheckpoint(CLI::App& app) {
  auto files = std::make_shared<std::vector<std::string>>();
  auto* cmd = app.add_subcommand(
      "upgrade-checkpoint",
      "Rewrite checkpoints of format 1 (torch::serialize archives) as format 2, in place. Format 1 "
      "is read through TorchScript's importer, which is not safe on untrusted files: upgrade only files you trust");
  cmd->add_option("checkpoints", *files, "checkpoint files (.ckpt)")->required();
  cmd->callback([files] {
    for (const std::string& f : *files) {
      rl::UpgradeCheckpoint(f, f);
      fmt::print("upgraded {}\n", f);
    }
  });
}

}  // namespace rmpmarl::apps
#endif  // RMPMARL_HAS_TORCH
