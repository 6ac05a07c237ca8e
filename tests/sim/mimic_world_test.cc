// URDF <mimic> joints in MuJoCo: the follower joints are held to their leaders by joint equalities, have
// no servo, start on the constraint, and MuJoCo's own body positions match rmpmarl's kinematics while the servos
// move the independent joints.
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <string>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::sim {
namespace {

kinematics::Robot MimicArm() {
  kinematics::Robot robot;
  robot.model = kinematics::LoadUrdfModel(std::string(RMPMARL_TEST_DATA_DIR) + "/robots/mimic/mimic_arm.urdf");
  robot.name = robot.model.name();
  const kinematics::Model& m = robot.model;
  robot.capsules = {{m.LinkIndex("link2"), Eigen::Vector3d::Zero(), Eigen::Vector3d(0.3, 0, 0), 0.045},
                    {m.LinkIndex("link3"), Eigen::Vector3d::Zero(), Eigen::Vector3d(0.25, 0, 0), 0.04},
                    {m.LinkIndex("finger_left"), Eigen::Vector3d::Zero(), Eigen::Vector3d(0.06, 0, 0), 0.01},
                    {m.LinkIndex("finger_right"), Eigen::Vector3d::Zero(), Eigen::Vector3d(0.06, 0, 0), 0.01}};
  robot.end_effector.link = m.LinkIndex("tcp");
  for (int k = 1; k < m.num_links(); ++k) robot.excluded_pairs.emplace_back(m.link(k).parent, k);
  robot.excluded_pairs.emplace_back(m.LinkIndex("finger_left"), m.LinkIndex("finger_right"));
  return robot;
}

TEST(MimicWorldTest, FollowersTrackTheirLeadersAndMujocoMatchesTheKinematics) {
  const kinematics::Robot robot = MimicArm();
  const auto model = std::make_shared<const WorldModel>(robot);
  const mjModel* m = model->mj_model();
  EXPECT_EQ(m->nu, 4);   // servos on the independent dofs only
  EXPECT_EQ(m->njnt, 7); // and 3 followers
  // one joint equality per follower, joint1 = polycoef(joint2) = offset + multiplier · leader
  ASSERT_EQ(m->neq, 3);
  auto expect_equality = [&](int e, const char* follower, const char* leader, double offset, double multiplier) {
    EXPECT_EQ(m->eq_type[e], mjEQ_JOINT);
    EXPECT_EQ(m->eq_obj1id[e], mj_name2id(m, mjOBJ_JOINT, follower));
    EXPECT_EQ(m->eq_obj2id[e], mj_name2id(m, mjOBJ_JOINT, leader));
    EXPECT_DOUBLE_EQ(m->eq_data[mjNEQDATA * e], offset);
    EXPECT_DOUBLE_EQ(m->eq_data[mjNEQDATA * e + 1], multiplier);
  };
  expect_equality(0, "j4", "j3", 0.2, -0.5);
  expect_equality(1, "finger_joint_right", "finger_joint_left", 0.0, 1.0);
  expect_equality(2, "finger_tip_joint", "finger_joint_left", -0.1, 10.0);
  ASSERT_EQ(model->mimic_joints().size(), 3u);

  World sim(model);
  Eigen::VectorXd q0(4);
  q0 << 0.3, -0.4, -0.8, 0.01;
  sim.Reset(q0);
  kinematics::Data data(robot.model);
  auto expect_match = [&](const Eigen::VectorXd& q, double tolerance, const char* when) {
    kinematics::CalcForwardKinematics(robot.model, q, &data);
    for (int k = 0; k < robot.model.num_links(); ++k) {
      const mjtNum* xpos = sim.mj_data()->xpos + 3 * model->link_body(k);
      EXPECT_LT((data.X_WL[k].translation() - Eigen::Vector3d(xpos[0], xpos[1], xpos[2])).norm(), tolerance)
          << when << ": " << robot.model.link(k).name;
    }
    for (const WorldModel::MimicJoint& mimic : model->mimic_joints()) {
      EXPECT_NEAR(sim.mj_data()->qpos[mimic.qpos_adr], mimic.multiplier * q[mimic.dof] + mimic.offset,
                  tolerance * 10.0) << when;
    }
  };
  expect_match(sim.q(), 1e-12, "after Reset");  // starts exactly on the constraint

  // the servos move every independent joint, the gripper included; the equality constraints carry the followers
  Eigen::VectorXd target(4);
  target << -0.2, 0.3, -1.5, 0.035;
  sim.SetJointTargets(target);
  sim.Step(1500);
  EXPECT_LT((sim.q() - target).cwiseAbs().maxCoeff(), 0.02) << sim.q().transpose();
  expect_match(sim.q(), 2e-3, "after 1500 steps");  // MuJoCo's equalities are soft: millimetres
}

}  // namespace
}  // namespace rmpmarl::sim
