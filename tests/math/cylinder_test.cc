// Capsule–cylinder distances against independent references: the point–cylinder distance against dense samples of
// the cylinder's surface, the capsule's against a brute-force minimum over its axis, hand-derived cases, and the
// witness points' conventions.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rmpmarl/math/geometry.h"

namespace rmpmarl::math {
namespace {

using Eigen::Vector3d;

Eigen::Isometry3d RandomPose(std::mt19937_64& rng) {
  std::normal_distribution<double> normal(0.0, 1.0);
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized().toRotationMatrix();
  X.translation() = Vector3d(normal(rng), normal(rng), normal(rng)) * 0.3;
  return X;
}

// the distance from an outside point to the cylinder's surface by dense sampling of the surface (side and caps)
double SampledSurfaceDistance(const Cylinder& c, const Vector3d& p_W) {
  const Vector3d p = c.X_WC.inverse() * p_W;
  double best = INFINITY;
  constexpr int kAround = 720, kAlong = 400, kRings = 200;
  for (int i = 0; i < kAround; ++i) {
    const double a = 2.0 * M_PI * i / kAround;
    const Vector3d u(std::cos(a), std::sin(a), 0.0);
    for (int j = 0; j <= kAlong; ++j) {
      const double z = -c.half_length + 2.0 * c.half_length * j / kAlong;
      best = std::min(best, (p - (c.radius * u + Vector3d(0, 0, z))).norm());
    }
    for (int k = 0; k <= kRings; ++k) {
      for (const double z : {-c.half_length, c.half_length}) {
        best = std::min(best, (p - (c.radius * k / kRings * u + Vector3d(0, 0, z))).norm());
      }
    }
  }
  return best;
}

TEST(CylinderDistanceTest, PointDistanceMatchesSampledSurfaceAndHandValues) {
  Cylinder c;
  c.radius = 0.1;
  c.half_length = 0.2;
  // by hand: beside the side, above a cap, beyond the rim, inside near the side, inside near a cap
  EXPECT_NEAR(CylinderSignedDistance(c, Vector3d(0.3, 0.0, 0.05)), 0.2, 1e-15);
  EXPECT_NEAR(CylinderSignedDistance(c, Vector3d(0.0, 0.05, 0.5)), 0.3, 1e-15);
  EXPECT_NEAR(CylinderSignedDistance(c, Vector3d(0.13, 0.0, 0.24)), 0.05, 1e-15);
  EXPECT_NEAR(CylinderSignedDistance(c, Vector3d(0.08, 0.0, 0.0)), -0.02, 1e-15);
  EXPECT_NEAR(CylinderSignedDistance(c, Vector3d(0.0, 0.0, -0.19)), -0.01, 1e-15);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> box(-0.6, 0.6);
  for (int trial = 0; trial < 40; ++trial) {
    c.X_WC = RandomPose(rng);
    Vector3d p;
    do {
      p = c.X_WC * Vector3d(box(rng), box(rng), box(rng));
    } while (CylinderSignedDistance(c, p) <= 0.0);
    const double sampled = SampledSurfaceDistance(c, p);
    // the samples lie within 0.9 mm of any surface point: the sampled distance is at most that much above
    EXPECT_LE(CylinderSignedDistance(c, p), sampled + 1e-12) << trial;
    EXPECT_GE(CylinderSignedDistance(c, p), sampled - 1e-3) << trial;
  }
}

TEST(CylinderDistanceTest, CapsuleDistanceIsTheMinimumOverTheAxisAndItsWitnessesAreConsistent) {
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> coord(-0.5, 0.5), size(0.01, 0.25);
  int penetrating = 0, outside = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Cylinder c;
    c.X_WC = RandomPose(rng);
    c.radius = size(rng);
    c.half_length = size(rng);
    Capsule cap;
    cap.p_WA = c.X_WC * Vector3d(coord(rng), coord(rng), coord(rng));
    cap.p_WB = trial % 7 == 0 ? cap.p_WA : Vector3d(c.X_WC * Vector3d(coord(rng), coord(rng), coord(rng)));
    cap.radius = 0.5 * size(rng);
    const DistanceResult r = CapsuleCylinderDistance(cap, c);
    // brute force: the exact point distance at 20001 axis points
    double brute = INFINITY;
    for (int i = 0; i <= 20000; ++i) {
      const double s = i / 20000.0;
      brute = std::min(brute, CylinderSignedDistance(c, cap.p_WA + s * (cap.p_WB - cap.p_WA)) - cap.radius);
    }
    // never above the brute-force minimum, and below it by no more than the axis sampling can hide
    const double step = (cap.p_WB - cap.p_WA).norm() / 20000.0;
    EXPECT_LE(r.distance, brute + 1e-12) << trial;
    EXPECT_GE(r.distance, brute - step - 1e-12) << trial;
    // conventions: unit normal, p_W1 ≈ p_W2 + distance · n_W, p_W2 on the cylinder's surface
    EXPECT_NEAR(r.n_W.norm(), 1.0, 1e-12) << trial;
    EXPECT_LT((r.p_W1 - (r.p_W2 + r.distance * r.n_W)).norm(), 1e-9) << trial;
    EXPECT_NEAR(CylinderSignedDistance(c, r.p_W2), 0.0, 1e-9) << trial;
    if (r.distance + cap.radius > 1e-9) {
      // the axis misses the cylinder: p_W1 lies on the capsule's surface
      const Vector3d d = cap.p_WB - cap.p_WA;
      const double s = d.squaredNorm() > 0 ? std::clamp((r.p_W1 - cap.p_WA).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
      EXPECT_NEAR((r.p_W1 - (cap.p_WA + s * d)).norm(), cap.radius, 1e-7) << trial;
      ++outside;
    }
    penetrating += r.distance < 0.0;
  }
  EXPECT_GT(penetrating, 40);
  EXPECT_GT(outside, 40);
}

TEST(CylinderDistanceTest, HandDerivedCapsules) {
  Cylinder c;  // about z, radius 0.1, half length 0.2
  c.radius = 0.1;
  c.half_length = 0.2;
  // a capsule parallel to the axis, 0.3 from it: 0.2 between the surfaces, minus its radius 0.05
  Capsule parallel{Vector3d(0.3, 0.0, -0.1), Vector3d(0.3, 0.0, 0.1), 0.05};
  DistanceResult r = CapsuleCylinderDistance(parallel, c);
  EXPECT_NEAR(r.distance, 0.15, 1e-12);
  EXPECT_NEAR((r.n_W - Vector3d::UnitX()).norm(), 0.0, 1e-12);
  // a capsule across the top, 0.1 above the cap
  Capsule across{Vector3d(-0.5, 0.0, 0.3), Vector3d(0.5, 0.0, 0.3), 0.02};
  r = CapsuleCylinderDistance(across, c);
  EXPECT_NEAR(r.distance, 0.08, 1e-12);
  // the distance is flat over the cap and rises only quadratically past its rim, so a minimiser of the value finds
  // the axis point to about the square root of the rounding: the normal to 1e-6
  EXPECT_NEAR((r.n_W - Vector3d::UnitZ()).norm(), 0.0, 1e-6);
  // a capsule through the middle along x: the deepest axis point is the centre, 0.1 from the side
  Capsule through{Vector3d(-0.5, 0.0, 0.0), Vector3d(0.5, 0.0, 0.0), 0.01};
  r = CapsuleCylinderDistance(through, c);
  EXPECT_NEAR(r.distance, -0.11, 1e-12);
  // the same with the cylinder moved and turned: the distance does not change
  c.X_WC = Eigen::Translation3d(1.0, -2.0, 0.5) * Eigen::AngleAxisd(0.7, Vector3d(1, 2, 3).normalized());
  const Capsule moved{c.X_WC * through.p_WA, c.X_WC * through.p_WB, through.radius};
  EXPECT_NEAR(CapsuleCylinderDistance(moved, c).distance, -0.11, 1e-12);
}

}  // namespace
}  // namespace rmpmarl::math
