// Signed distances and witness points of segment, capsule, sphere and box pairs, checked against brute-force 1-D
// minimisation of independent point-to-shape distances, against finite-difference gradients and on hand-built
// degenerate cases.
#include "rmpmarl/math/geometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

namespace rmpmarl::math {
namespace {

using Eigen::Isometry3d;
using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr int kRandomPairs = 10000;
constexpr double kDistanceTolerance = 1e-6;  // |implementation − brute force|, absolute
constexpr double kWitnessTolerance = 1e-9;   // witness points on surfaces, p_W1 = p_W2 + distance · n_W
constexpr double kGradientTolerance = 2e-5;  // |finite-difference gradient − gradient_norm · n_W|

// ---------------------------------------------------------------------------------------------------------------
// Independent references: closed-form point-to-shape distances, minimised over one segment parameter numerically.

// minimum of a convex function on [0,1]: a dense grid, then golden-section search in the best sample's bracket
template <class F>
double MinimiseOnUnitInterval(const F& f) {
  constexpr int kGrid = 200;
  int best_k = 0;
  double best = f(0.0);
  for (int k = 1; k <= kGrid; ++k) {
    const double value = f(static_cast<double>(k) / kGrid);
    if (value < best) best = value, best_k = k;
  }
  double lo = std::max(0.0, (best_k - 1.0) / kGrid), hi = std::min(1.0, (best_k + 1.0) / kGrid);
  const double inv_phi = (std::sqrt(5.0) - 1.0) / 2.0;
  double x1 = hi - inv_phi * (hi - lo), x2 = lo + inv_phi * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  for (int iteration = 0; iteration < 80; ++iteration) {
    if (f1 < f2) {
      hi = x2, x2 = x1, f2 = f1;
      x1 = hi - inv_phi * (hi - lo), f1 = f(x1);
    } else {
      lo = x1, x1 = x2, f1 = f2;
      x2 = lo + inv_phi * (hi - lo), f2 = f(x2);
    }
  }
  return std::min({best, f1, f2});
}

// distance from point p to segment [a, b] by projection onto its line and clamping
double RefPointSegmentDistance(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d d = b - a;
  const double dd = d.squaredNorm();
  const double s = dd > 0.0 ? std::clamp((p - a).dot(d) / dd, 0.0, 1.0) : 0.0;
  return (a + s * d - p).norm();
}

// segment–segment distance: point-to-segment distance minimised over segment 1's parameter
double RefSegmentSegmentDistance(const Vector3d& a1, const Vector3d& b1, const Vector3d& a2, const Vector3d& b2) {
  return MinimiseOnUnitInterval([&](double s) { return RefPointSegmentDistance(a1 + s * (b1 - a1), a2, b2); });
}

// exact signed distance from a point to a box: outside the norm of the excess, inside minus the nearest-face distance
double RefBoxSignedDistance(const Box& box, const Vector3d& p_WQ) {
  const Vector3d p_BQ = box.X_WB.inverse() * p_WQ;
  const Vector3d q = p_BQ.cwiseAbs() - box.half_size;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// capsule–box signed distance: the box SDF minimised over the capsule axis, minus the radius
double RefCapsuleBoxDistance(const Capsule& capsule, const Box& box) {
  const Vector3d d = capsule.p_WB - capsule.p_WA;
  return MinimiseOnUnitInterval([&](double s) { return RefBoxSignedDistance(box, capsule.p_WA + s * d); }) -
         capsule.radius;
}

// capsule–sphere signed distance: centre-to-axis-point distance minimised by sampling, minus both radii
double RefCapsuleSphereDistance(const Capsule& capsule, const Sphere& sphere) {
  const Vector3d d = capsule.p_WB - capsule.p_WA;
  return MinimiseOnUnitInterval([&](double s) { return (capsule.p_WA + s * d - sphere.p_WC).norm(); }) -
         capsule.radius - sphere.radius;
}

// ---------------------------------------------------------------------------------------------------------------
// Random inputs (seeded) and shared checks.

// a uniformly distributed point in the cube [-half, half]³ around centre
Vector3d RandomPoint(std::mt19937_64& rng, double half, const Vector3d& centre = Vector3d::Zero()) {
  std::uniform_real_distribution<double> u(-half, half);
  return centre + Vector3d(u(rng), u(rng), u(rng));
}

// a uniformly distributed unit quaternion (normalised 4-D Gaussian)
Quaterniond RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  return Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized();
}

// a random rigid transform with translation in [-1, 1]³
Isometry3d RandomPose(std::mt19937_64& rng) {
  Isometry3d X = Isometry3d::Identity();
  X.linear() = RandomRotation(rng).toRotationMatrix();
  X.translation() = RandomPoint(rng, 1.0);
  return X;
}

// a capsule translated by delta
Capsule Translated(Capsule capsule, const Vector3d& delta) {
  capsule.p_WA += delta;
  capsule.p_WB += delta;
  return capsule;
}

// central differences of distance(δ), δ = translation of shape 1; false at a kink (one-sided slopes disagree)
template <class DistanceOfTranslation>
bool FiniteDifferenceGradient(const DistanceOfTranslation& distance, Vector3d* gradient) {
  constexpr double kStep = 1e-7;
  const double centre = distance(Vector3d::Zero());
  for (int k = 0; k < 3; ++k) {
    const Vector3d delta = kStep * Vector3d::Unit(k);
    const double plus = distance(delta), minus = distance(-delta);
    if (std::abs((plus - centre) - (centre - minus)) / kStep > 1e-5) return false;
    (*gradient)[k] = (plus - minus) / (2.0 * kStep);
  }
  return true;
}

// checks the conventions every result obeys: unit normal and p_W1 = p_W2 + distance · n_W
void ExpectConsistent(const DistanceResult& r) {
  EXPECT_NEAR(r.n_W.norm(), 1.0, 1e-12);
  EXPECT_LT((r.p_W1 - (r.p_W2 + r.distance * r.n_W)).norm(), kWitnessTolerance);
  EXPECT_GE(r.gradient_norm, 0.0);
  EXPECT_LE(r.gradient_norm, 1.0 + 1e-12);
}

// checks that p lies on the capsule's surface
void ExpectOnCapsuleSurface(const Capsule& capsule, const Vector3d& p) {
  EXPECT_NEAR(RefPointSegmentDistance(p, capsule.p_WA, capsule.p_WB), capsule.radius, kWitnessTolerance);
}

// tallies finite-difference gradient checks so that a test can require most random cases to be checked
struct GradientTally {
  int checked = 0;
  int skipped = 0;
  double max_error = 0.0;
};

// compares gradient_norm · n_W with finite differences of the distance under translations of shape 1
template <class DistanceOfTranslation>
void ExpectGradient(const DistanceOfTranslation& distance, const DistanceResult& r, GradientTally* tally) {
  Vector3d fd;
  if (!FiniteDifferenceGradient(distance, &fd)) {
    ++tally->skipped;
    return;
  }
  ++tally->checked;
  const double error = (fd - r.gradient_norm * r.n_W).norm();
  tally->max_error = std::max(tally->max_error, error);
  EXPECT_LT(error, kGradientTolerance) << "fd " << fd.transpose() << " vs " << (r.gradient_norm * r.n_W).transpose();
}

// ---------------------------------------------------------------------------------------------------------------
// Segment–segment

TEST(GeometryTest, SegmentSegmentMatchesBruteForce) {
  std::mt19937_64 rng(101);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  double max_error = 0.0;
  for (int trial = 0; trial < kRandomPairs; ++trial) {
    const Vector3d a1 = RandomPoint(rng, 1.0), a2 = RandomPoint(rng, 1.0);
    Vector3d b1 = RandomPoint(rng, 1.0), b2 = RandomPoint(rng, 1.0);
    const double kind = unit(rng);
    if (kind < 0.1) {
      b2 = a2 + (b1 - a1) * (2.0 * unit(rng) - 1.0) + RandomPoint(rng, 1e-9);  // nearly parallel
    } else if (kind < 0.15) {
      b2 = a2 + (b1 - a1) * (2.0 * unit(rng) - 1.0);  // parallel up to rounding
    } else if (kind < 0.2) {
      b1 = a1;  // segment 1 is a point
    }
    const SegmentClosestPoints c = ClosestPointsSegmentSegment(a1, b1, a2, b2);
    const double reference = RefSegmentSegmentDistance(a1, b1, a2, b2);
    const double error = std::abs(c.distance - reference);
    max_error = std::max(max_error, error);
    ASSERT_LT(error, kDistanceTolerance) << "trial " << trial;
    EXPECT_GE(c.s, 0.0);
    EXPECT_LE(c.s, 1.0);
    EXPECT_GE(c.t, 0.0);
    EXPECT_LE(c.t, 1.0);
    EXPECT_LT((c.p_W1 - (a1 + c.s * (b1 - a1))).norm(), 1e-12);
    EXPECT_LT((c.p_W2 - (a2 + c.t * (b2 - a2))).norm(), 1e-12);
    EXPECT_NEAR(c.distance, (c.p_W1 - c.p_W2).norm(), 1e-12);
  }
  std::printf("segment-segment: max |error| %.3g\n", max_error);
}

TEST(GeometryTest, SegmentSegmentDegenerateCases) {
  const Vector3d o(0, 0, 0), x2(2, 0, 0);
  // parallel, overlapping in x ∈ [1, 2]
  SegmentClosestPoints c = ClosestPointsSegmentSegment(o, x2, Vector3d(1, 1, 0), Vector3d(3, 1, 0));
  EXPECT_NEAR(c.distance, 1.0, 1e-15);
  EXPECT_NEAR(c.p_W1.x(), c.p_W2.x(), 1e-15);
  EXPECT_GE(c.p_W1.x(), 1.0);
  EXPECT_LE(c.p_W1.x(), 2.0);
  // anti-parallel, overlapping
  c = ClosestPointsSegmentSegment(o, x2, Vector3d(3, 1, 0), Vector3d(1, 1, 0));
  EXPECT_NEAR(c.distance, 1.0, 1e-15);
  // parallel, not overlapping: end points (2,0,0) and (3,1,0)
  c = ClosestPointsSegmentSegment(o, x2, Vector3d(3, 1, 0), Vector3d(5, 1, 0));
  EXPECT_NEAR(c.distance, std::sqrt(2.0), 1e-15);
  EXPECT_EQ(c.s, 1.0);
  EXPECT_EQ(c.t, 0.0);
  // collinear, disjoint
  c = ClosestPointsSegmentSegment(o, Vector3d(1, 0, 0), Vector3d(2, 0, 0), Vector3d(3, 0, 0));
  EXPECT_NEAR(c.distance, 1.0, 1e-15);
  // collinear, overlapping
  c = ClosestPointsSegmentSegment(o, x2, Vector3d(1, 0, 0), Vector3d(3, 0, 0));
  EXPECT_EQ(c.distance, 0.0);
  // nearly parallel (1e-10 rad): the closest pair is at the s = 0 end
  c = ClosestPointsSegmentSegment(o, Vector3d(1, 0, 0), Vector3d(0, 1, 0), Vector3d(1, 1 + 1e-10, 0));
  EXPECT_NEAR(c.distance, 1.0, 1e-14);
  // segment 1 a point
  c = ClosestPointsSegmentSegment(Vector3d(1, 1, 1), Vector3d(1, 1, 1), o, x2);
  EXPECT_NEAR(c.distance, std::sqrt(2.0), 1e-15);
  EXPECT_NEAR(c.t, 0.5, 1e-15);
  // segment 2 a point beyond segment 1's end
  c = ClosestPointsSegmentSegment(o, x2, Vector3d(3, 0, 0), Vector3d(3, 0, 0));
  EXPECT_NEAR(c.distance, 1.0, 1e-15);
  EXPECT_EQ(c.s, 1.0);
  // both points
  c = ClosestPointsSegmentSegment(o, o, Vector3d(1, 2, 2), Vector3d(1, 2, 2));
  EXPECT_NEAR(c.distance, 3.0, 1e-15);
  // crossing at both midpoints
  c = ClosestPointsSegmentSegment(Vector3d(-1, 0, 0), Vector3d(1, 0, 0), Vector3d(0, -1, 0), Vector3d(0, 1, 0));
  EXPECT_EQ(c.distance, 0.0);
  EXPECT_NEAR(c.s, 0.5, 1e-15);
  EXPECT_NEAR(c.t, 0.5, 1e-15);
  // skew, closest points interior: (0,0,0)-(2,0,0) and (1,-1,3)-(1,1,3)
  c = ClosestPointsSegmentSegment(o, x2, Vector3d(1, -1, 3), Vector3d(1, 1, 3));
  EXPECT_NEAR(c.distance, 3.0, 1e-15);
  EXPECT_NEAR(c.s, 0.5, 1e-15);
  EXPECT_NEAR(c.t, 0.5, 1e-15);
}

// ---------------------------------------------------------------------------------------------------------------
// Capsule–sphere

TEST(GeometryTest, CapsuleSphereMatchesBruteForce) {
  std::mt19937_64 rng(202);
  std::uniform_real_distribution<double> radius(0.0, 0.7), unit(0.0, 1.0);
  int penetrating = 0;
  double max_error = 0.0;
  GradientTally tally;
  for (int trial = 0; trial < kRandomPairs; ++trial) {
    Capsule capsule{RandomPoint(rng, 1.0), RandomPoint(rng, 1.0), radius(rng)};
    if (unit(rng) < 0.05) capsule.p_WB = capsule.p_WA;  // a sphere
    const Sphere sphere{RandomPoint(rng, 1.0), radius(rng)};
    const DistanceResult r = CapsuleSphereDistance(capsule, sphere);
    const double reference = RefCapsuleSphereDistance(capsule, sphere);
    const double error = std::abs(r.distance - reference);
    max_error = std::max(max_error, error);
    ASSERT_LT(error, kDistanceTolerance) << "trial " << trial;
    if (r.distance < 0.0) ++penetrating;
    ExpectConsistent(r);
    EXPECT_EQ(r.gradient_norm, 1.0);
    ExpectOnCapsuleSurface(capsule, r.p_W1);
    EXPECT_NEAR((r.p_W2 - sphere.p_WC).norm(), sphere.radius, kWitnessTolerance);
    auto distance = [&](const Vector3d& delta) {
      return CapsuleSphereDistance(Translated(capsule, delta), sphere).distance;
    };
    ExpectGradient(distance, r, &tally);
  }
  std::printf("capsule-sphere: %d/%d penetrating, max |error| %.3g, gradient checked %d (skipped %d), max %.3g\n",
              penetrating, kRandomPairs, max_error, tally.checked, tally.skipped, tally.max_error);
  EXPECT_GT(penetrating, kRandomPairs / 5);
  EXPECT_LT(penetrating, kRandomPairs / 2);
  EXPECT_GT(tally.checked, kRandomPairs * 9 / 10);
}

TEST(GeometryTest, CapsuleSphereDegenerateCases) {
  // centre on the axis: any normal perpendicular to the axis; both witnesses on their surfaces
  const Capsule capsule{Vector3d(0, 0, 0), Vector3d(2, 0, 0), 0.5};
  DistanceResult r = CapsuleSphereDistance(capsule, Sphere{Vector3d(1, 0, 0), 0.25});
  EXPECT_NEAR(r.distance, -0.75, 1e-15);
  EXPECT_NEAR(r.n_W.x(), 0.0, 1e-15);
  ExpectConsistent(r);
  ExpectOnCapsuleSurface(capsule, r.p_W1);
  EXPECT_NEAR((r.p_W2 - Vector3d(1, 0, 0)).norm(), 0.25, 1e-15);
  // beyond the end point
  r = CapsuleSphereDistance(capsule, Sphere{Vector3d(4, 0, 0), 0.5});
  EXPECT_NEAR(r.distance, 1.0, 1e-15);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d(-1, 0, 0)));
  // touching: distance exactly 0
  r = CapsuleSphereDistance(capsule, Sphere{Vector3d(0.5, 1, 0), 0.5});
  EXPECT_EQ(r.distance, 0.0);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d(0, -1, 0)));
  EXPECT_TRUE(r.p_W1.isApprox(r.p_W2));
  // zero-length capsule = sphere
  const Capsule ball{Vector3d(0, 0, 0), Vector3d(0, 0, 0), 1.0};
  r = CapsuleSphereDistance(ball, Sphere{Vector3d(3, 0, 0), 1.0});
  EXPECT_NEAR(r.distance, 1.0, 1e-15);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d(-1, 0, 0)));
  // concentric spheres: +z by convention
  r = CapsuleSphereDistance(ball, Sphere{Vector3d(0, 0, 0), 0.5});
  EXPECT_NEAR(r.distance, -1.5, 1e-15);
  EXPECT_EQ(r.n_W, Vector3d::UnitZ());
  ExpectConsistent(r);
}

