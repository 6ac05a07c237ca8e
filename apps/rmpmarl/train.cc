// `rmpmarl train CONFIG [--resume] [--seed N] [--nproc N]`: PPO / MAPPO training from a configs/train/<name>.yaml,
// in one process or data-parallel over N local processes (or over the ranks torchrun's variables describe).
#include "commands.h"

#ifdef RMPMARL_HAS_TORCH
#include <fmt/core.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/distributed.h"
#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::apps {
namespace {

// `--nproc N`: this process starts N copies of itself as the ranks of a local group (torchrun's variables, a free
// loopback port) and waits for them. When one fails, the others end on their own (a collective with a dead peer
// fails at once, one with a hung peer after the timeout); any still running `timeout` + 10 s later are killed.
[[noreturn]] void LaunchLocalRanks(int nproc, int timeout_s, char** argv) {
  const int port = rl::FreeLocalPort();
  std::vector<pid_t> pids;
  for (int r = 0; r < nproc; ++r) {
    const pid_t pid = fork();
    if (pid < 0) throw std::runtime_error("train --nproc: fork failed");
    if (pid == 0) {
      setenv("RANK", std::to_string(r).c_str(), 1);
      setenv("LOCAL_RANK", std::to_string(r).c_str(), 1);
      setenv("WORLD_SIZE", std::to_string(nproc).c_str(), 1);
      setenv("MASTER_ADDR", "127.0.0.1", 1);
      setenv("MASTER_PORT", std::to_string(port).c_str(), 1);
      setenv("RMPMARL_DIST_TIMEOUT", std::to_string(timeout_s).c_str(), 1);
      execv("/proc/self/exe", argv);
      std::perror("train --nproc: cannot start a rank");
      _exit(127);
    }
    pids.push_back(pid);
  }
  int failed_rank = -1, failed_status = 0, running = nproc;
  std::chrono::steady_clock::time_point deadline;
  while (running > 0) {
    int status = 0;
    const pid_t pid = waitpid(-1, &status, failed_rank >= 0 ? WNOHANG : 0);
    if (pid > 0) {
      --running;
      int r = 0;
      while (r < nproc && pids[r] != pid) ++r;
      if (r < nproc) pids[r] = 0;
      const bool ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
      if (!ok && failed_rank < 0) {
        failed_rank = r;
        failed_status = status;
        deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s + 10);
      }
      continue;
    }
    if (failed_rank >= 0 && std::chrono::steady_clock::now() > deadline) {
      for (pid_t p : pids) {
        if (p > 0) kill(p, SIGKILL);
      }
      deadline = std::chrono::steady_clock::time_point::max();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (failed_rank >= 0) {
    fmt::print(stderr, "rmpmarl train: rank {} of {} {} {}; the run stopped (resume it from its last checkpoint with "
                       "--resume)\n", failed_rank, nproc, WIFSIGNALED(failed_status) ? "was killed by signal" : "exited with status",
               WIFSIGNALED(failed_status) ? WTERMSIG(failed_status) : WEXITSTATUS(failed_status));
    std::exit(1);
  }
  std::exit(0);
}

}  // namespace

void RegisterTrain(CLI::App& app, int, char** argv) {
  struct Args {
    std::string config;
    bool resume = false;
    std::optional<std::uint64_t> seed;
    std::string output;
    std::optional<int> updates;
    std::optional<int> torch_threads;
    std::optional<int> env_threads;
    int nproc = 1;
    int dist_timeout = 60;
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
  cmd->add_option("--nproc", args->nproc,
                  "data-parallel training over N local processes, each with the config's num_envs environments "
                  "(across machines: start one process per rank with torchrun's RANK, WORLD_SIZE, MASTER_ADDR, "
                  "MASTER_PORT; docs/learning.md)")
      ->check(CLI::Range(1, 256))->capture_default_str();
  cmd->add_option("--dist-timeout", args->dist_timeout,
                  "data-parallel: seconds a rank waits for the others (rendezvous, each collective) before it fails")
      ->check(CLI::Range(1, 86400))->capture_default_str();
  cmd->callback([args, argv] {
    std::optional<rl::ProcessGroupOptions> group = rl::ProcessGroupFromEnvironment();
    if (args->nproc > 1 && !group) LaunchLocalRanks(args->nproc, args->dist_timeout, argv);
    if (args->nproc > 1 && group && group->world_size != args->nproc) {
      throw InputError(fmt::format("--nproc {}: expected the WORLD_SIZE of this process's group, got WORLD_SIZE={}",
                                   args->nproc, group->world_size));
    }
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
    std::unique_ptr<rl::Collective> collective;
    if (group && group->world_size > 1) {
      if (!std::getenv("RMPMARL_DIST_TIMEOUT")) group->timeout = std::chrono::seconds(args->dist_timeout);
      collective = rl::JoinProcessGroup(*group);
    }
    rl::RunTraining(config, rl::MakeTaskFactory(config.task),
                    rl::RunOptions{.resume = args->resume, .collective = collective.get()});
  });
}

}  // namespace rmpmarl::apps
#endif  // RMPMARL_HAS_TORCH
