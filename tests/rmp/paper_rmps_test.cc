// The paper's target RMP (eqs 5–7) and collision RMP (eqs 8–9) against hand-computed values; metrics are symmetric
// positive semi-definite and finite everywhere, including on the target and at zero/negative distance.
#include "rmpmarl/rmp/paper_rmps.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <cmath>
#include <limits>
#include <random>

#include "rmp_test_util.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/rmp/joint_layer.h"

namespace rmpmarl::rmp {
namespace {

using testing::RandomVector3;
using testing::Uniform;

// small round parameters whose values are easy to follow by hand
TargetRmpParams HandTargetParams(TargetDamping damping) {
  return {.accel_p_gain = 2.0,
          .accel_d_gain = 0.5,
          .damping = damping,
          .accel_norm_eps = 0.1,
          .metric_alpha_length_scale = 0.2,
          .min_metric_alpha = 0.1,
          .max_metric_scalar = 3.0,
          .min_metric_scalar = 5.0,
          .proximity_metric_boost_scalar = 4.0,
          .proximity_metric_boost_length_scale = 0.3};
}

// x = 0, x₀ = (0.3, 0.4, 0) (distance 0.5), ẋ = (1, 0, 2). Values from the formulas evaluated independently:
//   α = 0.9 exp(−0.25/0.08) + 0.1 = 0.13954324026106668, β = exp(−0.25/0.18) = 0.24935220877729622,
//   a = 2 (0.3, 0.4, 0)/0.6 − 0.5 √5 (1, 0, 2),  M = (4β + 1 − β)(3α I + 5(1 − α) u uᵀ), u = (0.6, 0.8, 0).
TEST(TargetRmpTest, MatchesHandComputedValuesWithQuadraticDamping) {
  const Rmp3 rmp = EvalTargetRmp(HandTargetParams(TargetDamping::kQuadratic), Eigen::Vector3d::Zero(),
                                 Eigen::Vector3d(1.0, 0.0, 2.0), Eigen::Vector3d(0.3, 0.4, 0.0));
  EXPECT_NEAR(rmp.a.x(), -0.1180339887498949, 1e-14);
  EXPECT_NEAR(rmp.a.y(), 1.3333333333333335, 1e-14);
  EXPECT_NEAR(rmp.a.z(), -2.23606797749979, 1e-14);
  Eigen::Matrix3d M;
  M << 3.4392173103552164, 3.609905137280901, 0.0, 3.609905137280901, 5.5449953071024085, 0.0, 0.0, 0.0,
      0.7317884573945412;
  EXPECT_LT((rmp.M - M).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(TargetRmpTest, LinearDampingOptionIsRmpflowsTerm) {
  const Rmp3 rmp = EvalTargetRmp(HandTargetParams(TargetDamping::kLinear), Eigen::Vector3d::Zero(),
                                 Eigen::Vector3d(1.0, 0.0, 2.0), Eigen::Vector3d(0.3, 0.4, 0.0));
  EXPECT_NEAR(rmp.a.x(), 0.5, 1e-14);
  EXPECT_NEAR(rmp.a.y(), 1.3333333333333335, 1e-14);
  EXPECT_NEAR(rmp.a.z(), -1.0, 1e-14);
  // the metric does not depend on the damping
  const Rmp3 quadratic = EvalTargetRmp(HandTargetParams(TargetDamping::kQuadratic), Eigen::Vector3d::Zero(),
                                       Eigen::Vector3d(1.0, 0.0, 2.0), Eigen::Vector3d(0.3, 0.4, 0.0));
  EXPECT_EQ(rmp.M, quadratic.M);
}

TEST(TargetRmpTest, LimitsFarFromAndOnTheTarget) {
  const TargetRmpParams p = HandTargetParams(TargetDamping::kQuadratic);
  // far away: α → α_min, β → 0, acceleration magnitude → k_p
  const Eigen::Vector3d x0(30.0, -40.0, 0.0);
  const Rmp3 far = EvalTargetRmp(p, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), x0);
  const Eigen::Vector3d u = x0.normalized();
  const Eigen::Matrix3d M_far = 0.1 * 3.0 * Eigen::Matrix3d::Identity() + 0.9 * 5.0 * u * u.transpose();
  EXPECT_LT((far.M - M_far).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_NEAR(far.a.norm(), 2.0 * 50.0 / 50.1, 1e-12);
  // exactly on the target: a = −k_d‖ẋ‖ẋ, α = β = 1, M = b μ_near I, no NaN
  const Eigen::Vector3d x(0.1, 0.2, 0.3);
  const Rmp3 on = EvalTargetRmp(p, x, Eigen::Vector3d(0.0, 2.0, 0.0), x);
  ASSERT_TRUE(on.a.allFinite() && on.M.allFinite());
  EXPECT_LT((on.a - Eigen::Vector3d(0.0, -2.0, 0.0)).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((on.M - 4.0 * 3.0 * Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff(), 1e-15);
  // and continuous as the target is approached
  const Rmp3 near = EvalTargetRmp(p, x, Eigen::Vector3d::Zero(), x + Eigen::Vector3d(1e-9, -2e-9, 0.0));
  EXPECT_LT((near.M - on.M).cwiseAbs().maxCoeff(), 1e-12);
}

// symmetric, positive semi-definite (eigenvalues ≥ −1e-12 relative) and finite
void ExpectSpsd(const Eigen::Matrix3d& M) {
  ASSERT_TRUE(M.allFinite());
  EXPECT_EQ(M, M.transpose());
  const Eigen::Vector3d eig = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(M).eigenvalues();
  EXPECT_GE(eig.minCoeff(), -1e-12 * (1.0 + eig.cwiseAbs().maxCoeff()));
}

TEST(TargetRmpTest, MetricIsSymmetricPsdAndFiniteEverywhere) {
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 3000; ++trial) {
    TargetRmpParams p;
    p.accel_p_gain = Uniform(rng, 0.0, 100.0);
    p.accel_d_gain = Uniform(rng, 0.0, 100.0);
    p.damping = trial % 2 ? TargetDamping::kLinear : TargetDamping::kQuadratic;
    p.accel_norm_eps = Uniform(rng, 1e-3, 0.2);
    p.metric_alpha_length_scale = Uniform(rng, 1e-3, 0.5);
    p.min_metric_alpha = Uniform(rng, 0.0, 1.0);
    p.max_metric_scalar = Uniform(rng, 0.0, 1e4);
    p.min_metric_scalar = Uniform(rng, 0.0, 1e4);
    p.proximity_metric_boost_scalar = Uniform(rng, 0.0, 50.0);
    p.proximity_metric_boost_length_scale = Uniform(rng, 1e-3, 0.5);
    const Eigen::Vector3d x = RandomVector3(rng, -1.0, 1.0);
    // a third exactly on the target, a third within a micrometre, the rest anywhere
    Eigen::Vector3d x0 = x;
    if (trial % 3 == 1) x0 += RandomVector3(rng, -1e-6, 1e-6);
    if (trial % 3 == 2) x0 = RandomVector3(rng, -1.0, 1.0);
    const Rmp3 rmp = EvalTargetRmp(p, x, RandomVector3(rng, -3.0, 3.0), x0);
    ASSERT_TRUE(rmp.a.allFinite());
    ExpectSpsd(rmp.M);
  }
}

TEST(CollisionRmpTest, MatchesHandComputedValues) {
  CollisionRmpParams p;  // Lula's collision_rmp values with the paper's μ = 1
  // x = 0.02, ẋ = −0.01: σ = 1/(1 + e⁻¹), g = 0.96², a = 800 e⁻² + 50 σ 0.01/0.51, m = σ g/1.001
  Rmp1 rmp = EvalCollisionRmp(p, 0.02, -0.01);
  EXPECT_NEAR(rmp.a, 108.98495068598625, 1e-12);
  EXPECT_NEAR(rmp.m, 0.6730705155498627, 1e-14);
  rmp = EvalCollisionRmp(p, 0.3, 0.05);
  EXPECT_NEAR(rmp.a, -0.002227979593675878, 1e-15);
  EXPECT_NEAR(rmp.m, 7.138565081564945e-05, 1e-16);
  // beyond the modulation radius r the metric is exactly zero (the RMP is off)
  rmp = EvalCollisionRmp(p, 0.6, -1.0);
  EXPECT_NEAR(rmp.a, 3.331112591605596, 1e-12);
  EXPECT_EQ(rmp.m, 0.0);
}

TEST(CollisionRmpTest, AccelAndMetricFromOneGateAreTheRmpsBits) {
  // the coupled layer evaluates σ once per leaf and the acceleration once per length scale: the same bits as the
  // whole RMP, also with the length scales multiplied as EvalScaledCollisionRmp multiplies them
  CollisionRmpParams p;
  std::mt19937_64 rng(11);
  for (int trial = 0; trial < 2000; ++trial) {
    const double x = Uniform(rng, -0.05, 0.8), xd = Uniform(rng, -3.0, 3.0), scale = Uniform(rng, 0.2, 5.0);
    const double sigma = CollisionVelocityGate(xd, p.damping_velocity_gate_length_scale);
    const Rmp1 rmp = EvalCollisionRmp(p, x, xd);
    EXPECT_EQ(CollisionRmpAccel(p, x, xd, sigma), rmp.a) << x << " " << xd;
    EXPECT_EQ(CollisionRmpMetric(p, x, sigma), rmp.m) << x << " " << xd;
    CollisionRmpParams scaled = p;
    scaled.repulsion_std_dev *= scale;
    scaled.damping_std_dev *= scale;
    EXPECT_EQ(CollisionRmpAccel(scaled, x, xd, sigma), EvalScaledCollisionRmp(p, x, xd, scale).a);
  }
}

TEST(CollisionRmpTest, GatesMatchEquationNine) {
  EXPECT_DOUBLE_EQ(CollisionVelocityGate(0.0, 0.01), 0.5);
  EXPECT_NEAR(CollisionVelocityGate(0.01, 0.01), 1.0 - 1.0 / (1.0 + std::exp(-1.0)), 1e-15);
  EXPECT_NEAR(CollisionVelocityGate(-0.02, 0.01), 1.0 - 1.0 / (1.0 + std::exp(2.0)), 1e-15);
  EXPECT_EQ(CollisionVelocityGate(1e6, 0.01), 0.0);  // receding fast: off, not NaN
  EXPECT_EQ(CollisionVelocityGate(-1e6, 0.01), 1.0);
  EXPECT_DOUBLE_EQ(CollisionDistanceGate(0.0, 0.5), 1.0);
  EXPECT_DOUBLE_EQ(CollisionDistanceGate(0.2, 0.5), 0.04 / 0.25 - 0.4 / 0.5 + 1.0);
  EXPECT_DOUBLE_EQ(CollisionDistanceGate(0.5, 0.5), 0.0);
  EXPECT_EQ(CollisionDistanceGate(0.7, 0.5), 0.0);
}

TEST(CollisionRmpTest, PenetrationIsClampedToContactValues) {
  const CollisionRmpParams p;
  for (double xd : {-1.0, 0.0, 0.3}) {
    const Rmp1 contact = EvalCollisionRmp(p, 0.0, xd);
    for (double x : {-1e-9, -0.01, -1.0, -1e6}) {
      const Rmp1 inside = EvalCollisionRmp(p, x, xd);
      EXPECT_EQ(inside.a, contact.a);
      EXPECT_EQ(inside.m, contact.m);
    }
  }
  // at contact, approaching at 1 m/s: a = k_p + k_d σ/ε_d, m = σ μ/ε_m
  const double sigma = CollisionVelocityGate(-1.0, p.damping_velocity_gate_length_scale);
  const Rmp1 rmp = EvalCollisionRmp(p, 0.0, -1.0);
  EXPECT_NEAR(rmp.a, 800.0 + 50.0 * sigma / 0.01, 1e-9);
  EXPECT_NEAR(rmp.m, sigma / 0.001, 1e-9);
}

TEST(CollisionRmpTest, MetricIsNonNegativeAndFiniteEverywhere) {
  std::mt19937_64 rng(12);
  const double inf = std::numeric_limits<double>::infinity();
  for (int trial = 0; trial < 5000; ++trial) {
    CollisionRmpParams p;
    p.repulsion_gain = Uniform(rng, 0.0, 1000.0);
    p.repulsion_std_dev = Uniform(rng, 1e-3, 0.1);
    p.damping_gain = Uniform(rng, 0.0, 100.0);
    p.damping_std_dev = Uniform(rng, 1e-3, 0.1);
    p.damping_robustness_eps = Uniform(rng, 1e-4, 0.1);
    p.damping_velocity_gate_length_scale = Uniform(rng, 1e-3, 0.1);
    p.metric_scalar = Uniform(rng, 0.0, 1e4);
    p.metric_exploder_std_dev = Uniform(rng, 1e-3, 0.1);
    p.metric_exploder_eps = Uniform(rng, 1e-4, 0.1);
    p.metric_modulation_radius = Uniform(rng, 0.01, 1.0);
    const double x = trial % 4 == 0 ? 0.0 : Uniform(rng, -0.5, 1.0);
    const double xd = Uniform(rng, -5.0, 5.0);
    const Rmp1 rmp = EvalCollisionRmp(p, x, xd);
    ASSERT_TRUE(std::isfinite(rmp.a) && std::isfinite(rmp.m)) << "x=" << x << " xd=" << xd;
    EXPECT_GE(rmp.m, 0.0);
  }
  const Rmp1 far = EvalCollisionRmp(CollisionRmpParams{}, inf, 0.0);
  EXPECT_EQ(far.m, 0.0);
  EXPECT_TRUE(std::isfinite(far.a));
}

TEST(PaperRmpParamsTest, ValidationRejectsBadValues) {
  EXPECT_NO_THROW(ValidateTargetRmpParams(TargetRmpParams{}, "t"));
  EXPECT_NO_THROW(ValidateCollisionRmpParams(CollisionRmpParams{}, "c"));
  TargetRmpParams t;
  t.accel_p_gain = -1.0;
  EXPECT_THROW(ValidateTargetRmpParams(t, "t"), InputError);
  t = {};
  t.min_metric_alpha = 1.5;
  EXPECT_THROW(ValidateTargetRmpParams(t, "t"), InputError);
  t = {};
  t.accel_norm_eps = 0.0;
  EXPECT_THROW(ValidateTargetRmpParams(t, "t"), InputError);
  t = {};
  t.max_metric_scalar = std::nan("");
  EXPECT_THROW(ValidateTargetRmpParams(t, "t"), InputError);
  CollisionRmpParams c;
  c.metric_exploder_eps = 0.0;
  EXPECT_THROW(ValidateCollisionRmpParams(c, "c"), InputError);
  c = {};
  c.damping_gain = -2.0;
  try {
    ValidateCollisionRmpParams(c, "file.yaml: rmp_params.collision_rmp");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("file.yaml: rmp_params.collision_rmp.damping_gain"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace rmpmarl::rmp