// ---------------------------------------------------------------------------------------------------------------
// Capsule–capsule

TEST(GeometryTest, CapsuleCapsuleMatchesBruteForce) {
  std::mt19937_64 rng(303);
  std::uniform_real_distribution<double> radius(0.0, 0.4), unit(0.0, 1.0);
  int penetrating = 0;
  double max_error = 0.0;
  GradientTally tally;
  for (int trial = 0; trial < kRandomPairs; ++trial) {
    Capsule c1{RandomPoint(rng, 1.0), RandomPoint(rng, 1.0), radius(rng)};
    Capsule c2{RandomPoint(rng, 1.0), RandomPoint(rng, 1.0), radius(rng)};
    const double kind = unit(rng);
    if (kind < 0.05) {
      c2.p_WB = c2.p_WA + (c1.p_WB - c1.p_WA) * (2.0 * unit(rng) - 1.0);  // parallel
    } else if (kind < 0.1) {
      c1.p_WB = c1.p_WA;  // capsule 1 is a sphere
    } else if (kind < 0.15) {
      c2.p_WB = c2.p_WA;  // capsule 2 is a sphere
    }
    const DistanceResult r = CapsuleCapsuleDistance(c1, c2);
    const double reference = RefSegmentSegmentDistance(c1.p_WA, c1.p_WB, c2.p_WA, c2.p_WB) - c1.radius - c2.radius;
    const double error = std::abs(r.distance - reference);
    max_error = std::max(max_error, error);
    ASSERT_LT(error, kDistanceTolerance) << "trial " << trial;
    if (r.distance < 0.0) ++penetrating;
    ExpectConsistent(r);
    EXPECT_EQ(r.gradient_norm, 1.0);
    ExpectOnCapsuleSurface(c1, r.p_W1);
    ExpectOnCapsuleSurface(c2, r.p_W2);
    auto distance = [&](const Vector3d& delta) { return CapsuleCapsuleDistance(Translated(c1, delta), c2).distance; };
    ExpectGradient(distance, r, &tally);
  }
  std::printf("capsule-capsule: %d/%d penetrating, max |error| %.3g, gradient checked %d (skipped %d), max %.3g\n",
              penetrating, kRandomPairs, max_error, tally.checked, tally.skipped, tally.max_error);
  EXPECT_GT(penetrating, kRandomPairs / 5);
  EXPECT_LT(penetrating, kRandomPairs / 2);
  EXPECT_GT(tally.checked, kRandomPairs * 9 / 10);
}

