// ManipulatorEnv episodes: option persistence, link-length variants, resets and their randomisation, scenario
// paths and speeds, determinism across seeds and thread counts.
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/common/error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <set>

#include "../rl/rl_test_util.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/sim/pretrain_scenario.h"
#include "rmpmarl/rl/vec_env.h"


namespace rmpmarl::tasks {
namespace {

using rl::testing::Buffers;
using rl::testing::IndexOf;
using rl::testing::RandomActions;
using rl::testing::SmallConfig;
using sim::ReflectedDirection;
using sim::ReflectedPosition;

std::vector<int> StartedPattern(OptionTermination termination, int horizon, const std::vector<int>& flags) {
  TaskConfig c = SmallConfig(TaskKind::kPretrain2Link, "", 1);
  c.options.termination = termination;
  c.options.horizon = horizon;
  ManipulatorEnv env(MakeTaskContext(c));
  const EnvSpec& s = env.spec();
  Buffers b(s);
  std::mt19937_64 rng(2);
  env.Reset(rng, b.out());
  std::vector<int> started;
  std::vector<float> actions(s.num_agents * s.action.size(), 0.0f);  // option 0 = target, scales 1
  for (size_t t = 0; t < flags.size(); ++t) {
    if (s.action.has_termination) actions[s.action.termination_offset()] = static_cast<float>(flags[t]);
    env.Step(actions.data(), rng, b.out());
    started.push_back(static_cast<int>(b.option_started[0]));
    // the observation shows the running option (zeros once it ended)
    const bool running = !env.option_machine(0).idle();
    EXPECT_EQ(b.obs(s, 0, control::LocalObs::kOption), running ? 1.0f : 0.0f);
    EXPECT_EQ(b.option_started[1], started.size() == 1 || (termination == OptionTermination::kFixed &&
                                                            (started.size() - 1) % horizon == 0)
                                       ? 1.0f
                                       : 0.0f);
  }
  return started;
}

TEST(ManipulatorEnvTest, OptionsPersistForAFixedHorizon) {
  EXPECT_EQ(StartedPattern(OptionTermination::kFixed, 4, std::vector<int>(10, 1)),
            (std::vector<int>{1, 0, 0, 0, 1, 0, 0, 0, 1, 0}));
}

TEST(ManipulatorEnvTest, OptionsPersistUntilTheLearnedTerminationFires) {
  EXPECT_EQ(StartedPattern(OptionTermination::kLearned, 4, {0, 0, 0, 0, 0, 0, 1, 0, 1, 1, 0}),
            (std::vector<int>{1, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1}));
}

// ------------------------------------------------------------------------------- domain randomisation

TEST(ManipulatorEnvTest, LinkLengthVariantsRespectTheirRanges) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.randomization.variants = 8;
  auto planar = MakeTaskContext(c);
  std::set<double> lengths;
  for (int k = 0; k < planar->num_variants(); ++k) {
    const RobotVariant& v = planar->variant(k);
    for (double len : v.planar2_lengths) {
      EXPECT_GE(len, 0.3);
      EXPECT_LE(len, 0.7);
      lengths.insert(len);
    }
    // the compiled robot has those lengths: the end effector at q = 0 is at l1 + l2 along x
    const kinematics::Robot& robot = v.world_model->robot();
    kinematics::Data data(robot.model);
    kinematics::CalcForwardKinematics(robot.model, Eigen::Vector2d::Zero(), &data);
    const Eigen::Vector3d p = kinematics::CalcPointPosition(data, robot.end_effector.link,
                                                            robot.end_effector.X_LE.translation());
    EXPECT_NEAR(p.x(), v.planar2_lengths[0] + v.planar2_lengths[1], 1e-12);
  }
  EXPECT_NEAR(planar->variant(0).planar2_lengths[0], 0.5, 1e-12);  // the nominal variant
  EXPECT_GE(lengths.size(), 14u);

