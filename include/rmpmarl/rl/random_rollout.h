#pragma once
/// Random-action rollouts through the VecEnv engine, counting non-finite values: the soak command (bench/soak.cc,
/// `make soak`) and the random-steps test (tests/rl/random_steps_test.cc) run the same loop.
#include <cstdint>
#include <random>

#include "rmpmarl/tasks/env.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::rl {

/// uniformly random actions for every agent of one env: option indices, continuous values a bit beyond [-1, 1] (the
/// env clips), termination flags set with probability 0.2.
void RandomActions(const tasks::EnvSpec& spec, std::mt19937_64& rng, float* actions);

/// How long and on what a random rollout runs.
struct RandomRolloutOptions {
  int num_envs = 16;
  int threads = 1;          ///< VecEnv worker threads
  long steps = 0;           ///< env steps in all (rounded up to whole batches of num_envs)
  std::uint64_t seed = 0;   ///< VecEnv seed; the actions' RNG is derived from it
};

/// What a random rollout saw.
struct RandomRolloutStats {
  long steps = 0, nonfinite = 0, episodes = 0, invalid_episodes = 0, collisions = 0;
  double seconds = 0.0;
};

/// steps `config`'s task with random actions; every value of every observation, global state, reward term, reward
/// and final observation after every step counts towards `nonfinite`.
RandomRolloutStats RandomRollout(const tasks::TaskConfig& config, const RandomRolloutOptions& options);

}  // namespace rmpmarl::rl
