// Capsule fits against dense sampling: every sampled surface point of the primitive (or point set) lies inside the
// capsule, and the capsule is no bigger than needed: it touches the samples (its radius is tight) and its volume is
// within 1 % of the best capsule found by brute force over 1,000 axis directions.
#include "rmpmarl/setup/capsule_fit.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rmpmarl/common/error.h"

namespace rmpmarl::setup {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kVolumeMargin = 0.01;  // the fitted capsule's volume may exceed the brute-force best by 1 %

Eigen::Matrix3Xd SampleCylinder(double r, double length, int n_around, int n_along) {
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n_around; ++i) {
    const double a = 2.0 * kPi * i / n_around;
    for (int k = 0; k <= n_along; ++k) p.emplace_back(r * std::cos(a), r * std::sin(a), -0.5 * length + length * k / n_along);
    for (int k = 1; k < 8; ++k) {  // end discs
      p.emplace_back(r * k / 8.0 * std::cos(a), r * k / 8.0 * std::sin(a), 0.5 * length);
      p.emplace_back(r * k / 8.0 * std::cos(a), r * k / 8.0 * std::sin(a), -0.5 * length);
    }
  }
  Eigen::Matrix3Xd m(3, p.size());
  for (size_t i = 0; i < p.size(); ++i) m.col(i) = p[i];
  return m;
}

Eigen::Matrix3Xd SampleBox(const Eigen::Vector3d& size, int n) {
  std::vector<Eigen::Vector3d> p;
  const Eigen::Vector3d h = 0.5 * size;
  for (int axis = 0; axis < 3; ++axis) {
    const int i = (axis + 1) % 3, j = (axis + 2) % 3;
    for (int a = 0; a <= n; ++a) {
      for (int b = 0; b <= n; ++b) {
        for (double sign : {-1.0, 1.0}) {
          Eigen::Vector3d q;
          q[axis] = sign * h[axis];
          q[i] = -h[i] + size[i] * a / n;
          q[j] = -h[j] + size[j] * b / n;
          p.push_back(q);
        }
      }
    }
  }
  Eigen::Matrix3Xd m(3, p.size());
  for (size_t k = 0; k < p.size(); ++k) m.col(k) = p[k];
  return m;
}

Eigen::Matrix3Xd SampleSphere(double r, int n) {
  Eigen::Matrix3Xd m(3, n);
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  for (int k = 0; k < n; ++k) {
    const double z = 1.0 - 2.0 * (k + 0.5) / n;
    const double rho = std::sqrt(1.0 - z * z);
    m.col(k) = r * Eigen::Vector3d(rho * std::cos(golden * k), rho * std::sin(golden * k), z);
  }
  return m;
}

// largest signed distance of the samples from the capsule surface (≤ 0: all inside; ≈ 0: the capsule touches them).
double MaxSignedDistance(const math::Capsule& c, const Eigen::Matrix3Xd& samples) {
  double worst = -std::numeric_limits<double>::infinity();
  for (Eigen::Index i = 0; i < samples.cols(); ++i) worst = std::max(worst, CapsuleSignedDistance(c, samples.col(i)));
  return worst;
}

// the smallest capsule volume over 1,000 axis directions (Fibonacci half-sphere), each fitted along that axis to at
// most ~800 of the samples (fewer points can only make the brute-force capsule smaller: a stricter comparison).
double BruteForceVolume(const Eigen::Matrix3Xd& samples) {
  std::vector<Ball> balls;
  const Eigen::Index stride = std::max<Eigen::Index>(1, samples.cols() / 800);
  for (Eigen::Index i = 0; i < samples.cols(); i += stride) balls.push_back({samples.col(i), 0.0});
  const Eigen::Matrix3Xd dirs = SampleSphere(1.0, 2000);
  double best = std::numeric_limits<double>::infinity();
  for (Eigen::Index k = 0; k < dirs.cols(); ++k) {
    if (dirs(2, k) < 0.0) continue;
    best = std::min(best, CapsuleVolume(FitCapsuleAlongAxis(balls, dirs.col(k))));
  }
  return best;
}

void ExpectTightCover(const math::Capsule& c, const Eigen::Matrix3Xd& samples, const std::string& what) {
  SCOPED_TRACE(what);
  const double worst = MaxSignedDistance(c, samples);
  EXPECT_LE(worst, 1e-9) << "a sampled surface point lies outside the capsule";
  EXPECT_GE(worst, -0.01 * c.radius) << "the capsule does not touch the geometry: radius not tight";
  const double brute = BruteForceVolume(samples);
  EXPECT_LE(CapsuleVolume(c), (1.0 + kVolumeMargin) * brute) << "volume " << CapsuleVolume(c) << " vs best " << brute;
}

TEST(CapsuleFit, SphereIsItself) {
  const math::Capsule c = CapsuleCoveringSphere(0.07);
  EXPECT_DOUBLE_EQ(c.radius, 0.07);
  EXPECT_EQ((c.p_WB - c.p_WA).norm(), 0.0);
  ExpectTightCover(c, SampleSphere(0.07, 2000), "sphere");
}

