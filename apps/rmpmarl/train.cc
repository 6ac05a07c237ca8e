// `rmpmarl train CONFIG [--resume] [--seed N] [--nproc N]`: PPO / MAPPO training from a configs/train/<name>.yaml,
// in one process or data-parallel over N local processes (or over the ranks torchrun's variables describe).
#include "commands.h"

#ifdef RMPMARL_HAS_TORCH
#include <fmt/core.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

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
// fails at once, one with a hung peer after the timeout); any still running `timeout` + 10 s later are killed and
// named as hung. A rank dies with this process (PR_SET_PDEATHSIG).
[[noreturn]] void LaunchLocalRanks(int nproc, int timeout_s, char** argv) {
  const int port = rl::FreeLocalPort();
  // each rank's environment, made before forking (a child only calls async-signal-safe functions until execve)
  std::vector<std::vector<std::string>> envs(nproc);
  std::vector<std::vector<char*>> envps(nproc);
  for (int r = 0; r < nproc; ++r) {
    for (char** e = environ; *e != nullptr; ++e) {
      const std::string kv = *e;
      const std::string key = kv.substr(0, kv.find('='));
      if (key == "RANK" || key == "LOCAL_RANK" || key == "WORLD_SIZE" || key == "LOCAL_WORLD_SIZE" ||
          key == "MASTER_ADDR" || key == "MASTER_PORT" || key == "RMPMARL_DIST_TIMEOUT") {
        continue;
      }
      envs[r].push_back(kv);
    }
    envs[r].push_back(fmt::format("RANK={}", r));
    envs[r].push_back(fmt::format("LOCAL_RANK={}", r));
    envs[r].push_back(fmt::format("WORLD_SIZE={}", nproc));
    envs[r].push_back(fmt::format("LOCAL_WORLD_SIZE={}", nproc));
    envs[r].push_back("MASTER_ADDR=127.0.0.1");
    envs[r].push_back(fmt::format("MASTER_PORT={}", port));
    envs[r].push_back(fmt::format("RMPMARL_DIST_TIMEOUT={}", timeout_s));
    for (std::string& kv : envs[r]) envps[r].push_back(kv.data());
    envps[r].push_back(nullptr);
  }
  const pid_t launcher = getpid();
  std::vector<pid_t> pids(nproc, 0);
  for (int r = 0; r < nproc; ++r) {
    const pid_t pid = fork();
    if (pid < 0) {
      for (pid_t p : pids) {
        if (p > 0) kill(p, SIGKILL);
      }
      throw std::runtime_error(fmt::format("train --nproc: cannot start rank {}: fork failed", r));
    }
    if (pid == 0) {
      prctl(PR_SET_PDEATHSIG, SIGKILL);
      if (getppid() != launcher) _exit(125);  // the launcher died before prctl
      execve("/proc/self/exe", argv, envps[r].data());
      _exit(127);
    }
    pids[r] = pid;
  }
  std::vector<int> status(nproc, -1);
  std::vector<bool> killed(nproc, false);
  int failed_rank = -1, running = nproc;
  std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max();
  while (running > 0) {
    int st = 0;
    const pid_t pid = waitpid(-1, &st, failed_rank >= 0 ? WNOHANG : 0);
    if (pid > 0) {
      int r = 0;
      while (r < nproc && pids[r] != pid) ++r;
      if (r == nproc) continue;
      --running;
      status[r] = st;
      const bool ok = WIFEXITED(st) && WEXITSTATUS(st) == 0;
      if (!ok && failed_rank < 0) {
        failed_rank = r;
        deadline = std::chrono::steady_clock::now() + std::chrono::seconds(timeout_s + 10);
      }
      continue;
    }
    if (std::chrono::steady_clock::now() > deadline) {
      for (int r = 0; r < nproc; ++r) {
        if (status[r] == -1) {
          kill(pids[r], SIGKILL);
          killed[r] = true;
        }
      }
      deadline = std::chrono::steady_clock::time_point::max();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  if (failed_rank < 0) std::exit(0);
  // what each rank did: a rank still running past the timeout hung (the others timed out waiting for it)
  std::string report;
  for (int r = 0; r < nproc; ++r) {
    const int st = status[r];
    std::string what = killed[r]                ? "hung: killed after the timeout"
                       : WIFSIGNALED(st)         ? fmt::format("killed by signal {}", WTERMSIG(st))
                       : WEXITSTATUS(st) == 0    ? "finished"
                                                 : fmt::format("exited with status {}", WEXITSTATUS(st));
    report += fmt::format("{}rank {}: {}", report.empty() ? "" : "; ", r, what);
  }
  fmt::print(stderr, "rmpmarl train: the run of {} ranks stopped ({}); resume it from its last checkpoint with "
                     "--resume\n", nproc, report);
  std::exit(1);
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
    std::optional<int> envs;
    int nproc = 1;
    int dist_timeout = 60;
    bool quiet = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand("train", "Train per-joint agents (MAPPO) or a single agent (PPO) from a training "
                                          "config; writes checkpoints, metrics.csv, TensorBoard events and policy.rmpp");
  cmd->add_option("config", args->config, "training config, e.g. configs/train/pretrain-2link.yaml")->required();
  cmd->add_flag("--resume", args->resume, "continue exactly from <output_dir>/checkpoint.ckpt");
  cmd->add_option("--seed", args->seed, "override the config's seed (the default output_dir gets a -seed<N> suffix)")
      ->check(SeedCheck());
  cmd->add_option("--output", args->output, "override output_dir (default: the config's, else runs/<name>)");
  cmd->add_option("--updates", args->updates, "override total_updates")->check(CLI::Range(1, 10000000));
  cmd->add_option("--torch-threads", args->torch_threads, "override torch_threads")->check(CLI::Range(1, 256));
  cmd->add_option("--env-threads", args->env_threads, "override env_threads")->check(CLI::Range(1, 256));
  cmd->add_option("--envs", args->envs,
                  "override num_envs, the environments of each rank (--nproc 2 --envs 8 learns from the batch and the "
                  "episodes of one process of 16, in less time)")
      ->check(CLI::Range(1, 4096));
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
    if (args->envs) {
      config.num_envs = *args->envs;
      const int samples = config.ppo.rollout_steps() * config.num_envs;
      if (config.ppo.minibatches() > samples) {
        throw InputError(fmt::format("--envs {}: expected at least ppo.minibatches = {} env steps per rollout, got {} "
                                     "(rollout_steps {} × {} envs)", *args->envs, config.ppo.minibatches(), samples,
                                     config.ppo.rollout_steps(), config.num_envs));
      }
    }
    if (args->quiet) config.progress = false;
    std::unique_ptr<rl::Collective> collective;
    if (group && group->world_size > 1) {
      if (!std::getenv("RMPMARL_DIST_TIMEOUT")) group->timeout = std::chrono::seconds(args->dist_timeout);
      collective = rl::JoinProcessGroup(*group);
    }
    rl::RunTraining(config, rl::MakeTaskFactory(config.task),
                    rl::RunOptions{.resume = args->resume, .on_update = {}, .collective = collective.get()});
  });
}

}  // namespace rmpmarl::apps
#endif  // RMPMARL_HAS_TORCH
