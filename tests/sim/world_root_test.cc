// A URDF whose root link carries a name MuJoCo reserves ("world", as xarm_ros and many Gazebo files have) builds its
// MuJoCo world: the link's body is renamed, and the kinematics still match MuJoCo's.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/mjcf.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::sim {
namespace {

constexpr const char* kWorldRootedUrdf = R"(<?xml version="1.0"?>
<robot name="world_rooted">
  <link name="world"/>
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="fix" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 0.05"/></joint>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>)";

TEST(WorldRootTest, AUrdfRootedAtWorldBuildsItsMujocoWorld) {
  kinematics::Robot robot;
  robot.model = kinematics::ParseUrdfModel(kWorldRootedUrdf, "world_rooted.urdf");
  robot.name = robot.model.name();
  robot.capsules = {{2, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.3, 0, 0), 0.04},
                    {3, Eigen::Vector3d::Zero(), Eigen::Vector3d(0.2, 0, 0), 0.03}};
  robot.end_effector.link = 3;
  robot.excluded_pairs = {{0, 1}, {1, 2}, {2, 3}};
  ASSERT_EQ(robot.model.link(0).name, "world");
  EXPECT_EQ(MjcfNames::LinkBody(robot, 0), "link/world");
  EXPECT_EQ(MjcfNames::LinkBody(robot, 2), "l1");
  const WorldModel world(robot);
  const mjModel* m = world.mj_model();
  EXPECT_EQ(mj_name2id(m, mjOBJ_BODY, "link/world"), world.link_body(0));
  World sim(std::make_shared<const WorldModel>(robot));
  Eigen::VectorXd q(2);
  q << 0.4, -0.3;
  sim.Reset(q);
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  for (int k = 0; k < robot.model.num_links(); ++k) {
    const mjtNum* xpos = sim.mj_data()->xpos + 3 * world.link_body(k);
    EXPECT_LT((data.X_WL[k].translation() - Eigen::Vector3d(xpos[0], xpos[1], xpos[2])).norm(), 1e-9)
        << robot.model.link(k).name;
  }
}

}  // namespace
}  // namespace rmpmarl::sim