  TaskConfig u = SmallConfig(TaskKind::kReachAvoid, "ur5e", 5);
  u.randomization.link_scale = {0.8, 1.2};
  auto arm = MakeTaskContext(u);
  const kinematics::Robot nominal = kinematics::LoadShippedRobot("ur5e");
  for (int k = 0; k < arm->num_variants(); ++k) {
    const double s = arm->variant(k).link_scale;
    EXPECT_GE(s, 0.8);
    EXPECT_LE(s, 1.2);
    const kinematics::Robot& r = arm->variant(k).world_model->robot();
    for (int j = 0; j < nominal.model.num_links(); ++j) {
      EXPECT_LT((r.model.link(j).X_PJ.translation() - s * nominal.model.link(j).X_PJ.translation()).norm(), 1e-12);
    }
    for (size_t j = 0; j < nominal.capsules.size(); ++j) {
      EXPECT_NEAR(r.capsules[j].radius, s * nominal.capsules[j].radius, 1e-12);
      EXPECT_LT((r.capsules[j].p_LB - s * nominal.capsules[j].p_LB).norm(), 1e-12);
    }
    EXPECT_LT((r.end_effector.X_LE.translation() - s * nominal.end_effector.X_LE.translation()).norm(), 1e-12);
  }
  EXPECT_EQ(arm->variant(0).link_scale, 1.0);
}

TEST(ManipulatorEnvTest, ResetsReuseTheVariantPool) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.randomization.variants = 4;
  const long before_context = WorldModelsBuilt();
  auto context = MakeTaskContext(c);
  EXPECT_EQ(WorldModelsBuilt() - before_context, 4);  // K models, once
  const long before = WorldModelsBuilt();
  rl::VecEnv envs(MakeManipulatorEnvFactory(context), {.num_envs = 3, .seed = 11, .num_threads = 1});
  std::vector<std::unique_ptr<ManipulatorEnv>> direct;
  for (int k = 0; k < 2; ++k) direct.push_back(std::make_unique<ManipulatorEnv>(context));
  std::set<const sim::WorldModel*> used;
  std::mt19937_64 rng(4);
  Buffers b(context->spec());
  for (int r = 0; r < 40; ++r) {
    envs.Reset();
    for (auto& env : direct) {
      env->Reset(rng, b.out());
      used.insert(env->world().shared_model().get());
      EXPECT_EQ(env->world().shared_model(), context->variant(env->variant()).world_model);  // the pool's model
    }
  }
  EXPECT_EQ(WorldModelsBuilt(), before);  // envs and resets built none
  EXPECT_EQ(used.size(), 4u);             // every variant was drawn
  EXPECT_GE(context->variant(0).world_model.use_count(), 2);
}

TEST(ManipulatorEnvTest, PretrainResetsRandomiseWithinTheirRanges) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.scenario.pretrain.obstacle_path_offset = {0.0, 0.0};  // the paper's scene: the cube on the path
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  Buffers b(env.spec());
  std::mt19937_64 rng(9);
  std::set<double> q0s, speeds;
  for (int r = 0; r < 30; ++r) {
    env.Reset(rng, b.out());
    const Eigen::VectorXd& q = env.world().q();
    const Eigen::VectorXd& qd = env.world().qd();
    for (int i = 0; i < 2; ++i) {
      EXPECT_LE(std::abs(q[i]), 1.5 + 1e-12);  // ready posture 0 ± initial_q_spread
      EXPECT_LE(std::abs(qd[i]), 0.2 * 3.0 + 1e-12);
    }
    q0s.insert(q[0]);
    const sim::TargetState& t = env.scenario().target();
    const double v = t.v_WT.norm();
    EXPECT_GE(v, 0.05 - 1e-12);
    EXPECT_LE(v, 0.25 + 1e-12);
    EXPECT_NEAR(t.v_WT.z(), 0.0, 1e-12);  // in the arm's plane
    speeds.insert(v);
    EXPECT_TRUE(t.bounds.contains(t.p_WT));
    // the cube sits on the target's reflected path, 1–3 s ahead
    const Eigen::Vector3d cube = env.scenario().obstacles()[0].p_WO();
    double nearest = 1e9;
    for (double time = 1.0; time <= 3.0; time += 1e-3) {
      nearest = std::min(nearest, (ReflectedPosition(t.p_WT, t.v_WT, time, t.bounds) - cube).norm());
    }
    EXPECT_LT(nearest, 1e-3);
  }
  EXPECT_EQ(q0s.size(), 30u);
  EXPECT_EQ(speeds.size(), 30u);
}

