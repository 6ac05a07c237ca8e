// C-space RMPs of the RMPflow baseline against hand-computed values.
#include "rmpmarl/rmp/joint_rmps.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {
namespace {

TEST(JointRmpsTest, RobustCapIsIdentityInsideAndCapsOutside) {
  Eigen::VectorXd out(2);
  RobustCap(Eigen::Vector2d(0.3, 0.0), 0.5, out);
  EXPECT_EQ(out, Eigen::Vector2d(0.3, 0.0));
  RobustCap(Eigen::Vector2d(3.0, 4.0), 0.5, out);
  EXPECT_NEAR(out[0], 0.3, 1e-15);
  EXPECT_NEAR(out[1], 0.4, 1e-15);
}

TEST(JointRmpsTest, CSpaceTargetIsCappedDampedAttractor) {
  const CSpaceTargetRmpParams p;  // μ 50, k_p 100, k_d 50, θ 0.5, m 1
  Eigen::VectorXd f(2);
  // q₀ − q = (0.1, −0.2) inside the cap: f = 50 (100 (0.1, −0.2) − 50 (1, 0))
  const double s = EvalCSpaceTargetRmp(p, Eigen::Vector2d(0.0, 0.2), Eigen::Vector2d(1.0, 0.0),
                                       Eigen::Vector2d(0.1, 0.0), f);
  EXPECT_DOUBLE_EQ(s, 51.0);
  EXPECT_NEAR(f[0], 50.0 * (10.0 - 50.0), 1e-10);
  EXPECT_NEAR(f[1], 50.0 * (-20.0), 1e-10);
  // q₀ − q = (3, 4) beyond the cap: position term 100 · 0.5 · (0.6, 0.8)
  EvalCSpaceTargetRmp(p, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), Eigen::Vector2d(3.0, 4.0), f);
  EXPECT_NEAR(f[0], 50.0 * 30.0, 1e-10);
  EXPECT_NEAR(f[1], 50.0 * 40.0, 1e-10);
}

TEST(JointRmpsTest, AMovingCSpaceTargetDampsTheRelativeVelocity) {
  const CSpaceTargetRmpParams p;  // μ 50, k_p 100, k_d 50
  Eigen::VectorXd f(2);
  // q₀ − q = (0.1, −0.2), q̇ − q̇₀ = (1, 0) − (0.4, −0.5): f = 50 (100 (0.1, −0.2) − 50 (0.6, 0.5))
  const double s = EvalCSpaceTargetRmp(p, Eigen::Vector2d(0.0, 0.2), Eigen::Vector2d(1.0, 0.0),
                                       Eigen::Vector2d(0.1, 0.0), Eigen::Vector2d(0.4, -0.5), f);
  EXPECT_DOUBLE_EQ(s, 51.0);
  EXPECT_NEAR(f[0], 50.0 * (10.0 - 30.0), 1e-10);
  EXPECT_NEAR(f[1], 50.0 * (-20.0 - 25.0), 1e-10);
  // tracking: at the target and moving with it, no force
  EvalCSpaceTargetRmp(p, Eigen::Vector2d(0.3, 0.2), Eigen::Vector2d(0.4, -0.5), Eigen::Vector2d(0.3, 0.2),
                      Eigen::Vector2d(0.4, -0.5), f);
  EXPECT_NEAR(f.norm(), 0.0, 1e-12);
}

