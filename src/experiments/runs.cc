// Training runs of the experiments as child processes of `rmpmarl train` (runs.h).
#include "rmpmarl/experiments/runs.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <thread>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/trainer.h"

extern char** environ;

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

struct Running {
  const TrainingRun* run = nullptr;
  pid_t pid = -1;
  int total_updates = 0;
  int first_update = 0;
  std::chrono::steady_clock::time_point start;
};

/// the last update written to a run's metrics.csv (0 when none).
int LastLoggedUpdate(const fs::path& dir) {
  std::ifstream in(dir / "metrics.csv");
  std::string line, last;
  while (std::getline(in, line)) {
    if (!line.empty()) last = line;
  }
  if (last.empty() || !std::isdigit(static_cast<unsigned char>(last[0]))) return 0;
  return std::stoi(last.substr(0, last.find(',')));
}

std::string Duration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long s = std::lround(seconds);
  return fmt::format("{:02}:{:02}", s / 60, s % 60);
}

std::string LogTail(const fs::path& log, int lines) {
  std::ifstream in(log);
  std::vector<std::string> all;
  for (std::string line; std::getline(in, line);) all.push_back(line);
  std::string out;
  for (size_t k = all.size() > static_cast<size_t>(lines) ? all.size() - lines : 0; k < all.size(); ++k) {
    out += "    " + all[k] + "\n";
  }
  return out;
}

}  // namespace

fs::path SelfExecutable() { return fs::read_symlink("/proc/self/exe"); }

fs::path RunDirectory(const RunnerOptions& options, const std::string& id) { return options.runs_dir / id; }

fs::path RunPolicy(const RunnerOptions& options, const std::string& id, int snapshot_update) {
  return RunDirectory(options, id) /
         (snapshot_update > 0 ? fmt::format("policy-u{}.rmpp", snapshot_update) : std::string("policy.rmpp"));
}

bool RunFinished(const RunnerOptions& options, const std::string& id) {
  return fs::exists(RunPolicy(options, id)) && fs::exists(RunDirectory(options, id) / "final.ckpt");
}

