// The per-episode metrics the experiments report (settled tracking error, time in collision, controller time) and
// a controller on a task's episodes (tasks::ControllerEpisodes, the baselines' harness), against values recomputed
// step by step.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "../rl/rl_test_util.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/tasks/task_episode.h"
#include "rmpmarl/control/controller.h"

namespace rmpmarl::tasks {
namespace {

using rl::testing::Buffers;
using rl::testing::SmallConfig;

// runs one episode with constant actions; returns the distances after each step.
std::vector<double> RunEpisode(ManipulatorEnv& env, Buffers& b, const std::vector<float>& actions, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  env.Reset(rng, b.out());
  std::vector<double> d;
  while (true) {
    env.Step(actions.data(), rng, b.out());
    d.push_back(env.last_step().distance_after);
    if (b.terminated || b.truncated) break;
  }
  return d;
}

TEST(EpisodeMetricsTest, SettledTrackingIsTheMeanDistanceFromOneSecondOn) {
  TaskConfig c = SmallConfig(TaskKind::kReachAvoid);
  c.episode.max_steps = 180;
  ManipulatorEnv env(MakeTaskContext(c));
  Buffers b(env.spec());
  std::vector<float> actions(static_cast<size_t>(env.spec().num_agents) * env.spec().action.size(), 0.0f);
  const std::vector<double> d = RunEpisode(env, b, actions, 11);
  ASSERT_EQ(d.size(), 180u);
  // step k (1-based) ends at t = k · 10 ms: the settled phase is steps 100 … 180
  double settled = 0.0, all = 0.0;
  for (size_t k = 0; k < d.size(); ++k) {
    all += d[k];
    if (k + 1 >= 100) settled += d[k];
  }
  EXPECT_NEAR(b.metrics.mean_tracking_error, all / 180.0, 1e-12);
  EXPECT_NEAR(b.metrics.settled_tracking_error, settled / 81.0, 1e-12);
  EXPECT_GT(b.metrics.mean_control_us, 0.0);  // the basic layer ran
}

TEST(EpisodeMetricsTest, SettledTrackingIsNaNForEpisodesShorterThanOneSecond) {
  TaskConfig c = SmallConfig(TaskKind::kReachAvoid);
  c.episode.max_steps = 50;
  ManipulatorEnv env(MakeTaskContext(c));
  Buffers b(env.spec());
  std::vector<float> actions(static_cast<size_t>(env.spec().num_agents) * env.spec().action.size(), 0.0f);
  RunEpisode(env, b, actions, 3);
  EXPECT_TRUE(std::isnan(b.metrics.settled_tracking_error));
  EXPECT_TRUE(std::isfinite(b.metrics.mean_tracking_error));
}

TEST(EpisodeMetricsTest, TimeInCollisionIsPositiveExactlyWhenThereWereCollisions) {
  // pretrain-2link with the target option everywhere drives the planar arm into the cube on the target's path in
  // many episodes (docs/environments.md); count over a few seeds.
  TaskConfig c = SmallConfig(TaskKind::kPretrain2Link, "", 2);
  c.scenario.pretrain.obstacle_path_offset = {0.0, 0.0};
  ManipulatorEnv env(MakeTaskContext(c));
  Buffers b(env.spec());
  std::vector<float> actions(static_cast<size_t>(env.spec().num_agents) * env.spec().action.size(), 0.0f);
  int with_collisions = 0;
  for (std::uint64_t seed = 1; seed <= 8; ++seed) {
    RunEpisode(env, b, actions, seed);
    EXPECT_EQ(b.metrics.collisions > 0, b.metrics.time_in_collision > 0.0) << "seed " << seed;
    EXPECT_LE(b.metrics.time_in_collision, b.metrics.length * env.spec().control_dt + 1e-12);
    with_collisions += b.metrics.collisions > 0 ? 1 : 0;
  }
  EXPECT_GT(with_collisions, 0);
}

TEST(EpisodeMetricsTest, AControllerRunsTheSameEpisodesAsTheEnvAndIsScoredTheSameWay) {
  TaskConfig c = SmallConfig(TaskKind::kReachAvoid);
  c.episode.max_steps = 300;
  c.scenario.crossing.num_obstacles = 0;
  c.observation.max_obstacles = 4;
  const auto context = MakeTaskContext(c);
  ControllerMaker maker;
  maker.make_policy = [](const kinematics::Robot& robot) {
    return std::make_unique<control::RmpflowAccelerationPolicy>(robot, 4);
  };
  ControllerEpisodes rmpflow(context, maker);
  std::vector<double> d;
  std::mt19937_64 rng(5);
  const EpisodeMetrics m = rmpflow.Run(rng, {.video_fps = 1000.0, .on_frame = [&](const sim::FrameInfo& f) {
                                               if (f.index > 0) d.push_back(f.tracking_error);
                                             }});
  EXPECT_FALSE(m.invalid);
  EXPECT_EQ(m.length, 300);
  ASSERT_EQ(d.size(), 300u);  // a frame after every control period
  // RMPflow converges on the moving target (measured: 0.1–4 mm after 3 s)
  EXPECT_GT(d.front(), 0.05);
  EXPECT_LT(d.back(), 0.01);
  EXPECT_EQ(m.final_tracking_error, d.back());
  double all = 0.0;
  for (double x : d) all += x;
  EXPECT_NEAR(m.mean_tracking_error, all / 300.0, 1e-12);
  EXPECT_LT(m.settled_tracking_error, m.mean_tracking_error);
  EXPECT_GT(m.mean_control_us, 0.0);
  EXPECT_NE(m.episode_return, 0.0);  // the task's reward scores a controller too
  // the same seed gives the same episode to an agent env
  ManipulatorEnv agents(context);
  Buffers b(agents.spec());
  std::mt19937_64 r1(5), r2(5);
  Eigen::Vector3d p_WT0 = Eigen::Vector3d::Constant(NAN);
  rmpflow.Run(r1, {.video_fps = 1.0, .on_frame = [&](const sim::FrameInfo& f) {
                     if (f.index == 0) p_WT0 = f.scenario->target().p_WT;
                   }});
  agents.Reset(r2, b.out());
  EXPECT_EQ(rmpflow.episode().variant(), agents.variant());
  EXPECT_EQ(p_WT0, agents.scenario().target().p_WT);
  EXPECT_EQ(r1(), r2());  // both drew the episode with the same numbers
}

TEST(EpisodeMetricsTest, AControllerMakerWithoutAPolicyMakerIsRejected) {
  const auto context = MakeTaskContext(SmallConfig(TaskKind::kReachAvoid));
  EXPECT_THROW(ControllerEpisodes(context, ControllerMaker{}), InputError);
}

}  // namespace
}  // namespace rmpmarl::tasks
