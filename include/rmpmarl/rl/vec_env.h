#pragma once
/// The generic batched engine: reset/step over N environments on a thread pool, with preallocated batch buffers,
/// auto-reset, and env k's RNG seeded with seed + k. Results are identical for a given seed whatever the thread
/// count (each env is stepped by exactly one thread and draws only from its own RNG).
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <memory>
#include <vector>

#include "rmpmarl/tasks/env.h"

namespace rmpmarl::rl {


/// What Step does with an env whose episode ended (Gymnasium's autoreset modes).
enum class Autoreset {
  /// reset in the same Step: the batch row holds the new episode's first observation, final_* the last one's.
  kSameStep,
  /// the batch row holds the ended episode's last observation; the next Step ignores that env's action, resets it
  /// and writes the new episode's first observation with reward 0 and both flags clear (Gymnasium 1.x's default).
  kNextStep,
};

struct VecEnvOptions {
  int num_envs = 1;
  std::uint64_t seed = 0;
  int num_threads = 1;  ///< worker threads (1: step on the calling thread)
  Autoreset autoreset = Autoreset::kSameStep;
};

/// Batch buffers; rows are envs (for per-agent arrays, env-major: row = env * num_agents + agent).
struct Batch {
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> local_obs;     ///< (N·A) × obs_dim
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> global_state;  ///< N × state_dim
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> reward_terms;  ///< N × terms
  Eigen::VectorXf reward;                                                               ///< N
  std::vector<std::uint8_t> terminated;                                                 ///< N
  std::vector<std::uint8_t> truncated;                                                  ///< N
  Eigen::VectorXf option_started;                                                       ///< N·A
  /// N·A: 1 where the env read the agent's continuous action part this step (StepOutput::parameters_read; 1 for
  /// envs that always read it)
  Eigen::VectorXf parameters_read;
  /// global state at the last step of an episode that ended this step (before the auto-reset), for bootstrapping
  /// truncated episodes; rows of envs that did not end are unspecified.
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> final_global_state;
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> final_local_obs;  ///< likewise, (N·A) × obs
  std::vector<tasks::EpisodeMetrics> metrics;  ///< N, valid where terminated or truncated this step
};

class VecEnv {
 public:
  /// builds num_envs envs with `factory`; all must share one EnvSpec layout (checked). Throws InputError.
  VecEnv(const tasks::EnvFactory& factory, const VecEnvOptions& options);
  ~VecEnv();
  VecEnv(const VecEnv&) = delete;
  VecEnv& operator=(const VecEnv&) = delete;

  const tasks::EnvSpec& spec() const;
  int num_envs() const;
  const VecEnvOptions& options() const;
  /// resets every env (RNGs re-seeded with seed + k) and fills the batch with first observations.
  void Reset();
  /// the same with a new seed (kept for later Reset() calls).
  void Reset(std::uint64_t seed);
  /// resets every env drawing from its RNG where it left off (no re-seeding): the next episodes, not the first again.
  void ResetContinuing();
  /// steps every env with `actions` ((N·A) × action_size, row-major); envs whose episode ends are auto-reset as
  /// options().autoreset says. With kSameStep their batch rows then hold the new episode's first observation, and
  /// final_* hold the last one; with kNextStep final_* are not written.
  void Step(const float* actions);
  const Batch& batch() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rmpmarl::rl
