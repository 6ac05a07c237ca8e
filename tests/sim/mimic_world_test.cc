// URDF <mimic> joints in MuJoCo: the follower joints are held to their leaders by joint equalities, have
// no servo, start on the constraint, and MuJoCo's own body positions match rmpmarl's kinematics while the servos
// move the independent joints.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <mujoco/mujoco.h>

#include <random>
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

TEST(MimicWorldTest, InverseDynamicsFeedForwardTracksAnAcceleratingCommandWithMimicJoints) {
  // a 1 Hz sway of the arm's three revolute dofs (q_d = q0 + A (1 − cos ω t), targets q_d + (d/kp) q̇_d with q̈_d at
  // every physics step; the gripper held): the feed-forward tracks it closer than the PD alone on every dof, j3 with
  // its mimic follower j4 included (whose torque and joint damping its servo supplies through the joint equality);
  // the dof map is not the identity here (followers sit between the leaders' dofs)
  const kinematics::Robot robot = MimicArm();
  Eigen::Vector3d max_error[2];
  for (int on = 0; on < 2; ++on) {
    WorldOptions options;
    options.warning_margin = 0.0;
    options.servo.inverse_dynamics_feedforward = on == 1;
    const auto model = std::make_shared<const WorldModel>(robot, SceneSpec{}, options);
    World world(model);
    const int n = model->nq();
    ASSERT_EQ(n, 4);
    Eigen::VectorXd q0(n), amplitude = Eigen::VectorXd::Zero(n);
    for (int i = 0; i < n; ++i) {
      const double lo = model->lower_limits()[i], hi = model->upper_limits()[i];
      q0[i] = lo + 0.3 * (hi - lo);
      if (i < 3) amplitude[i] = 0.15 * (hi - lo);
    }
    const Eigen::VectorXd ff = model->servos().feedforward;
    const double w = 2.0 * M_PI;
    world.Reset(q0);
    max_error[on].setZero();
    const int steps = static_cast<int>(std::lround(1.0 / model->options().timestep));
    for (int s = 0; s < steps; ++s) {
      const double t = world.time();
      const Eigen::VectorXd q_d = q0 + amplitude * (1.0 - std::cos(w * t));
      const Eigen::VectorXd qd_d = amplitude * (w * std::sin(w * t));
      const Eigen::VectorXd qdd_d = amplitude * (w * w * std::cos(w * t));
      world.SetJointTargets(q_d + ff.cwiseProduct(qd_d), qdd_d);
      ASSERT_TRUE(world.Step().ok);
      const Eigen::VectorXd q_next = q0 + amplitude * (1.0 - std::cos(w * world.time()));
      const Eigen::Vector3d e = ((world.q() - q_next).head<3>().array() / amplitude.head<3>().array()).abs();
      max_error[on] = max_error[on].cwiseMax(e);
    }
  }
  fmt::print("  mimic arm, 1 Hz sway: max |q − q_d| / amplitude of j1, j2, j3: {:.4f} {:.4f} {:.4f} with the PD alone, "
             "{:.4f} {:.4f} {:.4f} with the feed-forward\n", max_error[0][0], max_error[0][1], max_error[0][2],
             max_error[1][0], max_error[1][1], max_error[1][2]);
  EXPECT_LT(max_error[1][0], 0.2 * max_error[0][0]);
  EXPECT_LT(max_error[1][1], 0.2 * max_error[0][1]);
  EXPECT_LT(max_error[1][2], 0.2 * max_error[0][2]);
}

}  // namespace
}  // namespace rmpmarl::sim
