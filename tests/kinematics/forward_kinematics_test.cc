// Forward kinematics, point Jacobians and J̇q̇ against hand-derived values and central finite differences.
#include "rmpmarl/kinematics/forward_kinematics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rmpmarl/common/error.h"
#include "../support/alloc_counter.h"
#include "test_robots.h"

namespace rmpmarl::kinematics {
namespace {

using testing::AllTestRobots;
using testing::RandomConfiguration;
using testing::RandomVelocity;

constexpr int kConfigurationsPerRobot = 1000;

// the points the tests probe on a robot: every capsule end point and the end effector.
std::vector<std::pair<int, Eigen::Vector3d>> ProbePoints(const Robot& robot) {
  std::vector<std::pair<int, Eigen::Vector3d>> points;
  for (const LinkCapsule& c : robot.capsules) {
    points.emplace_back(c.link, c.p_LA);
    points.emplace_back(c.link, c.p_LB);
  }
  points.emplace_back(robot.end_effector.link, robot.end_effector.X_LE.translation());
  return points;
}

TEST(ForwardKinematicsTest, Planar2MatchesHandDerivedFormulas) {
  const double l1 = 0.37, l2 = 0.61;
  const Robot robot = MakePlanar2({.link1_length = l1, .link2_length = l2});
  Data data(robot.model);
  std::mt19937_64 rng(7);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
    const Eigen::VectorXd qd = testing::RandomVelocity(robot.model, rng);
    CalcVelocityKinematics(robot.model, q, qd, &data);
    const double c1 = std::cos(q[0]), s1 = std::sin(q[0]);
    const double c12 = std::cos(q[0] + q[1]), s12 = std::sin(q[0] + q[1]);
    // end effector: x = l1 c1 + l2 c12, y = l1 s1 + l2 s12
    const Eigen::Vector3d p_WE = CalcPointPosition(data, robot.end_effector.link, robot.end_effector.X_LE.translation());
    EXPECT_NEAR(p_WE.x(), l1 * c1 + l2 * c12, 1e-12);
    EXPECT_NEAR(p_WE.y(), l1 * s1 + l2 * s12, 1e-12);
    EXPECT_NEAR(p_WE.z(), 0.0, 1e-12);
    // J = [[-l1 s1 - l2 s12, -l2 s12], [l1 c1 + l2 c12, l2 c12], [0, 0]]
    Eigen::Matrix3Xd J(3, 2);
    CalcPointJacobian(robot.model, data, robot.end_effector.link, robot.end_effector.X_LE.translation(), J);
    Eigen::Matrix3Xd J_expected(3, 2);
    J_expected << -l1 * s1 - l2 * s12, -l2 * s12, l1 * c1 + l2 * c12, l2 * c12, 0, 0;
    EXPECT_LT((J - J_expected).cwiseAbs().maxCoeff(), 1e-12);
    // J̇q̇ = -[l1 c1 w1² + l2 c12 w12², l1 s1 w1² + l2 s12 w12², 0] with w12 = q̇1 + q̇2
    const double w1 = qd[0], w12 = qd[0] + qd[1];
    const Eigen::Vector3d jdqd = CalcPointJdotQdot(data, robot.end_effector.link, robot.end_effector.X_LE.translation());
    EXPECT_NEAR(jdqd.x(), -(l1 * c1 * w1 * w1 + l2 * c12 * w12 * w12), 1e-12);
    EXPECT_NEAR(jdqd.y(), -(l1 * s1 * w1 * w1 + l2 * s12 * w12 * w12), 1e-12);
    EXPECT_NEAR(jdqd.z(), 0.0, 1e-12);
  }
}

TEST(ForwardKinematicsTest, ZeroConfigurationComposesJointOrigins) {
  const Robot robot = testing::LoadTreeRobot();
  Data data(robot.model);
  CalcForwardKinematics(robot.model, Eigen::VectorXd::Zero(robot.model.nq()), &data);
  for (int k = 1; k < robot.model.num_links(); ++k) {
    const Link& link = robot.model.link(k);
    const Eigen::Isometry3d expected = data.X_WL[link.parent] * link.X_PJ;
    EXPECT_LT((data.X_WL[k].matrix() - expected.matrix()).cwiseAbs().maxCoeff(), 1e-15) << link.name;
  }
}

TEST(ForwardKinematicsTest, JacobiansMatchCentralFiniteDifferences) {
  const double h = 1e-6;
  for (const Robot& robot : AllTestRobots()) {
    const Model& model = robot.model;
    Data data(model), data_plus(model), data_minus(model);
    Eigen::Matrix3Xd J(3, model.nq());
    std::mt19937_64 rng(1234);
    double max_error = 0.0;
    const auto points = ProbePoints(robot);
    for (int trial = 0; trial < kConfigurationsPerRobot; ++trial) {
      const Eigen::VectorXd q = RandomConfiguration(model, rng);
      CalcForwardKinematics(model, q, &data);
      for (const auto& [link, p_LP] : points) {
        CalcPointJacobian(model, data, link, p_LP, J);
        for (int i = 0; i < model.nq(); ++i) {
          Eigen::VectorXd qp = q, qm = q;
          qp[i] += h;
          qm[i] -= h;
          CalcForwardKinematics(model, qp, &data_plus);
          CalcForwardKinematics(model, qm, &data_minus);
          const Eigen::Vector3d fd =
              (CalcPointPosition(data_plus, link, p_LP) - CalcPointPosition(data_minus, link, p_LP)) / (2 * h);
          max_error = std::max(max_error, (J.col(i) - fd).cwiseAbs().maxCoeff());
        }
      }
    }
    EXPECT_LT(max_error, 1e-8) << robot.name;
    RecordProperty(robot.name + "_jacobian_max_abs_error", std::to_string(max_error));
  }
}

TEST(ForwardKinematicsTest, JdotQdotMatchesFiniteDifferenceOfJacobianAlongMotion) {
  // J̇q̇ = d/dt (J(q(t)) q̇) at q̈ = 0 ≈ (J(q + h q̇) − J(q − h q̇)) q̇ / (2h); also ṗ = J q̇.
  const double h = 1e-6;
  for (const Robot& robot : AllTestRobots()) {
    const Model& model = robot.model;
    Data data(model), data_plus(model), data_minus(model);
    Eigen::Matrix3Xd J(3, model.nq()), J_plus(3, model.nq()), J_minus(3, model.nq());
    std::mt19937_64 rng(99);
    double max_error = 0.0, max_velocity_error = 0.0;
    const auto points = ProbePoints(robot);
    for (int trial = 0; trial < kConfigurationsPerRobot; ++trial) {
      const Eigen::VectorXd q = RandomConfiguration(model, rng);
      const Eigen::VectorXd qd = RandomVelocity(model, rng);
      CalcVelocityKinematics(model, q, qd, &data);
      CalcForwardKinematics(model, q + h * qd, &data_plus);
      CalcForwardKinematics(model, q - h * qd, &data_minus);
      for (const auto& [link, p_LP] : points) {
        CalcPointJacobian(model, data, link, p_LP, J);
        CalcPointJacobian(model, data_plus, link, p_LP, J_plus);
        CalcPointJacobian(model, data_minus, link, p_LP, J_minus);
        const Eigen::Vector3d fd = (J_plus - J_minus) * qd / (2 * h);
        const Eigen::Vector3d jdqd = CalcPointJdotQdot(data, link, p_LP);
        max_error = std::max(max_error, (jdqd - fd).cwiseAbs().maxCoeff());
        max_velocity_error =
            std::max(max_velocity_error, (CalcPointVelocity(data, link, p_LP) - J * qd).cwiseAbs().maxCoeff());
      }
    }
    EXPECT_LT(max_error, 1e-6) << robot.name;
    EXPECT_LT(max_velocity_error, 1e-12) << robot.name;
  }
}

TEST(ForwardKinematicsTest, JacobianColumnsVanishForDofsThatDoNotMoveTheLink) {
  const Robot robot = testing::LoadTreeRobot();
  Data data(robot.model);
  std::mt19937_64 rng(5);
  CalcForwardKinematics(robot.model, RandomConfiguration(robot.model, rng), &data);
  Eigen::Matrix3Xd J(3, robot.model.nq());
  const int arm_b2 = robot.model.LinkIndex("arm_b2");
  CalcPointJacobian(robot.model, data, arm_b2, Eigen::Vector3d(0.1, 0.0, 0.0), J);
  for (int i = 0; i < robot.model.nq(); ++i) {
    const bool moves = robot.model.DofMovesLink(i, arm_b2);
    EXPECT_EQ(moves, J.col(i).norm() > 0.0) << robot.model.dof_name(i);
  }
  // arm_b2 hangs from j0_torso, j1_slider, j5_b1, j6_b2 only
  EXPECT_EQ(robot.model.link_dofs(arm_b2).size(), 4u);
}

TEST(ForwardKinematicsTest, AlgorithmsAllocateNothingAfterDataIsMade) {
  for (const Robot& robot : AllTestRobots()) {
    const Model& model = robot.model;
    Data data(model);
    Eigen::Matrix3Xd J(3, model.nq());
    std::mt19937_64 rng(3);
    const Eigen::VectorXd q = RandomConfiguration(model, rng);
    const Eigen::VectorXd qd = RandomVelocity(model, rng);
    Eigen::Vector3d sink = Eigen::Vector3d::Zero();
    const long before = rmpmarl::testing::AllocationCount();
    CalcForwardKinematics(model, q, &data);
    CalcVelocityKinematics(model, q, qd, &data);
    for (const LinkCapsule& c : robot.capsules) {
      CalcPointJacobian(model, data, c.link, c.p_LA, J);
      sink += CalcPointJdotQdot(data, c.link, c.p_LB) + CalcPointVelocity(data, c.link, c.p_LA);
    }
    EXPECT_EQ(rmpmarl::testing::AllocationCount() - before, 0) << robot.name;
    EXPECT_TRUE(sink.allFinite());
  }
}

TEST(ForwardKinematicsTest, CheckJointVectorRejectsWrongSizeAndNonFinite) {
  const Robot robot = MakePlanar2();
  EXPECT_NO_THROW(CheckJointVector(robot.model, Eigen::VectorXd::Zero(2), "q"));
  try {
    CheckJointVector(robot.model, Eigen::VectorXd::Zero(3), "q");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("expected 2 values (one per joint), got 3"), std::string::npos) << e.what();
  }
  Eigen::VectorXd q = Eigen::VectorXd::Zero(2);
  q[1] = std::nan("");
  try {
    CheckJointVector(robot.model, q, "qd");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("entry 1 (joint 'joint2') must be finite"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rmpmarl::kinematics
