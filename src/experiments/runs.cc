// Training runs of the experiments as child processes of `rmpmarl train` (runs.h).
#include "rmpmarl/experiments/runs.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <thread>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/trainer.h"

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

std::string DescribeRuns(const std::vector<TrainingRun>& runs, const RunnerOptions& options) {
  std::string md = "| training run | updates | env steps | window success | window return | wall clock |\n"
                   "|---|---|---|---|---|---|\n";
  double total = 0.0;
  for (const TrainingRun& r : runs) {
    std::ifstream in(RunDirectory(options, r.id) / "metrics.csv");
    std::string line;
    std::getline(in, line);
    std::vector<std::string> header;
    {
      std::stringstream ss(line);
      for (std::string f; std::getline(ss, f, ',');) header.push_back(f);
    }
    const auto column = [&](const char* name) {
      return static_cast<size_t>(std::find(header.begin(), header.end(), name) - header.begin());
    };
    const size_t c_seconds = column("seconds"), c_steps = column("env_steps"), c_success = column("success_rate"),
                 c_return = column("mean_return");
    double seconds = 0.0;
    std::vector<std::string> last;
    while (std::getline(in, line)) {
      std::vector<std::string> f;
      std::stringstream ss(line);
      for (std::string x; std::getline(ss, x, ',');) f.push_back(x);
      if (f.size() != header.size()) continue;
      seconds += std::stod(f[c_seconds]);
      last = f;
    }
    total += seconds;
    if (last.empty()) {
      md += fmt::format("| {} | – | – | – | – | – |\n", r.id);
      continue;
    }
    md += fmt::format("| {} | {} | {:.2f} M | {:.0f} % | {:.0f} | {:.1f} min |\n", r.id, last[0],
                      std::stod(last[c_steps]) * 1e-6, 100.0 * std::stod(last[c_success]), std::stod(last[c_return]),
                      seconds / 60.0);
  }
  md += fmt::format("\nTraining total: {:.1f} core-minutes ({:.1f} min of wall clock at {} processes at once).\n",
                    total / 60.0, total / 60.0 / options.jobs, options.jobs);
  return md;
}

fs::path SelfExecutable() { return fs::read_symlink("/proc/self/exe"); }

fs::path RunDirectory(const RunnerOptions& options, const std::string& id) { return options.runs_dir / id; }

fs::path RunPolicy(const RunnerOptions& options, const std::string& id, int snapshot_update) {
  return RunDirectory(options, id) /
         (snapshot_update > 0 ? fmt::format("policy-u{}.rmpp", snapshot_update) : std::string("policy.rmpp"));
}

bool RunFinished(const RunnerOptions& options, const std::string& id) {
  return fs::exists(RunPolicy(options, id)) && fs::exists(RunDirectory(options, id) / "final.ckpt");
}

namespace {

/// the training config a run is trained with (its train.yaml).
rl::TrainConfig RunConfig(const TrainingRun& r, const RunnerOptions& options) {
  const fs::path dir = fs::absolute(RunDirectory(options, r.id));
  rl::TrainConfig config = rl::LoadTrainConfig(r.base_config);
  config.seed = r.seed;
  if (r.total_updates > 0) config.total_updates = r.total_updates;
  config.snapshot_updates = r.snapshot_updates;
  config.output_dir = dir.string();
  config.name = r.id;
  config.checkpoint_every = std::min(config.checkpoint_every, config.total_updates);
  if (!r.init_from.empty()) {
    config.init_actor_from = (fs::absolute(RunDirectory(options, r.init_from)) / "final.ckpt").string();
  }
  if (!r.task_overrides.empty()) {
    if (!config.task.overrides_yaml.empty()) {
      throw InputError(fmt::format("training run {}: {} already has task overrides", r.id, r.base_config));
    }
    config.task.overrides_yaml = r.task_overrides;
  }
  if (!r.mix_task.empty()) {
    config.task.mix_name = r.mix_task;
    config.task.mix_overrides_yaml = r.mix_overrides;
  }
  return config;
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// a finished run with every snapshot, trained with exactly the config it would get now (else InputError: reusing
/// it would report a different method than the one asked for).
bool ReusableRun(const TrainingRun& r, const RunnerOptions& options) {
  if (!RunFinished(options, r.id)) return false;
  const fs::path dir = RunDirectory(options, r.id);
  const std::string expected = rl::ToYaml(RunConfig(r, options));
  if (ReadText(dir / "train.yaml") != expected) {
    throw InputError(fmt::format("training run {} in {} was trained with a different config than this experiment "
                                 "asks for (compare its train.yaml with:\n{}); move or delete the directory to "
                                 "retrain it", r.id, dir.string(), expected));
  }
  for (int u : r.snapshot_updates) {
    if (!fs::exists(RunPolicy(options, r.id, u))) {
      throw InputError(fmt::format("training run {} finished without its snapshot {}; delete {} to retrain it", r.id,
                                   RunPolicy(options, r.id, u).string(), dir.string()));
    }
  }
  return true;
}

/// kills and reaps the children still running when TrainAll leaves by an exception.
struct ChildGuard {
  std::vector<pid_t>* pids;
  ~ChildGuard() {
    for (pid_t pid : *pids) kill(pid, SIGTERM);
    for (pid_t pid : *pids) waitpid(pid, nullptr, 0);
  }
};

std::string DescribeStatus(int status) {
  if (WIFEXITED(status)) return fmt::format("exit status {}", WEXITSTATUS(status));
  if (WIFSIGNALED(status)) return fmt::format("killed by signal {}", WTERMSIG(status));
  return fmt::format("wait status {}", status);
}

}  // namespace

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
    if (ReusableRun(r, options)) {
      fmt::print("  run {}: finished before, reused ({})\n", r.id, RunDirectory(options, r.id).string());
    } else {
      pending.push_back(&r);
    }
  }
  std::fflush(stdout);
  std::vector<Running> running;
  std::vector<pid_t> children;  // of `running`, for the guard
  const ChildGuard guard{&children};
  auto last_progress = std::chrono::steady_clock::now();

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
      const rl::TrainConfig config = RunConfig(r, options);
      const fs::path yaml = dir / "train.yaml";
      std::ofstream(yaml, std::ios::trunc) << rl::ToYaml(config);
      const bool resume = fs::exists(dir / "checkpoint.ckpt");
      const int first = resume ? LastLoggedUpdate(dir) : 0;

      std::vector<std::string> args = {cli.string(), "train", yaml.string()};
      if (resume) args.push_back("--resume");
      std::vector<char*> argv;
      for (std::string& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      const std::string log = (dir / "train.log").string();
      const pid_t parent = getpid();
      const pid_t pid = fork();
      if (pid < 0) throw InputError(fmt::format("cannot start training run {}: fork failed", r.id));
      if (pid == 0) {  // the child: dies with the experiment (no orphan keeps writing the run), output to the log
        prctl(PR_SET_PDEATHSIG, SIGTERM);
        if (getppid() != parent) _exit(127);
        const int fd = open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
        if (fd < 0) _exit(126);
        dup2(fd, STDOUT_FILENO);
        dup2(fd, STDERR_FILENO);
        close(fd);
        execv(cli.c_str(), argv.data());
        _exit(127);
      }
      children.push_back(pid);
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
      std::erase(children, it->pid);
      if (!(WIFEXITED(status) && WEXITSTATUS(status) == 0) || !RunFinished(options, it->run->id)) {
        throw InputError(fmt::format("training run {} failed ({}); the end of {}:\n{}", it->run->id,
                                     DescribeStatus(status), (dir / "train.log").string(),
                                     LogTail(dir / "train.log", 15)));
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
