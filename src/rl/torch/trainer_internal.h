// Internal to the trainer's sources: the trainer's state (Trainer::Impl), the checkpoint's magic, loading a learner from
// a checkpoint, and the running episode statistics and number formatting of the training log. Not installed.
#pragma once

#include <fmt/format.h>

#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <memory>
#include <string>

#include "rmpmarl/rl/torch/ppo.h"
#include "rmpmarl/rl/torch/trainer.h"
#include "rmpmarl/tasks/env.h"
#include "rmpmarl/rl/vec_env.h"

namespace rmpmarl::rl::internal {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr char kCheckpointMagic[8] = {'R', 'M', 'P', 'M', 'C', 'K', 'P', 'T'};

/// what shapes a learner: two specs with equal fingerprints fit the same networks
std::string SpecFingerprint(const tasks::EnvSpec& s);
/// a whole file; InputError "<what> <path>: cannot open it"
std::string ReadFile(const std::string& path, const char* what);

struct LoadedCheckpoint {
  TrainConfig config;
  tasks::EnvSpec spec;
  std::unique_ptr<Ppo> ppo;
  int update = 0;
  std::int64_t env_steps = 0;
};

/// the learner, config and counters of a checkpoint; InputError naming the file when it cannot be restored
LoadedCheckpoint LoadLearner(const std::string& path);

// running aggregate of finished episodes.
struct EpisodeStats {
  int episodes = 0, successes = 0, collisions = 0, collision_free = 0, clearance_count = 0;
  double return_sum = 0.0, track_sum = 0.0, track_sq = 0.0, final_track_sum = 0.0, clearance_sum = 0.0;
  double length_sum = 0.0, settled_sum = 0.0;
  int settled_count = 0;
  void Add(const tasks::EpisodeMetrics& m) {
    ++episodes;
    if (std::isfinite(m.settled_tracking_error)) {
      settled_sum += 1000.0 * m.settled_tracking_error;
      ++settled_count;
    }
    successes += m.success ? 1 : 0;
    collisions += m.collisions;
    collision_free += m.collisions == 0 ? 1 : 0;
    return_sum += m.episode_return;
    const double track_mm = 1000.0 * m.mean_tracking_error;
    track_sum += track_mm;
    track_sq += track_mm * track_mm;
    final_track_sum += 1000.0 * m.final_tracking_error;
    length_sum += m.length;
    if (std::isfinite(m.min_clearance)) {
      clearance_sum += m.min_clearance;
      ++clearance_count;
    }
  }
  double Mean(double sum) const { return episodes > 0 ? sum / episodes : kNaN; }
};

inline std::string FormatDuration(double seconds) {
  if (!std::isfinite(seconds) || seconds < 0) return "--:--";
  const long s = std::lround(seconds);
  return s >= 3600 ? fmt::format("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
                   : fmt::format("{:02}:{:02}", s / 60, s % 60);
}

inline std::string Num(double v, const char* spec = "{:.3g}") {
  return std::isfinite(v) ? fmt::format(fmt::runtime(spec), v) : std::string("-");
}

}  // namespace rmpmarl::rl::internal

namespace rmpmarl::rl {

// the trainer's state, shared by the update loop (trainer.cc) and the checkpoints (trainer_checkpoint.cc)
struct Trainer::Impl {
  Collective* collective = nullptr;
  int rank = 0, world = 1;
  TrainConfig config;
  tasks::EnvFactory factory;
  tasks::EnvSpec spec;
  std::unique_ptr<VecEnv> env;
  std::unique_ptr<Ppo> ppo;
  int update = 0;
  std::int64_t env_steps = 0;
  int env_built_for = 0;   // the segment-start update the current VecEnv was seeded for
  int envs_reset_at = -1;  // update at which the current envs were seeded and reset
  std::deque<tasks::EpisodeMetrics> recent;  // the last stats_window finished episodes (checkpointed)

  // seeds and resets the envs for the segment that starts at update u (env k: seed + u·N + k).
  void ResetEnvs(int u) {
    if (!env || env_built_for != u) {
      const std::uint64_t seed = config.seed + static_cast<std::uint64_t>(u) * config.num_envs * world +
                                 static_cast<std::uint64_t>(rank) * config.num_envs;
      env = std::make_unique<VecEnv>(factory, VecEnvOptions{config.num_envs, seed, config.env_threads});
      env_built_for = u;
    }
    env->Reset();  // re-seeds env k's RNG with the VecEnv's seed + k
    envs_reset_at = u;
  }

  UpdateSummary RunUpdate();
};

}  // namespace rmpmarl::rl
