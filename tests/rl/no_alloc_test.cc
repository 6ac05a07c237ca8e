// ManipulatorEnv::Step allocates nothing: counted through a replaced global operator new (tests/support/alloc_counter.cc).
#include <gtest/gtest.h>

#include "../support/alloc_counter.h"
#include "rl_test_util.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/sim/controlled_world.h"
#include "rmpmarl/tasks/manipulator_env.h"

namespace rmpmarl::rl {
namespace {

TEST(NoAllocTest, EnvStepDoesNotAllocate) {
  struct Case {
    tasks::TaskKind task;
    tasks::InterfaceMode mode;
    const char* robot;
    rmp::LayerResolve resolve = rmp::LayerResolve::kPerJoint;
  };
  const Case cases[] = {{tasks::TaskKind::kPretrain2Link, tasks::InterfaceMode::kPerJointRmp, ""},
                        {tasks::TaskKind::kReachAvoid, tasks::InterfaceMode::kPerJointRmp, "panda"},
                        {tasks::TaskKind::kReachAvoid, tasks::InterfaceMode::kDirect, "ur5e"},
                        {tasks::TaskKind::kLineCrossing, tasks::InterfaceMode::kPerJointRmp, "panda"},
                        {tasks::TaskKind::kReachAvoid, tasks::InterfaceMode::kPerJointRmp, "panda", rmp::LayerResolve::kCoupled},
                        {tasks::TaskKind::kCluttered, tasks::InterfaceMode::kPerJointDirect, "panda"}};
  for (const Case& c : cases) {
    SCOPED_TRACE(tasks::TaskKindName(c.task));
    tasks::TaskConfig config = testing::SmallConfig(c.task, c.robot, 1);
    config.interface = c.mode;
    config.basic_layer.resolve = c.resolve;
    config.episode.max_steps = 100000;  // no episode end inside the counted window
    if (c.task == tasks::TaskKind::kReachAvoid) config.scenario.crossing.num_obstacles = 4;
    tasks::ManipulatorEnv env(tasks::MakeTaskContext(config));
    const tasks::EnvSpec& s = env.spec();
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

// the learned controller in a user's loop: a control step (warnings from the geometry, observations, the network, the
// coupled basic layer at every substep) allocates nothing either
TEST(NoAllocTest, LearnedControllerStepDoesNotAllocate) {
  const std::string path = (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string();
  const control::PolicyFile file = control::LoadPolicyFile(path);
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  std::unique_ptr<sim::Scenario> scenario = sim::MakeScenario("crossing", robot);
  auto world_model = std::make_shared<const sim::WorldModel>(robot, scenario->scene_spec());
  sim::World world(world_model);
  auto learned = control::MakeLearnedController(robot, file, path, scenario->num_obstacles());
  const control::ControllerOptions options = learned->controller_options();
  control::ReactiveController controller(world_model->servos(), std::move(learned), options);
  scenario->Reset(7, world);
  sim::ResetController(controller, world);
  rmp::Scene scene;
  scene.obstacles.reserve(scenario->num_obstacles());
  auto step = [&] {
    scenario->FillScene(&scene);
    sim::StepController(controller, world, scene);
    world.Step(controller.physics_steps_per_control());
    scenario->Advance(controller.control_period(), world.QueryContacts(), world);
  };
  for (int k = 0; k < 20; ++k) step();
  const long before = rmpmarl::testing::AllocationCount();
  for (int k = 0; k < 200; ++k) step();
  EXPECT_EQ(rmpmarl::testing::AllocationCount() - before, 0);
}

}  // namespace
}  // namespace rmpmarl::rl
