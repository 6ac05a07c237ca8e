// ManipulatorEnv::Step allocates nothing: counted through a replaced global operator new (tests/support/alloc_counter.cc).
#include <gtest/gtest.h>

#include "../support/alloc_counter.h"
#include "rl_test_util.h"
#include "rmpmarl/rl/manipulator_env.h"

namespace rmpmarl::rl {
namespace {

TEST(NoAllocTest, EnvStepDoesNotAllocate) {
  struct Case {
    TaskKind task;
    InterfaceMode mode;
    const char* robot;
    rmp::LayerResolve resolve = rmp::LayerResolve::kPerJoint;
  };
  const Case cases[] = {{TaskKind::kPretrain2Link, InterfaceMode::kPerJointRmp, ""},
                        {TaskKind::kReachAvoid, InterfaceMode::kPerJointRmp, "panda"},
                        {TaskKind::kReachAvoid, InterfaceMode::kDirect, "ur5e"},
                        {TaskKind::kLineCrossing, InterfaceMode::kPerJointRmp, "panda"},
                        {TaskKind::kReachAvoid, InterfaceMode::kPerJointRmp, "panda", rmp::LayerResolve::kCoupled},
                        {TaskKind::kCluttered, InterfaceMode::kPerJointDirect, "panda"}};
  for (const Case& c : cases) {
    SCOPED_TRACE(TaskKindName(c.task));
    TaskConfig config = testing::SmallConfig(c.task, c.robot, 1);
    config.interface = c.mode;
    config.basic_layer.resolve = c.resolve;
    config.episode.max_steps = 100000;  // no episode end inside the counted window
    if (c.task == TaskKind::kReachAvoid) config.scenario.crossing.num_obstacles = 4;
    ManipulatorEnv env(MakeTaskContext(config));
    const EnvSpec& s = env.spec();
    testing::Buffers b(s);
    std::mt19937_64 rng(3), arng(4);
    env.Reset(rng, b.out());
    std::vector<float> actions(400 * static_cast<size_t>(s.num_agents) * s.action.size());
    for (int k = 0; k < 400; ++k) testing::RandomActions(s, arng, actions.data() + k * s.num_agents * s.action.size());
    for (int k = 0; k < 20; ++k) env.Step(actions.data() + k * s.num_agents * s.action.size(), rng, b.out());
    const long before = rmpmarl::testing::AllocationCount();
    for (int k = 20; k < 400; ++k) env.Step(actions.data() + k * s.num_agents * s.action.size(), rng, b.out());
    EXPECT_EQ(rmpmarl::testing::AllocationCount() - before, 0);
    EXPECT_FALSE(b.terminated);
  }
}

}  // namespace
}  // namespace rmpmarl::rl
