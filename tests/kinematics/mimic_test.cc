// URDF <mimic> joints: a follower's value is multiplier · leader + offset; q holds the independent dofs
// only; forward kinematics against hand-derived formulas, Jacobians and J̇q̇ against central finite differences of
// that forward kinematics, and the parser's refusals.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "test_robots.h"

namespace rmpmarl::kinematics {
namespace {

Model LoadMimicArm() {
  return LoadUrdfModel(std::string(RMPMARL_TEST_DATA_DIR) + "/robots/mimic/mimic_arm.urdf");
}

TEST(MimicTest, FollowersHaveNoCoordinateAndPointAtTheirIndependentLeader) {
  const Model model = LoadMimicArm();
  ASSERT_EQ(model.nq(), 4);  // j1, j2, j3, finger_joint_left
  EXPECT_EQ(model.dof_name(0), "j1");
  EXPECT_EQ(model.dof_name(2), "j3");
  EXPECT_EQ(model.dof_name(3), "finger_joint_left");
  EXPECT_TRUE(model.has_mimic_joints());
  const Link& j4 = model.link(model.LinkIndex("link4"));
  EXPECT_EQ(j4.q_index, -1);
  EXPECT_EQ(j4.mimic_dof, 2);
  EXPECT_DOUBLE_EQ(j4.mimic_multiplier, -0.5);
  EXPECT_DOUBLE_EQ(j4.mimic_offset, 0.2);
  const Link& right = model.link(model.LinkIndex("finger_right"));
  EXPECT_EQ(right.mimic_dof, 3);
  EXPECT_DOUBLE_EQ(right.mimic_multiplier, 1.0);  // urdfdom's default
  EXPECT_DOUBLE_EQ(right.mimic_offset, 0.0);
  // a mimic of a mimic composes: 10 (1 q + 0) - 0.1
  const Link& tip = model.link(model.LinkIndex("finger_tip"));
  EXPECT_EQ(tip.mimic_dof, 3);
  EXPECT_DOUBLE_EQ(tip.mimic_multiplier, 10.0);
  EXPECT_DOUBLE_EQ(tip.mimic_offset, -0.1);
  // dof j3 drives link3 (its own joint) and link4 (its follower); both move the hand
  EXPECT_EQ(model.dof_joint_links(2), (std::vector<int>{model.LinkIndex("link3"), model.LinkIndex("link4")}));
  EXPECT_TRUE(model.DofMovesLink(3, model.LinkIndex("finger_right")));
  EXPECT_TRUE(model.DofMovesLink(3, model.LinkIndex("finger_tip")));
  EXPECT_FALSE(model.DofMovesLink(3, model.LinkIndex("tcp")));
}

TEST(MimicTest, ForwardKinematicsMatchesHandDerivedFormulas) {
  const Model model = LoadMimicArm();
  Data data(model);
  const int tcp = model.LinkIndex("tcp"), left = model.LinkIndex("finger_left"),
            right = model.LinkIndex("finger_right"), tip = model.LinkIndex("finger_tip");
  std::mt19937_64 rng(3);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::VectorXd q = testing::RandomConfiguration(model, rng);
    CalcForwardKinematics(model, q, &data);
    // in the arm's vertical plane (turned by q1 about z): R_y(a) (x, 0, 0) = (x cos a, 0, -x sin a);
    // link2 at height 0.4, then 0.3 along q2, 0.25 along q2 + q3, 0.12 + 0.1 along q2 + q3 + q4, q4 = -0.5 q3 + 0.2
    const double q4 = -0.5 * q[2] + 0.2;
    const double a2 = q[1], a3 = q[1] + q[2], a4 = q[1] + q[2] + q4;
    const double r = 0.3 * std::cos(a2) + 0.25 * std::cos(a3) + 0.22 * std::cos(a4);
    const double z = 0.4 - 0.3 * std::sin(a2) - 0.25 * std::sin(a3) - 0.22 * std::sin(a4);
    const Eigen::Vector3d expected(r * std::cos(q[0]), r * std::sin(q[0]), z);
    EXPECT_LT((data.X_WL[tcp].translation() - expected).norm(), 1e-12) << "trial " << trial;
    // the parallel gripper: finger origins 0.02 + 2 q_f apart, symmetric about the hand
    EXPECT_NEAR((data.X_WL[left].translation() - data.X_WL[right].translation()).norm(), 0.02 + 2.0 * q[3], 1e-12);
    // the tip turns by 10 q_f - 0.1 about the right finger's z axis
    const Eigen::Matrix3d R_rel = data.X_WL[right].linear().transpose() * data.X_WL[tip].linear();
    const Eigen::Matrix3d R_expected = Eigen::AngleAxisd(10.0 * q[3] - 0.1, Eigen::Vector3d::UnitZ()).matrix();
    EXPECT_LT((R_rel - R_expected).cwiseAbs().maxCoeff(), 1e-12);
    EXPECT_DOUBLE_EQ(model.JointValue(tip, q), 10.0 * q[3] - 0.1);
  }
}

TEST(MimicTest, JacobiansAndVelocityProductsMatchFiniteDifferences) {
  const Model model = LoadMimicArm();
  Data data(model), plus(model), minus(model);
  std::mt19937_64 rng(11);
  const double h = 1e-6;
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::VectorXd q = testing::RandomConfiguration(model, rng);
    const Eigen::VectorXd qd = testing::RandomVelocity(model, rng);
    CalcVelocityKinematics(model, q, qd, &data);
    for (int k = 1; k < model.num_links(); ++k) {
      const Eigen::Vector3d p_LP(std::uniform_real_distribution<double>(-0.1, 0.1)(rng), 0.03, -0.02);
      Eigen::Matrix3Xd J(3, model.nq());
      CalcPointJacobian(model, data, k, p_LP, J);
      for (int i = 0; i < model.nq(); ++i) {
        Eigen::VectorXd qp = q, qm = q;
        qp[i] += h;
        qm[i] -= h;
        CalcForwardKinematics(model, qp, &plus);
        CalcForwardKinematics(model, qm, &minus);
        const Eigen::Vector3d column = (plus.X_WL[k] * p_LP - minus.X_WL[k] * p_LP) / (2.0 * h);
        EXPECT_LT((J.col(i) - column).norm(), 1e-7) << model.link(k).name << " dof " << i;
        // the per-column function the basic layer uses, at the world point
        EXPECT_LT((CalcPointJacobianColumn(model, data, i, k, data.X_WL[k] * p_LP) - column).norm(), 1e-7);
      }
      // velocity = J q̇, and J̇q̇ = d/dt (J q̇) at fixed q̇ along q + t q̇
      EXPECT_LT((CalcPointVelocity(data, k, p_LP) - J * qd).norm(), 1e-12) << model.link(k).name;
      Data ahead(model), behind(model);
      Eigen::Matrix3Xd Jp(3, model.nq()), Jm(3, model.nq());
      CalcForwardKinematics(model, q + h * qd, &ahead);
      CalcForwardKinematics(model, q - h * qd, &behind);
      CalcPointJacobian(model, ahead, k, p_LP, Jp);
      CalcPointJacobian(model, behind, k, p_LP, Jm);
      const Eigen::Vector3d jdqd = (Jp - Jm) * qd / (2.0 * h);
      EXPECT_LT((CalcPointJdotQdot(data, k, p_LP) - jdqd).norm(), 1e-6) << model.link(k).name;
    }
  }
}