TEST(GeometryTest, CapsuleCapsuleDegenerateCases) {
  const Capsule c1{Vector3d(0, 0, 0), Vector3d(2, 0, 0), 0.25};
  // parallel, overlapping: normal −y (from capsule 2 to capsule 1)
  DistanceResult r = CapsuleCapsuleDistance(c1, Capsule{Vector3d(1, 1, 0), Vector3d(3, 1, 0), 0.25});
  EXPECT_NEAR(r.distance, 0.5, 1e-15);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d(0, -1, 0)));
  // parallel, not overlapping
  r = CapsuleCapsuleDistance(c1, Capsule{Vector3d(3, 1, 0), Vector3d(5, 1, 0), 0.25});
  EXPECT_NEAR(r.distance, std::sqrt(2.0) - 0.5, 1e-15);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d(-1, -1, 0).normalized()));
  // collinear, overlapping: normal perpendicular to the common axis, witnesses on both surfaces
  Capsule c2{Vector3d(1, 0, 0), Vector3d(3, 0, 0), 0.1};
  r = CapsuleCapsuleDistance(c1, c2);
  EXPECT_NEAR(r.distance, -0.35, 1e-15);
  EXPECT_NEAR(r.n_W.x(), 0.0, 1e-15);
  ExpectConsistent(r);
  ExpectOnCapsuleSurface(c1, r.p_W1);
  ExpectOnCapsuleSurface(c2, r.p_W2);
  // axes crossing at right angles: normal ±z = d1 × d2 normalised
  c2 = Capsule{Vector3d(1, -1, 0), Vector3d(1, 1, 0), 0.1};
  r = CapsuleCapsuleDistance(c1, c2);
  EXPECT_NEAR(r.distance, -0.35, 1e-15);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d::UnitZ()));
  ExpectOnCapsuleSurface(c1, r.p_W1);
  ExpectOnCapsuleSurface(c2, r.p_W2);
  // touching across: axes 0.5 apart along z, radii 0.25 each
  r = CapsuleCapsuleDistance(c1, Capsule{Vector3d(1, -1, 0.5), Vector3d(1, 1, 0.5), 0.25});
  EXPECT_EQ(r.distance, 0.0);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d(0, 0, -1)));
  // both zero length (two spheres), and one zero-length capsule lying on the other's axis
  r = CapsuleCapsuleDistance(Capsule{Vector3d(0, 0, 0), Vector3d(0, 0, 0), 1.0},
                             Capsule{Vector3d(0, 3, 4), Vector3d(0, 3, 4), 1.0});
  EXPECT_NEAR(r.distance, 3.0, 1e-15);
  EXPECT_TRUE(r.n_W.isApprox(Vector3d(0, -0.6, -0.8)));
  c2 = Capsule{Vector3d(0.5, 0, 0), Vector3d(0.5, 0, 0), 0.1};
  r = CapsuleCapsuleDistance(c1, c2);
  EXPECT_NEAR(r.distance, -0.35, 1e-15);
  EXPECT_NEAR(r.n_W.x(), 0.0, 1e-15);
  ExpectOnCapsuleSurface(c1, r.p_W1);
  ExpectOnCapsuleSurface(c2, r.p_W2);
  r = CapsuleCapsuleDistance(c2, c1);
  EXPECT_NEAR(r.n_W.x(), 0.0, 1e-15);
  ExpectOnCapsuleSurface(c2, r.p_W1);
  ExpectOnCapsuleSurface(c1, r.p_W2);
}

