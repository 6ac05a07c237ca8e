#pragma once
// Buffers for driving one Env directly, random actions, and small task configs the rl tests share.
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

#include "rmpmarl/tasks/env.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/rl/random_rollout.h"

namespace rmpmarl::rl::testing {

// owned output buffers of one env, filled with a sentinel (-7) so that unwritten entries show.
struct Buffers : tasks::StepBuffers {
  explicit Buffers(const tasks::EnvSpec& spec) : tasks::StepBuffers(spec, -7.0f) { terminated = truncated = 7; }
  // obs feature `k` of agent `a`.
  float obs(const tasks::EnvSpec& spec, int a, int k) const { return local_obs[static_cast<size_t>(a) * spec.local_obs_dim + k]; }
};

// index of a feature name in a name list (-1 when absent).
inline int IndexOf(const std::vector<std::string>& names, const std::string& name) {
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<int>(i);
  }
  return -1;
}

// random actions (the library's, shared with the soak command)
using rl::RandomActions;

// a task config with fewer variants (faster contexts) for tests.
inline tasks::TaskConfig SmallConfig(tasks::TaskKind task, const std::string& robot = "", int variants = 2) {
  tasks::TaskConfig c = tasks::DefaultTaskConfig(task);
  if (!robot.empty()) c.robot = robot;
  c.randomization.variants = variants;
  return c;
}

}  // namespace rmpmarl::rl::testing