TEST(ManipulatorEnvTest, PretrainPathOffsetPutsTheCubeBesideTheWholePath) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.scenario.pretrain.obstacle_path_offset = {0.05, 0.10};
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  Buffers b(env.spec());
  std::mt19937_64 rng(21);
  const double h = 0.5 * c.scenario.pretrain.obstacle_side;
  int left = 0, right = 0;
  for (int r = 0; r < 30; ++r) {
    env.Reset(rng, b.out());
    const sim::TargetState& t = env.scenario().target();
    const Eigen::Vector3d cube = env.scenario().obstacles()[0].p_WO();
    // brute force, 1 ms steps, the distance from the library's capsule–box query (a point: a zero-radius capsule):
    // the whole path (the scenario's duration) keeps the range's minimum from the cube ...
    math::Box box;
    box.X_WB.translation() = cube;
    box.half_size.setConstant(h);
    double nearest_all = 1e9, nearest_lead = 1e9, time_lead = 0.0;
    for (double time = 0.0; time <= env.scenario().default_duration(); time += 1e-3) {
      const Eigen::Vector3d x = ReflectedPosition(t.p_WT, t.v_WT, time, t.bounds);
      const double d = math::CapsuleBoxDistance(math::Capsule{x, x, 0.0}, box).distance;
      nearest_all = std::min(nearest_all, d);
      if (time >= 1.0 && time <= 3.0 && d < nearest_lead) {
        nearest_lead = d;
        time_lead = time;
      }
    }
    EXPECT_GE(nearest_all, 0.05 - 1e-3);
    // ... and passes it within the range's maximum (plus a corner's excess over a face, h (sqrt 2 - 1)) 1–3 s ahead
    EXPECT_LE(nearest_lead, 0.10 + h * (std::sqrt(2.0) - 1.0) + 1e-3);
    const Eigen::Vector3d p = ReflectedPosition(t.p_WT, t.v_WT, time_lead, t.bounds);
    const Eigen::Vector3d d = ReflectedDirection(t.p_WT, t.v_WT, time_lead, t.bounds);
    (d.cross(cube - p).z() > 0.0 ? left : right)++;
  }
  EXPECT_GE(left, 5);  // both sides of the path
  EXPECT_GE(right, 5);
}

// the shipped scene's rejections (the cube must stay clear of the whole path) must not bias the target's speed: the
// accepted episodes keep U(0.05, 0.25) m/s — mean 0.15, both quartiles near 0.10 and 0.20
TEST(ManipulatorEnvTest, PretrainPathOffsetKeepsTheTargetSpeedDistribution) {
  const TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  ASSERT_GT(c.scenario.pretrain.obstacle_path_offset[1], 0.0);
  ManipulatorEnv env(MakeTaskContext(c));
  Buffers b(env.spec());
  std::mt19937_64 rng(31);
  std::vector<double> speeds;
  for (int r = 0; r < 400; ++r) {
    env.Reset(rng, b.out());
    speeds.push_back(env.scenario().target().v_WT.norm());
  }
  std::sort(speeds.begin(), speeds.end());
  double mean = 0.0;
  for (double v : speeds) mean += v / speeds.size();
  std::printf("accepted target speeds: mean %.4f, quartiles %.4f %.4f %.4f\n", mean, speeds[100], speeds[200],
              speeds[300]);
  EXPECT_NEAR(mean, 0.15, 0.01);  // the standard error of 400 uniform draws is 0.0029
  EXPECT_NEAR(speeds[100], 0.10, 0.015);
  EXPECT_NEAR(speeds[300], 0.20, 0.015);
}

TEST(ManipulatorEnvTest, ReflectedDirectionIsTheDerivativeOfTheReflectedPath) {
  const Eigen::AlignedBox3d box(Eigen::Vector3d(0.2, -0.5, 0.0), Eigen::Vector3d(0.8, 0.5, 0.0));
  const Eigen::Vector3d p(0.3, 0.1, 0.0), v(0.21, -0.13, 0.0);
  int checked = 0;
  for (double t = 0.0; t < 20.0; t += 0.137) {
    const double e = 1e-6;
    const Eigen::Vector3d fd =
        (ReflectedPosition(p, v, t + e, box) - ReflectedPosition(p, v, t - e, box)) / (2.0 * e);
    if (std::abs(fd.norm() - v.norm()) > 1e-6) continue;  // a reflection inside the difference stencil
    EXPECT_LT((ReflectedDirection(p, v, t, box) - fd.normalized()).norm(), 1e-6) << "t " << t;
    ++checked;
  }
  EXPECT_GT(checked, 130);  // of 146 times, all but those within 1 µs of a reflection
  EXPECT_EQ(ReflectedDirection(p, Eigen::Vector3d::Zero(), 1.0, box), Eigen::Vector3d::Zero());
}