// ---------------------------------------------------------------------------------------------------------------
// Capsule–box

// checks a capsule–box result against the reference, the conventions and finite differences
void CheckCapsuleBox(const Capsule& capsule, const Box& box, GradientTally* tally, double* max_error) {
  const DistanceResult r = CapsuleBoxDistance(capsule, box);
  const double reference = RefCapsuleBoxDistance(capsule, box);
  const double error = std::abs(r.distance - reference);
  *max_error = std::max(*max_error, error);
  ASSERT_LT(error, kDistanceTolerance) << "got " << r.distance << " expected " << reference << " capsule "
                                       << capsule.p_WA.transpose() << " / " << capsule.p_WB.transpose();
  ExpectConsistent(r);
  ExpectOnCapsuleSurface(capsule, r.p_W1);
  const double sdf2 = RefBoxSignedDistance(box, r.p_W2);
  if (r.gradient_norm > 1.0 - 1e-12) {
    EXPECT_NEAR(sdf2, 0.0, kWitnessTolerance);
  } else {
    EXPECT_LE(sdf2, kWitnessTolerance);  // documented: inside the box when the gradient is a blend of face normals
  }
  auto distance = [&](const Vector3d& delta) { return CapsuleBoxDistance(Translated(capsule, delta), box).distance; };
  ExpectGradient(distance, r, tally);
}