// a two-joint URDF whose second joint carries the given <mimic> element (and type).
std::string UrdfWithMimic(const std::string& mimic, const std::string& type = "revolute") {
  return R"(<robot name="m"><link name="a"/><link name="b"/><link name="c"/>
  <joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="j2" type=")" + type + R"("><parent link="b"/><child link="c"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/>)" + mimic + R"(</joint></robot>)";
}

void ExpectInputError(const std::string& urdf, const std::string& fragment) {
  try {
    ParseUrdfModel(urdf, "m.urdf");
    ADD_FAILURE() << "expected InputError containing: " << fragment;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

TEST(MimicTest, BadMimicReferencesAreRefusedNamingTheJoint) {
  ExpectInputError(UrdfWithMimic(R"(<mimic joint="nope"/>)"), "joint 'j2': <mimic joint=\"nope\">: no joint of that name");
  ExpectInputError(UrdfWithMimic(R"(<mimic joint="j2"/>)"), "follow each other in a cycle");
  // a mimic on a fixed joint sets nothing: the joint stays fixed (as ROS and MoveIt read it)
  const Model fixed = ParseUrdfModel(UrdfWithMimic(R"(<mimic joint="j1"/>)", "fixed"), "m.urdf");
  EXPECT_EQ(fixed.nq(), 1);
  EXPECT_EQ(fixed.links()[2].joint_type, JointType::kFixed);
  const Model ok = ParseUrdfModel(UrdfWithMimic(R"(<mimic joint="j1" multiplier="2" offset="0.5"/>)"), "m.urdf");
  EXPECT_EQ(ok.nq(), 1);
  Eigen::VectorXd q(1);
  q << 0.25;
  EXPECT_DOUBLE_EQ(ok.JointValue(2, q), 1.0);
}

}  // namespace
}  // namespace rmpmarl::kinematics