TEST(JointRmpsTest, JointLimitBarrierMatchesLulaForm) {
  const JointLimitRmpParams p;
  // x = 0.05, ẋ = −0.01: a = 1/(0.25 + 0.01) + 200·0.01, m = 1000/(1 + e⁻¹)/(5 + 0.001)
  const Rmp1 rmp = EvalJointLimitRmp(p, 0.05, -0.01);
  EXPECT_NEAR(rmp.a, 1.0 / 0.26 + 2.0, 1e-12);
  EXPECT_NEAR(rmp.m, 1000.0 / (1.0 + std::exp(-1.0)) / 5.001, 1e-10);
  // past the boundary: clamped to the boundary values, finite
  const Rmp1 at = EvalJointLimitRmp(p, 0.0, -0.5);
  const Rmp1 past = EvalJointLimitRmp(p, -0.2, -0.5);
  EXPECT_EQ(at.a, past.a);
  EXPECT_EQ(at.m, past.m);
  EXPECT_TRUE(std::isfinite(past.m) && std::isfinite(past.a));
  EXPECT_NEAR(at.a, 1.0 / 0.01 + 100.0, 1e-9);
}

TEST(JointRmpsTest, VelocityCapActsOnlyInTheDampingRegion) {
  const JointVelocityCapRmpParams p;  // v_max 1, v_r 0.3, k_d 1000, μ 100
  Rmp1 rmp = EvalJointVelocityCapRmp(p, 1.0, 0.5);
  EXPECT_EQ(rmp.m, 0.0);
  EXPECT_EQ(rmp.a, 0.0);
  // |q̇| = 0.85: excess 0.15, a = −1000 · 0.15, m = 100/(1 − 0.25)
  rmp = EvalJointVelocityCapRmp(p, 1.0, -0.85);
  EXPECT_NEAR(rmp.a, 150.0, 1e-9);
  EXPECT_NEAR(rmp.m, 100.0 / 0.75, 1e-9);
  // beyond v_max the metric is clipped, finite
  rmp = EvalJointVelocityCapRmp(p, 1.0, 5.0);
  EXPECT_NEAR(rmp.m, 100.0 / (1.0 - 0.99 * 0.99), 1e-9);
  EXPECT_NEAR(rmp.a, -1000.0 * 4.3, 1e-9);
  // a cap below the damping region shrinks the region to the cap
  rmp = EvalJointVelocityCapRmp(p, 0.2, 0.1);
  EXPECT_NEAR(rmp.a, -100.0, 1e-9);
}

TEST(JointRmpsTest, MetricsAreNonNegativeAndFiniteEverywhere) {
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> x(-2.0, 2.0), v(-20.0, 20.0);
  const JointLimitRmpParams limit;
  const JointVelocityCapRmpParams cap;
  for (int trial = 0; trial < 5000; ++trial) {
    const double xs = trial % 5 == 0 ? 0.0 : x(rng);
    const Rmp1 l = EvalJointLimitRmp(limit, xs, v(rng));
    ASSERT_TRUE(std::isfinite(l.a) && std::isfinite(l.m));
    EXPECT_GE(l.m, 0.0);
    const Rmp1 c = EvalJointVelocityCapRmp(cap, 0.5 + std::abs(x(rng)), v(rng));
    ASSERT_TRUE(std::isfinite(c.a) && std::isfinite(c.m));
    EXPECT_GE(c.m, 0.0);
  }
}

TEST(JointRmpsTest, ValidationRejectsBadValues) {
  EXPECT_NO_THROW(ValidateCSpaceTargetRmpParams({}, "x"));
  EXPECT_NO_THROW(ValidateJointLimitRmpParams({}, "x"));
  EXPECT_NO_THROW(ValidateJointVelocityCapRmpParams({}, "x"));
  EXPECT_NO_THROW(ValidateCSpaceDampingRmpParams({}, "x"));
  EXPECT_THROW(ValidateCSpaceTargetRmpParams({.position_gain = -1.0}, "x"), InputError);
  EXPECT_THROW(ValidateJointLimitRmpParams({.metric_length_scale = 0.0}, "x"), InputError);
  EXPECT_THROW(ValidateJointVelocityCapRmpParams({.max_velocity = 1.0, .velocity_damping_region = 2.0}, "x"),
               InputError);
  EXPECT_THROW(ValidateCSpaceDampingRmpParams({.accel_d_gain = INFINITY}, "x"), InputError);
}

}  // namespace
}  // namespace rmpmarl::rmp