TEST(GeometryTest, CapsuleBoxMatchesBruteForce) {
  std::mt19937_64 rng(404);
  std::uniform_real_distribution<double> half(0.05, 0.6), radius(0.0, 0.2), unit(0.0, 1.0);
  int penetrating = 0, blended = 0, through = 0;
  double max_error = 0.0;
  GradientTally tally;
  for (int trial = 0; trial < kRandomPairs; ++trial) {
    Box box;
    box.X_WB.linear() = RandomRotation(rng).toRotationMatrix();
    box.X_WB.translation() = RandomPoint(rng, 0.3);
    box.half_size = Vector3d(half(rng), half(rng), half(rng));
    Capsule capsule{RandomPoint(rng, 1.2), RandomPoint(rng, 1.2), radius(rng)};
    if (unit(rng) < 0.05) capsule.p_WB = capsule.p_WA;  // a sphere
    SCOPED_TRACE(trial);
    CheckCapsuleBox(capsule, box, &tally, &max_error);
    if (HasFatalFailure()) return;
    const DistanceResult r = CapsuleBoxDistance(capsule, box);
    if (r.distance < 0.0) ++penetrating;
    if (r.gradient_norm < 1.0) ++blended;
    // the axis crosses the box while both end points are outside it: what an edges-and-end-points check misses
    if (RefBoxSignedDistance(box, capsule.p_WA) > 0.0 && RefBoxSignedDistance(box, capsule.p_WB) > 0.0 &&
        r.distance + capsule.radius < 0.0) {
      ++through;
    }
  }
  std::printf("capsule-box: %d/%d penetrating (%d with blended gradient, %d axes through the box with both ends "
              "outside), max |error| %.3g, gradient checked %d (skipped %d), max %.3g\n",
              penetrating, kRandomPairs, blended, through, max_error, tally.checked, tally.skipped, tally.max_error);
  EXPECT_GT(through, kRandomPairs / 20);
  EXPECT_GT(penetrating, kRandomPairs / 5);
  EXPECT_LT(penetrating, kRandomPairs / 2);
  EXPECT_GT(tally.checked, kRandomPairs * 9 / 10);
}

