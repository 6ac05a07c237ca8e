#pragma once
/// The training runs an experiment needs, trained as child processes of `rmpmarl train` (one process per core, as
/// docs/learning.md measured), at most `jobs` at once, dependencies (pre-training) first. Idempotent: a run whose
/// policy.rmpp exists is reused, an interrupted one (checkpoint.ckpt without policy.rmpp) is resumed exactly, so
/// killing an experiment mid-way and running it again trains nothing twice.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace rmpmarl::experiments {

/// One training run: a shipped training config with a seed, a budget and (optionally) a pre-trained actor.
struct TrainingRun {
  std::string id;                      ///< its directory under the runs directory, e.g. "marl-rmp-reach-avoid-seed1"
  std::string base_config;             ///< configs/train/<name>.yaml (absolute or relative to the working directory)
  std::uint64_t seed = 1;
  int total_updates = 0;               ///< 0: the config's
  std::vector<int> snapshot_updates;   ///< also export policy-u<N>.rmpp after these updates (training budgets)
  std::string init_from;               ///< id of the run whose final.ckpt initialises the actor ("": the config's)
  std::string task_overrides;          ///< YAML map merged over the task (e.g. "{observation: {max_obstacles: 6}}")
  std::string mix_task;                ///< a second task half the envs train on (rl::TaskSelection::mix_name), "" none
  std::string mix_overrides;           ///< its overrides
};

/// Where and how the runs are trained.
struct RunnerOptions {
  std::filesystem::path runs_dir;      ///< one directory per run id
  std::filesystem::path cli;           ///< the rmpmarl executable (default: this process's own executable)
  int jobs = 2;                        ///< child processes at once
  double progress_period_s = 30.0;     ///< a progress line per running run this often
};

/// the directory of a run.
std::filesystem::path RunDirectory(const RunnerOptions& options, const std::string& id);
/// its exported final policy (policy.rmpp) or a budget snapshot (policy-u<N>.rmpp).
std::filesystem::path RunPolicy(const RunnerOptions& options, const std::string& id, int snapshot_update = 0);
/// true when the run finished (policy.rmpp present).
bool RunFinished(const RunnerOptions& options, const std::string& id);

/// trains every unfinished run (resuming interrupted ones) with at most options.jobs children at once, each after
/// the run it is initialised from. Writes <run>/train.yaml and <run>/train.log. Throws InputError naming the log of
/// a run that failed, or a dependency that is not in `runs`.
void TrainAll(const std::vector<TrainingRun>& runs, const RunnerOptions& options);

/// a markdown table of the runs: updates, env steps, final training-window success and return, and the training
/// wall clock of each (the sum of its metrics.csv update times, resumes included), with the total.
std::string DescribeRuns(const std::vector<TrainingRun>& runs, const RunnerOptions& options);

/// the path of this process's executable (/proc/self/exe).
std::filesystem::path SelfExecutable();

}  // namespace rmpmarl::experiments
