#pragma once
/// Training runs: the YAML training config, the PPO/MAPPO training loop over a VecEnv, checkpoints (full state,
/// atomic, checksummed), resume, evaluation and policy export. Torch-free header (the implementation uses libtorch)
/// so that the CLI compiles quickly.
///
/// Exact resume: the envs are re-seeded and reset at every checkpoint boundary (update u with
/// u % checkpoint_every == 0; env k of segment s = u / checkpoint_every is seeded with seed + s·num_envs + k), so a
/// checkpoint never has to hold an env's simulation state and a resumed run equals an uninterrupted one bit for bit.
/// Episodes running at a boundary are cut there (bootstrapped from V like any rollout end, not reported).
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "rmpmarl/tasks/env.h"
#include "rmpmarl/rl/torch/ppo_options.h"
#include "rmpmarl/rl/vec_env.h"

namespace rmpmarl::rl {
class Collective;
}

namespace rmpmarl::rl {

/// Which environment to train on (resolved by MakeTaskFactory).
struct TaskSelection {
  std::string name;            ///< e.g. "pretrain-2link", "reach-avoid", "toy-reach"
  std::string config;          ///< optional task YAML (e.g. configs/tasks/reach-avoid.yaml)
  std::string interface;       ///< e.g. "per-joint-rmp", "direct", "per-joint-direct" (task-defined)
  std::string overrides_yaml;  ///< optional YAML map of task parameters (task-defined)
  /// a second task trained alongside (a mixture of scenes): that share of the envs runs it instead, with
  /// the same interface; both must be manipulator tasks with one batch layout (same robot, obstacle slots). "": none
  std::string mix_name;
  std::string mix_overrides_yaml;  ///< its overrides (as overrides_yaml)
  double mix_fraction = 0.5;       ///< share of the envs that run the mix task, in (0, 1)
};

/// A training run, as read from configs/train/<name>.yaml (docs/learning.md lists every key).
struct TrainConfig {
  std::string name;
  TaskSelection task;
  std::string algorithm = "mappo";  ///< "mappo" or "ppo" (the same code; "ppo" requires num_agents == 1)
  std::uint64_t seed = 1;
  int num_envs = 16;
  int env_threads = 1;              ///< VecEnv worker threads (results do not depend on it)
  int torch_threads = 1;            ///< libtorch/OpenBLAS threads
  int total_updates = 100;
  int checkpoint_every = 25;        ///< also the env re-seeding period (see above)
  std::string output_dir;           ///< empty: no files are written
  std::string init_actor_from;      ///< checkpoint of a pre-trained agent whose actor initialises the shared actor
  /// training-budget snapshots: after each of these updates the actor is also exported as
  /// <output_dir>/policy-u<update>.rmpp (e.g. the paper's 5K/10K budgets of Table 3 inside one 15K run). 1..total.
  std::vector<int> snapshot_updates;
  bool write_csv = true;
  bool write_tensorboard = true;
  bool progress = true;             ///< progress bar and one line per update on stderr/stdout
  int stats_window = 100;           ///< episode metrics are averaged over this many recent episodes
  NetworkOptions network;
  PpoOptions ppo;
};

/// reads a training config; unknown keys and bad values throw InputError naming the file and key.
TrainConfig LoadTrainConfig(const std::string& path);
/// parses a training config from YAML text; `where` names the source in messages.
TrainConfig ParseTrainConfig(const std::string& yaml_text, const std::string& where);
/// the config as flat (dotted key, value) pairs in a fixed order; ParseTrainConfig accepts the YAML of ToYaml.
std::vector<std::pair<std::string, std::string>> FlattenTrainConfig(const TrainConfig& config);
std::string ToYaml(const TrainConfig& config);

/// makes the env factory of a task: the built-in "toy-reach" (any number of agents; interface "options" or
/// "direct") and the manipulator tasks. Throws InputError for an unknown task, listing the known ones.
tasks::EnvFactory MakeTaskFactory(const TaskSelection& task);
std::vector<std::string> KnownTasks();

/// One update's numbers. Episode metrics are over the last `logging.window` episodes that ended (across updates;
/// NaN before the first).
struct UpdateSummary {
  int update = 0;               ///< updates done so far
  std::int64_t env_steps = 0;   ///< env steps so far (all envs)
  int episodes = 0;             ///< episodes that ended during this update's rollout
  int window_episodes = 0;      ///< episodes the metrics below are over
  double mean_return = 0.0, success_rate = 0.0, tracking_error_mm = 0.0, final_tracking_error_mm = 0.0;
  double min_clearance_m = 0.0, collisions_per_episode = 0.0, episode_length = 0.0;
  double policy_loss = 0.0, value_loss = 0.0;
  double entropy_option = 0.0, entropy_continuous = 0.0, entropy_termination = 0.0;
  double approx_kl = 0.0, clip_fraction = 0.0, explained_variance = 0.0;
  double actor_grad_norm = 0.0, critic_grad_norm = 0.0;
  double lr = 0.0;
  double fps = 0.0;             ///< env steps per second of this update (rollout + learning), all ranks
  double seconds = 0.0;         ///< wall clock of this update
  double rollout_seconds = 0.0; ///< of which collecting the rollout (env steps + acting)
  double learn_seconds = 0.0;   ///< of which GAE and the PPO epochs
};

/// The PPO/MAPPO training loop for one config.
class Trainer {
 public:
  /// builds fresh networks (initialised from config.init_actor_from when set) and the envs. Throws InputError.
  /// With a collective of W > 1 ranks (distributed.h) this is rank r of a data-parallel run: its envs are
  /// seeded apart from every other rank's (env k of rank r in segment s: seed + s·N·W + r·N + k, so W ranks of N envs
  /// see the episodes one process of W·N envs would), rank 0's networks are broadcast, and every update learns from
  /// every rank's rollout.
  Trainer(const TrainConfig& config, tasks::EnvFactory factory, Collective* collective = nullptr);
  ~Trainer();
  Trainer(const Trainer&) = delete;
  Trainer& operator=(const Trainer&) = delete;