// capsules whose axes are (nearly) parallel to box axes or faces, with end points on face planes: the flat and
// tied configurations where a piecewise analysis is most fragile
TEST(GeometryTest, CapsuleBoxNearlyAxisAlignedMatchesBruteForce) {
  std::mt19937_64 rng(505);
  std::uniform_real_distribution<double> half(0.05, 0.6), radius(0.0, 0.15), unit(0.0, 1.0), coordinate(-1.2, 1.2);
  std::uniform_int_distribution<int> axis(0, 2), snap(0, 3);
  const double perturbations[] = {0.0, 1e-15, 1e-12, 1e-9};
  double max_error = 0.0;
  GradientTally tally;
  for (int trial = 0; trial < kRandomPairs; ++trial) {
    Box box;
    box.X_WB = RandomPose(rng);
    box.half_size = Vector3d(half(rng), half(rng), half(rng));
    // build the axis in the box frame: two coordinates shared by both end points (parallel to a box axis) or one
    // shared coordinate (parallel to a face); coordinates sometimes snapped to ±h or 0
    Vector3d a_B(coordinate(rng), coordinate(rng), coordinate(rng));
    Vector3d e_B(coordinate(rng), coordinate(rng), coordinate(rng));
    const int along = axis(rng);
    const bool parallel_to_axis = unit(rng) < 0.5;
    for (int i = 0; i < 3; ++i) {
      if (i == along) continue;
      if (parallel_to_axis || i == (along + 1) % 3) e_B[i] = a_B[i];
    }
    for (int i = 0; i < 3; ++i) {
      const int s = snap(rng);
      const double value = s == 0 ? box.half_size[i] : s == 1 ? -box.half_size[i] : s == 2 ? 0.0 : a_B[i];
      if (e_B[i] == a_B[i]) e_B[i] = value;
      a_B[i] = value;
    }
    const double eps = perturbations[trial % 4];
    e_B += RandomPoint(rng, eps);
    const Capsule capsule{box.X_WB * a_B, box.X_WB * e_B, unit(rng) < 0.2 ? 0.0 : radius(rng)};
    SCOPED_TRACE(trial);
    CheckCapsuleBox(capsule, box, &tally, &max_error);
    if (HasFatalFailure()) return;
  }
  std::printf("capsule-box axis-aligned: max |error| %.3g, gradient checked %d (skipped %d), max %.3g\n", max_error,
              tally.checked, tally.skipped, tally.max_error);
  EXPECT_GT(tally.checked, kRandomPairs / 2);
}

