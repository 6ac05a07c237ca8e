// Step() and QueryContacts() allocate nothing: counted through a replaced global operator new (this binary only).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "alloc_counter.h"
#include "rmpmarl/sim/world.h"
#include "sim_test_util.h"

namespace {
std::atomic<long> g_allocations{0};
}  // namespace

void* operator new(std::size_t size) {
  g_allocations.fetch_add(1, std::memory_order_relaxed);
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void operator delete(void* p) noexcept { std::free(p); }
void operator delete[](void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete[](void* p, std::size_t) noexcept { std::free(p); }

long rmpmarl::sim::testing::AllocationCount() { return g_allocations.load(); }

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
  const long before = g_allocations.load();
  for (int s = 0; s < 500; ++s) {
    world.SetObstaclePose(s % 4, p_WO, R_WO);
    world.Step();
    contacts += static_cast<long>(world.QueryContacts().warnings.size());
  }
  const long after = g_allocations.load();
  EXPECT_EQ(after - before, 0);
  EXPECT_GT(contacts, 0);  // the query did real work
}

}  // namespace
}  // namespace rmpmarl::sim
