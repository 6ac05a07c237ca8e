// Step() and QueryContacts() allocate nothing: counted through a replaced global operator new (tests/support/alloc_counter.cc).
#include <gtest/gtest.h>

#include "../support/alloc_counter.h"
#include "rmpmarl/sim/world.h"
#include "sim_test_util.h"

namespace rmpmarl::sim {
namespace {

TEST(NoAllocTest, StepAndContactQueryDoNotAllocate) {
  const kinematics::Robot robot = testing::LoadTreeRobot();
  SceneSpec scene;
  for (int j = 0; j < 4; ++j) scene.obstacles.push_back(ObstacleSpec::Cube(0.1));
  auto wm = std::make_shared<const WorldModel>(robot, scene);
  World world(wm);
  std::mt19937_64 rng(1);
  const Eigen::VectorXd q_cmd = testing::RandomConfiguration(robot.model, rng);
  const Eigen::Vector3d p_WO(0.1, 0.0, 0.5);
  const Eigen::Matrix3d R_WO = testing::RandomRotation(rng);
  world.SetJointTargets(q_cmd);
  long contacts = 0;
  const long before = rmpmarl::testing::AllocationCount();
  for (int s = 0; s < 500; ++s) {
    world.SetObstaclePose(s % 4, p_WO, R_WO);
    world.Step();
    contacts += static_cast<long>(world.QueryContacts().warnings.size());
  }
  const long after = rmpmarl::testing::AllocationCount();
  EXPECT_EQ(after - before, 0);
  EXPECT_GT(contacts, 0);  // the query did real work
}

}  // namespace
}  // namespace rmpmarl::sim