// a hand-built capsule–box case in the box frame with its exact answer
struct BoxCase {
  const char* name;
  Vector3d half_size;
  Vector3d p_BA, p_BE;  // capsule end points in the box frame
  double radius;
  double distance;       // exact signed distance
  Vector3d n_B;          // expected normal in the box frame (zero: not checked)
  double gradient_norm;  // expected |gradient|
};

TEST(GeometryTest, CapsuleBoxDegenerateCases) {
  const Vector3d ones(1, 1, 1), zero = Vector3d::Zero();
  const BoxCase cases[] = {
      // both ends outside, axis through two opposite faces: a check of end points and box edges alone says > 0
      {"through faces", ones, {0.5, 0.3, -2}, {0.5, 0.3, 2}, 0.1, -0.6, {1, 0, 0}, 1.0},
      {"through one face", ones, {0.1, 0.2, 0.8}, {0.1, 0.2, 1.5}, 0.05, -0.25, {0, 0, 1}, 1.0},
      // oblique through x and z faces: deepest at x = −0.25 equidistant from the −x and +z faces
      {"oblique medial", ones, {-2, 0, -1.5}, {2, 0, 2.5}, 0.1, -0.85, Vector3d(-1, 0, 1).normalized(), std::sqrt(0.5)},
      // through a thin slab perpendicular to it: flat distance, normal → next-nearest face (+y)
      {"slab mid-plane", {1, 1, 0.2}, {0.1, 0.3, -1}, {0.1, 0.3, 1}, 0.05, -0.25, {0, 1, 0}, 0.0},
      {"fully inside, parallel", {1, 1, 0.5}, {-0.2, 0.1, 0.3}, {0.4, 0.1, 0.3}, 0.1, -0.3, {0, 0, 1}, 1.0},
      {"fully inside, oblique", ones, {0.1, 0.2, 0.3}, {0.5, 0.2, 0.6}, 0.1, -0.8, {0, 0, 1}, 1.0},
      {"touching parallel to a face", ones, {-0.5, 0, 1.25}, {0.5, 0, 1.25}, 0.25, 0.0, {0, 0, 1}, 1.0},
      {"parallel above a face", ones, {-0.5, 0, 2}, {0.5, 0, 2}, 0.25, 0.75, {0, 0, 1}, 1.0},
      {"parallel above a face, overhanging", ones, {-3, 0.2, 2}, {3, 0.2, 2}, 0.25, 0.75, {0, 0, 1}, 1.0},
      {"axis touching a vertex", ones, {1, 1, 1}, {2, 3, 4}, 0.0, 0.0, zero, 1.0},
      {"axis grazing an edge", ones, {-2, 1, 1}, {2, 1, 1}, 0.0, 0.0, zero, 1.0},
      {"sphere outside a corner", ones, {1.3, 1.4, -1.2}, {1.3, 1.4, -1.2}, 0.1, std::sqrt(0.29) - 0.1,
       Vector3d(0.3, 0.4, -0.2).normalized(), 1.0},
      {"sphere centre inside", ones, {0.2, -0.7, 0.1}, {0.2, -0.7, 0.1}, 0.5, -0.8, {0, -1, 0}, 1.0},
      {"axis past an edge", ones, {2, 2, -3}, {2, 2, 3}, 0.1, std::sqrt(2.0) - 0.1, Vector3d(1, 1, 0).normalized(),
       1.0},
  };
  std::mt19937_64 rng(606);
  for (const BoxCase& c : cases) {
    for (int pose = 0; pose < 4; ++pose) {
      SCOPED_TRACE(std::string(c.name) + ", pose " + std::to_string(pose));
      Box box;
      box.half_size = c.half_size;
      if (pose > 0) box.X_WB = RandomPose(rng);
      const Capsule capsule{box.X_WB * c.p_BA, box.X_WB * c.p_BE, c.radius};
      const DistanceResult r = CapsuleBoxDistance(capsule, box);
      EXPECT_NEAR(r.distance, c.distance, pose == 0 ? 1e-15 : 1e-13);
      EXPECT_NEAR(r.gradient_norm, c.gradient_norm, 1e-12);
      if (c.n_B != zero) {
        EXPECT_LT((box.X_WB.linear().transpose() * r.n_W - c.n_B).norm(), 1e-12);
      }
      ExpectConsistent(r);
      ExpectOnCapsuleSurface(capsule, r.p_W1);
      EXPECT_NEAR(r.distance, RefCapsuleBoxDistance(capsule, box), kDistanceTolerance);
    }
  }
}

}  // namespace
}  // namespace rmpmarl::math