TEST(ManipulatorEnvTest, LineCrossingDrawsItsSpeedPerEpisode) {
  auto context = MakeTaskContext(SmallConfig(TaskKind::kLineCrossing, "panda", 1));
  EXPECT_EQ(context->num_scenario_settings(), 5);
  ManipulatorEnv env(context);
  Buffers b(env.spec());
  std::mt19937_64 rng(2);
  std::set<double> speeds;
  for (int r = 0; r < 25; ++r) {
    env.Reset(rng, b.out());
    const double v = env.scenario().obstacles()[0].speed;
    EXPECT_EQ(v, context->config().scenario.line_speeds[env.scenario_setting()]);
    speeds.insert(v);
  }
  EXPECT_EQ(speeds, (std::set<double>{0.2, 0.6, 1.2, 1.8, 2.8}));
}

// --------------------------------------------------------------------------------------------- determinism

TEST(ManipulatorEnvTest, SameSeedSameTrajectory) {
  for (TaskKind task : {TaskKind::kPretrain2Link, TaskKind::kReachAvoid}) {
    TaskConfig c = SmallConfig(task, "", 3);
    c.episode.max_steps = 60;
    auto context = MakeTaskContext(c);
    ManipulatorEnv a(context), b(context);
    const EnvSpec& s = a.spec();
    Buffers ba(s), bb(s);
    std::mt19937_64 ra(42), rb(42), actions_rng(7);
    a.Reset(ra, ba.out());
    b.Reset(rb, bb.out());
    std::vector<float> actions(s.num_agents * s.action.size());
    for (int step = 0; step < 200; ++step) {
      RandomActions(s, actions_rng, actions.data());
      a.Step(actions.data(), ra, ba.out());
      b.Step(actions.data(), rb, bb.out());
      ASSERT_EQ(ba.local_obs, bb.local_obs) << step;
      ASSERT_EQ(ba.global_state, bb.global_state) << step;
      ASSERT_EQ(ba.reward_terms, bb.reward_terms) << step;
      ASSERT_EQ(ba.terminated, bb.terminated);
      ASSERT_EQ(ba.truncated, bb.truncated);
      if (ba.terminated || ba.truncated) {
        a.Reset(ra, ba.out());
        b.Reset(rb, bb.out());
        ASSERT_EQ(ba.local_obs, bb.local_obs);
      }
    }
  }
}

TEST(ManipulatorEnvTest, VecEnvResultsDoNotDependOnTheThreadCount) {
  TaskConfig c = SmallConfig(TaskKind::kReachAvoid, "ur5e", 3);
  c.episode.max_steps = 40;
  auto context = MakeTaskContext(c);
  rl::VecEnv one(MakeManipulatorEnvFactory(context), {.num_envs = 4, .seed = 3, .num_threads = 1});
  rl::VecEnv two(MakeManipulatorEnvFactory(context), {.num_envs = 4, .seed = 3, .num_threads = 2});
  one.Reset();
  two.Reset();
  const EnvSpec& s = one.spec();
  std::vector<float> actions(4 * s.num_agents * s.action.size());
  std::mt19937_64 rng(8);
  for (int step = 0; step < 100; ++step) {
    for (int k = 0; k < 4; ++k) RandomActions(s, rng, actions.data() + k * s.num_agents * s.action.size());
    one.Step(actions.data());
    two.Step(actions.data());
    ASSERT_TRUE(one.batch().local_obs == two.batch().local_obs) << step;
    ASSERT_TRUE(one.batch().reward == two.batch().reward) << step;
  }
}

// --------------------------------------------------------------------------------------------- bad input


}  // namespace
}  // namespace rmpmarl::tasks