void TrainAll(const std::vector<TrainingRun>& runs, const RunnerOptions& options) {
  if (options.jobs < 1) throw InputError(fmt::format("jobs: expected >= 1, got {}", options.jobs));
  const fs::path cli = options.cli.empty() ? SelfExecutable() : options.cli;
  std::map<std::string, const TrainingRun*> by_id;
  for (const TrainingRun& r : runs) {
    if (!by_id.emplace(r.id, &r).second) throw InputError(fmt::format("training run \"{}\" listed twice", r.id));
  }
  for (const TrainingRun& r : runs) {
    if (!r.init_from.empty() && !by_id.count(r.init_from)) {
      throw InputError(fmt::format("training run \"{}\" starts from \"{}\", which is not among the runs", r.id,
                                   r.init_from));
    }
  }
  std::vector<const TrainingRun*> pending;
  for (const TrainingRun& r : runs) {
    if (RunFinished(options, r.id)) {
      fmt::print("  run {}: finished before, reused ({})\n", r.id, RunDirectory(options, r.id).string());
    } else {
      pending.push_back(&r);
    }
  }
  std::fflush(stdout);
  std::vector<Running> running;
  auto last_progress = std::chrono::steady_clock::now();
  const auto kill_all = [&running] {
    for (const Running& c : running) kill(c.pid, SIGTERM);
    for (const Running& c : running) waitpid(c.pid, nullptr, 0);
  };

  while (!pending.empty() || !running.empty()) {
    // start what is ready
    for (auto it = pending.begin(); it != pending.end() && static_cast<int>(running.size()) < options.jobs;) {
      const TrainingRun& r = **it;
      if (!r.init_from.empty() && !RunFinished(options, r.init_from)) {
        ++it;
        continue;
      }
      const fs::path dir = fs::absolute(RunDirectory(options, r.id));
      fs::create_directories(dir);
      rl::TrainConfig config = rl::LoadTrainConfig(r.base_config);
      config.seed = r.seed;
      if (r.total_updates > 0) config.total_updates = r.total_updates;
      config.snapshot_updates = r.snapshot_updates;
      config.output_dir = dir.string();
      config.name = r.id;
      config.checkpoint_every = std::min(config.checkpoint_every, config.total_updates);
      if (!r.init_from.empty()) config.init_actor_from = (fs::absolute(RunDirectory(options, r.init_from)) /
                                                          "final.ckpt").string();
      if (!r.task_overrides.empty()) {
        if (!config.task.overrides_yaml.empty()) {
          throw InputError(fmt::format("training run {}: {} already has task overrides", r.id, r.base_config));
        }
        config.task.overrides_yaml = r.task_overrides;
      }
      const fs::path yaml = dir / "train.yaml";
      std::ofstream(yaml, std::ios::trunc) << rl::ToYaml(config);
      const bool resume = fs::exists(dir / "checkpoint.ckpt");
      const int first = resume ? LastLoggedUpdate(dir) : 0;

      posix_spawn_file_actions_t actions;
      posix_spawn_file_actions_init(&actions);
      const std::string log = (dir / "train.log").string();
      posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
      posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
      std::vector<std::string> args = {cli.string(), "train", yaml.string()};
      if (resume) args.push_back("--resume");
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      pid_t pid = -1;
      const int rc = posix_spawn(&pid, cli.c_str(), &actions, nullptr, argv.data(), environ);
      posix_spawn_file_actions_destroy(&actions);
      if (rc != 0) {
        kill_all();
        throw InputError(fmt::format("cannot start {} for training run {}: {}", cli.string(), r.id, strerror(rc)));
      }
      fmt::print("  run {}: {} {} updates{} (log {})\n", r.id, resume ? "resuming at update " +
                 std::to_string(first) + " of" : "training", config.total_updates,
                 r.init_from.empty() ? "" : ", actor from " + r.init_from, log);
      std::fflush(stdout);
      running.push_back({&r, pid, config.total_updates, first, std::chrono::steady_clock::now()});
      it = pending.erase(it);
    }
    if (running.empty()) {  // nothing can start: a dependency is missing
      throw InputError(fmt::format("training run {} waits for {}, which did not finish", pending.front()->id,
                                   pending.front()->init_from));
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    // reap
    for (auto it = running.begin(); it != running.end();) {
      int status = 0;
      const pid_t done = waitpid(it->pid, &status, WNOHANG);
      if (done == 0) {
        ++it;
        continue;
      }
      const fs::path dir = RunDirectory(options, it->run->id);
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - it->start).count();
      if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0) || !RunFinished(options, it->run->id)) {
        const std::string id = it->run->id;
        running.erase(it);
        kill_all();
        throw InputError(fmt::format("training run {} failed (exit status {}); the end of {}:\n{}", id, status,
                                     (dir / "train.log").string(), LogTail(dir / "train.log", 15)));
      }
      fmt::print("  run {}: done in {}\n", it->run->id, Duration(elapsed));
      std::fflush(stdout);
      it = running.erase(it);
    }
    const auto now = std::chrono::steady_clock::now();
    if (std::chrono::duration<double>(now - last_progress).count() >= options.progress_period_s) {
      last_progress = now;
      for (const Running& c : running) {
        const int u = LastLoggedUpdate(RunDirectory(options, c.run->id));
        const double elapsed = std::chrono::duration<double>(now - c.start).count();
        const double eta = u > c.first_update ? elapsed / (u - c.first_update) * (c.total_updates - u) : NAN;
        fmt::print("  run {}: update {}/{}  elapsed {}  ETA {}\n", c.run->id, u, c.total_updates, Duration(elapsed),
                   Duration(eta));
      }
      std::fflush(stdout);
    }
  }
}

}  // namespace rmpmarl::experiments
