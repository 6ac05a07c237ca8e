// ≥ 1M random-action env steps over the four tasks through the VecEnv engine: no non-finite value ever reaches an
// observation, a global state or a reward.
#include <gtest/gtest.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>

#include "rmpmarl/rl/random_rollout.h"

namespace rmpmarl::rl {
namespace {

// the share of the 1M steps each task gets (cheap planar pre-training gets most).
struct Share {
  tasks::TaskKind task;
  tasks::InterfaceMode mode;
  long steps;
};

TEST(RandomStepsTest, MillionRandomStepsStayFinite) {
  const Share shares[] = {
      {tasks::TaskKind::kPretrain2Link, tasks::InterfaceMode::kPerJointRmp, 400000},
      {tasks::TaskKind::kPretrain2Link, tasks::InterfaceMode::kDirect, 100000},
      {tasks::TaskKind::kReachAvoid, tasks::InterfaceMode::kPerJointRmp, 200000},
      {tasks::TaskKind::kReachAvoid, tasks::InterfaceMode::kPerJointDirect, 50000},
      {tasks::TaskKind::kLineCrossing, tasks::InterfaceMode::kPerJointRmp, 150000},
      {tasks::TaskKind::kCluttered, tasks::InterfaceMode::kPerJointRmp, 100000},
  };
  // RMPMARL_RANDOM_STEPS_SCALE (default 1) shrinks the run for quick local checks.
  const char* scale_env = std::getenv("RMPMARL_RANDOM_STEPS_SCALE");
  const double scale = scale_env != nullptr ? std::atof(scale_env) : 1.0;
  long total = 0, nonfinite = 0;
  for (const Share& share : shares) {
    tasks::TaskConfig c = tasks::LoadShippedTaskConfig(tasks::TaskKindName(share.task));
    c.interface = share.mode;
    c.episode.max_steps = 200;  // more resets per step budget
    const RandomRolloutStats s =
        RandomRollout(c, {.num_envs = 16, .threads = 2, .steps = static_cast<long>(scale * share.steps),
                          .seed = static_cast<std::uint64_t>(1234 + total)});
    std::printf("[ random ] %-15s %-16s %7ld steps %5ld episodes (%ld invalid, %ld collisions) %6.1f s  %7.0f steps/s  "
                "non-finite %ld\n",
                std::string(tasks::TaskKindName(share.task)).c_str(), std::string(tasks::InterfaceModeName(share.mode)).c_str(),
                s.steps, s.episodes, s.invalid_episodes, s.collisions, s.seconds, s.steps / s.seconds, s.nonfinite);
    EXPECT_EQ(s.nonfinite, 0) << tasks::TaskKindName(share.task);
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
