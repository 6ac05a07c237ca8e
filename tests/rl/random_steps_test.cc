// ≥ 1M random-action env steps over the four tasks through the VecEnv engine: no non-finite value ever reaches an
// observation, a global state or a reward.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdlib>

#include "rl_test_util.h"
#include "rmpmarl/rl/manipulator_env.h"
#include "rmpmarl/rl/vec_env.h"

namespace rmpmarl::rl {
namespace {

struct RandomRunStats {
  long steps = 0;
  long nonfinite = 0;
  long episodes = 0;
  long invalid_episodes = 0;
  long collisions = 0;
  double seconds = 0.0;
};

RandomRunStats RunRandom(const TaskConfig& config, int num_envs, long steps, std::uint64_t seed) {
  auto context = MakeTaskContext(config);
  VecEnv envs(MakeManipulatorEnvFactory(context), {.num_envs = num_envs, .seed = seed, .num_threads = 2});
  const EnvSpec& spec = envs.spec();
  std::vector<float> actions(static_cast<size_t>(num_envs) * spec.num_agents * spec.action.size());
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ull);
  RandomRunStats s;
  const auto start = std::chrono::steady_clock::now();
  envs.Reset();
  const auto count = [&s](const float* p, size_t n) {
    for (size_t k = 0; k < n; ++k) s.nonfinite += std::isfinite(p[k]) ? 0 : 1;
  };
  while (s.steps < steps) {
    for (int k = 0; k < num_envs; ++k) {
      testing::RandomActions(spec, rng, actions.data() + static_cast<size_t>(k) * spec.num_agents * spec.action.size());
    }
    envs.Step(actions.data());
    const Batch& b = envs.batch();
    count(b.local_obs.data(), b.local_obs.size());
    count(b.global_state.data(), b.global_state.size());
    count(b.reward_terms.data(), b.reward_terms.size());
    count(b.reward.data(), b.reward.size());
    count(b.final_local_obs.data(), b.final_local_obs.size());
    count(b.final_global_state.data(), b.final_global_state.size());
    for (int k = 0; k < num_envs; ++k) {
      if (b.terminated[k] || b.truncated[k]) {
        ++s.episodes;
        s.invalid_episodes += b.metrics[k].invalid ? 1 : 0;
        s.collisions += b.metrics[k].collisions;
      }
    }
    s.steps += num_envs;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

// the share of the 1M steps each task gets (cheap planar pre-training gets most).
struct Share {
  TaskKind task;
  InterfaceMode mode;
  long steps;
};

TEST(RandomStepsTest, MillionRandomStepsStayFinite) {
  const Share shares[] = {
      {TaskKind::kPretrain2Link, InterfaceMode::kPerJointRmp, 400000},
      {TaskKind::kPretrain2Link, InterfaceMode::kDirect, 100000},
      {TaskKind::kReachAvoid, InterfaceMode::kPerJointRmp, 200000},
      {TaskKind::kReachAvoid, InterfaceMode::kPerJointDirect, 50000},
      {TaskKind::kLineCrossing, InterfaceMode::kPerJointRmp, 150000},
      {TaskKind::kCluttered, InterfaceMode::kPerJointRmp, 100000},
  };
  // RMPMARL_RANDOM_STEPS_SCALE (default 1) shrinks the run for quick local checks.
  const char* scale_env = std::getenv("RMPMARL_RANDOM_STEPS_SCALE");
  const double scale = scale_env != nullptr ? std::atof(scale_env) : 1.0;
  long total = 0, nonfinite = 0;
  for (const Share& share : shares) {
    TaskConfig c = LoadShippedTaskConfig(TaskKindName(share.task));
    c.interface = share.mode;
    c.episode.max_steps = 200;  // more resets per step budget
    const RandomRunStats s = RunRandom(c, 16, static_cast<long>(scale * share.steps), 1234 + total);
    std::printf("[ random ] %-15s %-16s %7ld steps %5ld episodes (%ld invalid, %ld collisions) %6.1f s  %7.0f steps/s  "
                "non-finite %ld\n",
                std::string(TaskKindName(share.task)).c_str(), std::string(InterfaceModeName(share.mode)).c_str(),
                s.steps, s.episodes, s.invalid_episodes, s.collisions, s.seconds, s.steps / s.seconds, s.nonfinite);
    EXPECT_EQ(s.nonfinite, 0) << TaskKindName(share.task);
    if (scale >= 1.0) {
      EXPECT_GT(s.episodes, 0);
    }
    total += s.steps;
    nonfinite += s.nonfinite;
  }
  std::printf("[ random ] total %ld steps, non-finite values %ld\n", total, nonfinite);
  if (scale >= 1.0) {
    EXPECT_GE(total, 1000000);
  }
}

}  // namespace
}  // namespace rmpmarl::rl