TEST(CapsuleFit, CapsuleIsItself) {
  const math::Capsule c = CapsuleCoveringCapsule(0.05, 0.3);
  EXPECT_DOUBLE_EQ(c.radius, 0.05);
  EXPECT_NEAR((c.p_WB - c.p_WA).norm(), 0.3, 1e-15);
}

TEST(CapsuleFit, LongCylinderCoveredTightlyAndSmallest) {
  const math::Capsule c = CapsuleCoveringCylinder(0.06, 0.4);
  // along z, symmetric, radius a little above the cylinder's, ends pulled in from ±0.2
  EXPECT_NEAR(c.p_WA.head<2>().norm() + c.p_WB.head<2>().norm(), 0.0, 1e-12);
  EXPECT_NEAR(c.p_WA.z(), -c.p_WB.z(), 1e-12);
  EXPECT_GT(c.radius, 0.06);
  EXPECT_LT(c.p_WB.z(), 0.2);
  ExpectTightCover(c, SampleCylinder(0.06, 0.4, 128, 80), "long cylinder");
}

TEST(CapsuleFit, FlatDiscBecomesItsCircumscribedSphere) {
  const math::Capsule c = CapsuleCoveringCylinder(0.1, 0.02);
  EXPECT_NEAR((c.p_WB - c.p_WA).norm(), 0.0, 1e-9);
  EXPECT_NEAR(c.radius, std::hypot(0.1, 0.01), 1e-6);
  ExpectTightCover(c, SampleCylinder(0.1, 0.02, 128, 8), "disc");
}

TEST(CapsuleFit, BoxesAlongTheirLongestAxis) {
  for (const Eigen::Vector3d& size : {Eigen::Vector3d(0.1, 0.08, 0.5), Eigen::Vector3d(0.4, 0.05, 0.05),
                                      Eigen::Vector3d(0.1, 0.1, 0.1), Eigen::Vector3d(0.02, 0.3, 0.2)}) {
    const math::Capsule c = CapsuleCoveringBox(size);
    ExpectTightCover(c, SampleBox(size, 24), fmt::format("box {} {} {}", size.x(), size.y(), size.z()));
  }
}

TEST(CapsuleFit, PointSetOfARotatedShiftedCylinderMatchesTheClosedForm) {
  const Eigen::Isometry3d X_FG = Eigen::Translation3d(0.1, -0.2, 0.3) *
                                 Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized());
  const Eigen::Matrix3Xd p_G = SampleCylinder(0.05, 0.3, 128, 60);
  const Eigen::Matrix3Xd p_F = X_FG * p_G;
  const math::Capsule fit = FitCapsuleToPoints(p_F);
  const math::Capsule closed = CapsuleCoveringCylinder(0.05, 0.3);
  EXPECT_LE(MaxSignedDistance(fit, p_F), 1e-9);
  EXPECT_NEAR(CapsuleVolume(fit), CapsuleVolume(closed), 0.01 * CapsuleVolume(closed));
  // the axis is the cylinder's
  const Eigen::Vector3d axis = (fit.p_WB - fit.p_WA).normalized();
  EXPECT_GT(std::abs(axis.dot(X_FG.linear().col(2))), 0.999);
  ExpectTightCover(fit, p_F, "rotated cylinder points");
}

TEST(CapsuleFit, RandomPointCloudsAreCoveredAndNearOptimal) {
  std::mt19937_64 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  for (int trial = 0; trial < 4; ++trial) {
    Eigen::Matrix3Xd p(3, 400);
    const Eigen::Vector3d scale(0.3, 0.08 + 0.02 * trial, 0.05);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3 * trial + 0.2, Eigen::Vector3d(0.2, 1, 0.4).normalized()).toRotationMatrix();
    for (int i = 0; i < p.cols(); ++i) {
      p.col(i) = R * Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).cwiseProduct(scale) +
                 Eigen::Vector3d(0.05 * trial, 0.0, 0.1);
    }
    ExpectTightCover(FitCapsuleToPoints(p), p, fmt::format("cloud {}", trial));
  }
}

TEST(CapsuleFit, BallsAreCoveredWithTheirRadius) {
  std::vector<Ball> balls = {{Eigen::Vector3d(0, 0, 0), 0.05}, {Eigen::Vector3d(0.3, 0, 0), 0.03},
                             {Eigen::Vector3d(0.15, 0.02, 0), 0.0}};
  const math::Capsule c = FitCapsuleToBalls(balls);
  for (const Ball& b : balls) EXPECT_LE(CapsuleSignedDistance(c, b.p_F) + b.radius, 1e-9);
  EXPECT_LT(c.radius, 0.06);
}

TEST(CapsuleFit, RejectsEmptyAndNonFiniteInput) {
  EXPECT_THROW(FitCapsuleToBalls({}), InputError);
  EXPECT_THROW(FitCapsuleToBalls({{Eigen::Vector3d(NAN, 0, 0), 0.0}}), InputError);
}

}  // namespace
}  // namespace rmpmarl::setup
