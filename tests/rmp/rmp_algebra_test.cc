// RMP algebra: natural/canonical forms, pushforward, pullback, addition and the regularised resolve.
#include "rmpmarl/rmp/rmp.h"

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <random>

#include "rmp_test_util.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {
namespace {

using testing::RandomSpd;
using testing::RandomVector;

TEST(RmpAlgebraTest, NaturalAndCanonicalFormsRoundTrip) {
  std::mt19937_64 rng(1);
  for (int n = 1; n <= 6; ++n) {
    const CanonicalRmp canonical{RandomVector(n, rng), RandomSpd(n, rng)};
    const NaturalRmp natural = ToNatural(canonical);
    EXPECT_LT((natural.f - canonical.M * canonical.a).cwiseAbs().maxCoeff(), 1e-15);
    const CanonicalRmp back = ToCanonical(natural);
    // (M + λI)⁻¹ M a differs from a by O(λ ‖M⁻¹‖), λ ≈ 1e-6
    EXPECT_LT((back.a - canonical.a).cwiseAbs().maxCoeff(), 1e-4);
    EXPECT_EQ(back.M, canonical.M);
  }
}

TEST(RmpAlgebraTest, PushforwardAndPullbackMatchTheirFormulas) {
  std::mt19937_64 rng(2);
  const TaskMapValue map{RandomVector(3, rng), Eigen::MatrixXd::Random(3, 5), RandomVector(3, rng)};
  const Eigen::VectorXd qd = RandomVector(5, rng);
  EXPECT_LT((PushForwardVelocity(map, qd) - map.J * qd).cwiseAbs().maxCoeff(), 1e-15);
  const NaturalRmp rmp{RandomVector(3, rng), RandomSpd(3, rng)};
  const NaturalRmp pulled = Pullback(map, rmp);
  const Eigen::VectorXd f_expected = map.J.transpose() * (rmp.f - rmp.M * map.Jdot_qd);
  const Eigen::MatrixXd M_expected = map.J.transpose() * rmp.M * map.J;
  EXPECT_LT((pulled.f - f_expected).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_LT((pulled.M - M_expected).cwiseAbs().maxCoeff(), 1e-13);
  // 1-D maps take the scalar path
  const TaskMapValue line{RandomVector(1, rng), Eigen::MatrixXd::Random(1, 4), RandomVector(1, rng)};
  const NaturalRmp scalar{RandomVector(1, rng), Eigen::MatrixXd::Constant(1, 1, 2.5)};
  const NaturalRmp pulled1 = Pullback(line, scalar);
  EXPECT_LT((pulled1.f - line.J.transpose() * (scalar.f - scalar.M * line.Jdot_qd)).cwiseAbs().maxCoeff(), 1e-13);
  EXPECT_LT((pulled1.M - 2.5 * line.J.transpose() * line.J).cwiseAbs().maxCoeff(), 1e-13);
}

TEST(RmpAlgebraTest, AddSumsForcesAndMetrics) {
  std::mt19937_64 rng(3);
  const NaturalRmp a{RandomVector(4, rng), RandomSpd(4, rng)};
  const NaturalRmp b{RandomVector(4, rng), RandomSpd(4, rng)};
  const NaturalRmp sum = Add(a, b);
  EXPECT_EQ(sum.f, a.f + b.f);
  EXPECT_EQ(sum.M, a.M + b.M);
  EXPECT_THROW(Add(a, NaturalRmp{RandomVector(3, rng), RandomSpd(3, rng)}), InputError);
}

TEST(RmpAlgebraTest, ResolveIsTheRegularisedSolve) {
  std::mt19937_64 rng(4);
  for (int n = 1; n <= 7; ++n) {
    const NaturalRmp rmp{RandomVector(n, rng), 100.0 * RandomSpd(n, rng)};
    const double lambda = ResolveRegularizer(rmp.M);
    EXPECT_DOUBLE_EQ(lambda, 1e-6 * (1.0 + rmp.M.trace() / n));
    const Eigen::MatrixXd M_reg = rmp.M + lambda * Eigen::MatrixXd::Identity(n, n);
    const Eigen::VectorXd expected = M_reg.inverse() * rmp.f;
    const Eigen::VectorXd a = Resolve(rmp);
    EXPECT_LT((a - expected).norm(), 1e-10 * (1.0 + expected.norm()));
    // and close to the unregularised solution for a well-conditioned metric
    EXPECT_LT((a - rmp.M.inverse() * rmp.f).norm(), 1e-5 * (1.0 + expected.norm()));
  }
}

TEST(RmpAlgebraTest, ResolveOfRankDeficientMetricApproachesThePseudoInverse) {
  std::mt19937_64 rng(5);
  const Eigen::MatrixXd J = Eigen::MatrixXd::Random(3, 7);  // a 3-D task on a 7-DoF arm: rank 3
  const Eigen::MatrixXd M = J.transpose() * RandomSpd(3, rng) * J;
  const Eigen::VectorXd f = J.transpose() * RandomVector(3, rng);  // in the range of M
  const Eigen::VectorXd a = Resolve(NaturalRmp{f, M});
  ASSERT_TRUE(a.allFinite());
  const Eigen::VectorXd pinv = M.completeOrthogonalDecomposition().solve(f);
  EXPECT_LT((a - pinv).norm(), 1e-3 * pinv.norm());
  // a zero metric and force give a zero acceleration, not NaN
  const Eigen::VectorXd zero = Resolve(NaturalRmp{Eigen::VectorXd::Zero(4), Eigen::MatrixXd::Zero(4, 4)});
  EXPECT_TRUE(zero.isZero(0.0));
}

TEST(RmpAlgebraTest, SizeMismatchesAreInputErrors) {
  std::mt19937_64 rng(6);
  const TaskMapValue map{RandomVector(3, rng), Eigen::MatrixXd::Random(3, 5), RandomVector(3, rng)};
  EXPECT_THROW(Pullback(map, NaturalRmp{RandomVector(2, rng), RandomSpd(2, rng)}), InputError);
  EXPECT_THROW(Pullback(map, NaturalRmp{RandomVector(3, rng), RandomSpd(2, rng)}), InputError);
  EXPECT_THROW(PushForwardVelocity(map, RandomVector(4, rng)), InputError);
  EXPECT_THROW(Resolve(NaturalRmp{RandomVector(3, rng), RandomSpd(4, rng)}), InputError);
  EXPECT_THROW(ToNatural(CanonicalRmp{RandomVector(3, rng), RandomSpd(2, rng)}), InputError);
  EXPECT_THROW(RmpResolver(3, ResolveOptions{.relative_regularizer = 0.0}), InputError);
  EXPECT_THROW(RmpResolver(3, ResolveOptions{.relative_regularizer = -1.0}), InputError);
}

}  // namespace
}  // namespace rmpmarl::rmp