  /// restores the full training state from a checkpoint of a run with the same config and env layout; a corrupt
  /// file or a mismatch throws InputError saying what differs.
  void Resume(const std::string& checkpoint_path);
  /// collects one rollout and runs the PPO epochs.
  UpdateSummary RunUpdate();
  bool finished() const;
  int update() const;
  std::int64_t env_steps() const;
  const TrainConfig& config() const;
  const tasks::EnvSpec& spec() const;

  /// writes the full state (networks, optimiser, normalisers, RNG states, counters, config) atomically. In a
  /// data-parallel run every rank calls it (their sampling generators are gathered) and rank 0 alone writes.
  void SaveCheckpoint(const std::string& path) const;
  /// a CRC-32C of the parameters, Adam moments and normaliser statistics: equal on every rank of a data-parallel run.
  std::uint32_t LearnerChecksum() const;
  int rank() const;
  int world_size() const;
  /// writes the actor for the torch-free runtime (policy_runtime.h).
  void ExportPolicy(const std::string& path) const;
  /// every parameter, optimiser moment and normaliser statistic, flattened (for exactness tests).
  std::vector<double> StateVector() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Options of RunTraining beyond the config.
struct RunOptions {
  bool resume = false;  ///< continue from <output_dir>/checkpoint.ckpt
  /// called after every update (e.g. tests); may be empty.
  std::function<void(const UpdateSummary&)> on_update;
  /// a data-parallel run's process group (null: one process): rank 0 alone prints progress and writes the
  /// checkpoints, metrics, TensorBoard events and policy files.
  Collective* collective = nullptr;
};

/// trains `config` to total_updates with progress output, CSV/TensorBoard metrics, periodic and final checkpoints
/// (<output_dir>/checkpoint.ckpt, final.ckpt) and the exported policy (<output_dir>/policy.rmpp). Returns the last
/// summary.
UpdateSummary RunTraining(const TrainConfig& config, const tasks::EnvFactory& factory, const RunOptions& options = {});

/// the config stored in a checkpoint (throws InputError for a corrupt file).
TrainConfig ReadCheckpointConfig(const std::string& checkpoint_path);

struct EvalOptions {
  int episodes = 100;
  int num_envs = 8;
  int env_threads = 1;
  std::uint64_t seed = 1000003;
  bool stochastic = false;  ///< sample actions instead of taking the modes
};

/// Aggregate episode metrics of an evaluation.
struct EvalResult {
  int episodes = 0;
  double success_rate = 0.0;
  double tracking_error_mean_mm = 0.0, tracking_error_std_mm = 0.0;  ///< per-episode mean tracking error
  double final_tracking_error_mean_mm = 0.0;
  /// mean over episodes of the settled tracking error (t ≥ kSettleTime; NaN when no episode lasted that long)
  double settled_tracking_error_mean_mm = 0.0;
  double min_clearance_mean_m = 0.0;   ///< mean over episodes of the smallest clearance (finite ones)
  double collisions_per_episode = 0.0;
  double collision_free_rate = 0.0;
  double mean_return = 0.0, mean_length = 0.0;
};

/// runs `options.episodes` episodes (env k runs its share, so short failing episodes are not over-counted) with
/// the actor of a checkpoint (.ckpt, libtorch) or of an exported policy file (.rmpp, the Eigen runtime).
EvalResult Evaluate(const std::string& policy_path, const tasks::EnvFactory& factory, const EvalOptions& options);

/// the episodes env k of `num_envs` runs in an evaluation: the first `episodes` in (env, episode) order, so env k
/// runs episodes / num_envs, one more for k < episodes % num_envs (Evaluate; a controller on the same episodes).
std::vector<int> EvaluationShares(int episodes, int num_envs);

/// the summary of ended episodes (Evaluate's, or a controller's on tasks::ControllerEpisodes). Throws InputError
/// for none.
EvalResult SummarizeEpisodes(const std::vector<tasks::EpisodeMetrics>& episodes);

/// rewrites a format-1 checkpoint (a torch::serialize archive) as format 2 (TensorArchive) at
/// out_path (may equal path). Format 1 is read through TorchScript's importer, which is not safe on untrusted files
/// (tensor_archive.h): upgrade only files you trust. Throws InputError for a corrupt file or one already format 2.
void UpgradeCheckpoint(const std::string& path, const std::string& out_path);

/// writes the actor of a checkpoint as a policy file for the torch-free runtime (policy_runtime.h).
void ExportCheckpointPolicy(const std::string& checkpoint_path, const std::string& policy_path);

/// chooses libtorch's intra-op threads and OpenBLAS's threads (when OpenBLAS is the loaded BLAS).
void SetTorchThreads(int threads);

}  // namespace rmpmarl::rl
