// `rmpmarl train CONFIG [--resume] [--seed N]`: PPO / MAPPO training from a configs/train/<name>.yaml.
#include "commands.h"

#ifdef RMPMARL_HAS_TORCH
#include <fmt/core.h>

#include <memory>
#include <optional>
#include <string>

#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::apps {

void RegisterTrain(CLI::App& app) {
  struct Args {
    std::string config;
    bool resume = false;
    std::optional<std::uint64_t> seed;
    std::string output;
    std::optional<int> updates;
    std::optional<int> torch_threads;
    std::optional<int> env_threads;
    bool quiet = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("train", "Train per-joint agents (MAPPO) or a single agent (PPO) from a training "
                                          "config; writes checkpoints, metrics.csv, TensorBoard events and policy.rmpp");
  cmd->add_option("config", args->config, "training config, e.g. configs/train/pretrain-2link.yaml")->required();
  cmd->add_flag("--resume", args->resume, "continue exactly from <output_dir>/checkpoint.ckpt");
  cmd->add_option("--seed", args->seed, "override the config's seed (the default output_dir gets a -seed<N> suffix)");
  cmd->add_option("--output", args->output, "override output_dir (default: the config's, else runs/<name>)");
  cmd->add_option("--updates", args->updates, "override total_updates")->check(CLI::Range(1, 10000000));
  cmd->add_option("--torch-threads", args->torch_threads, "override torch_threads")->check(CLI::Range(1, 256));
  cmd->add_option("--env-threads", args->env_threads, "override env_threads")->check(CLI::Range(1, 256));
  cmd->add_flag("--quiet", args->quiet, "no progress output");
  cmd->callback([args] {
    rl::TrainConfig config = rl::LoadTrainConfig(args->config);
    if (config.output_dir.empty()) config.output_dir = "runs/" + config.name;
    if (args->seed) {
      config.seed = *args->seed;
      if (args->output.empty()) config.output_dir += fmt::format("-seed{}", *args->seed);
    }
    if (!args->output.empty()) config.output_dir = args->output;
    if (args->updates) config.total_updates = *args->updates;
    if (args->torch_threads) config.torch_threads = *args->torch_threads;
    if (args->env_threads) config.env_threads = *args->env_threads;
    if (args->quiet) config.progress = false;
    rl::RunTraining(config, rl::MakeTaskFactory(config.task), rl::RunOptions{.resume = args->resume});
  });
}

}  // namespace rmpmarl::apps
#endif  // RMPMARL_HAS_TORCH
