// Capsule covers: every point of the geometry inside (random surface samples the cover never saw), the excess
// against an exact reference, concave shapes split, a thin plate split across its width, spheres covered whole, and
// input errors.
#include "rmpmarl/setup/capsule_cover.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "rmpmarl/common/error.h"

namespace rmpmarl::setup {

namespace {

// area-weighted random points on the triangles (an independent sampler: the cover samples on a grid).
std::vector<Eigen::Vector3d> RandomSurfacePoints(const CoverGeometry& g, int n, std::uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<double> area;
  for (const Eigen::Vector3i& t : g.triangles) {
    area.push_back(0.5 * (g.vertices[t[1]] - g.vertices[t[0]]).cross(g.vertices[t[2]] - g.vertices[t[0]]).norm());
  }
  std::discrete_distribution<size_t> pick(area.begin(), area.end());
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3i& t = g.triangles[pick(rng)];
    double a = u(rng), b = u(rng);
    if (a + b > 1.0) {
      a = 1.0 - a;
      b = 1.0 - b;
    }
    p.push_back(g.vertices[t[0]] + a * (g.vertices[t[1]] - g.vertices[t[0]]) + b * (g.vertices[t[2]] - g.vertices[t[0]]));
  }
  return p;
}

double FarthestOutside(const std::vector<math::Capsule>& capsules, const std::vector<Eigen::Vector3d>& points) {
  double worst = -std::numeric_limits<double>::infinity();
  for (const Eigen::Vector3d& p : points) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const math::Capsule& c : capsules) nearest = std::min(nearest, CapsuleSignedDistance(c, p));
    worst = std::max(worst, nearest);
  }
  return worst;
}

// exact distance from p to the surface of an axis-aligned box of half sizes h centred at the origin.
double BoxSurfaceDistance(const Eigen::Vector3d& h, const Eigen::Vector3d& p) {
  const Eigen::Vector3d q = p.cwiseAbs() - h;
  const double outside = q.cwiseMax(0.0).norm();
  return outside > 0.0 ? outside : -q.maxCoeff();
}

// the triangulated surface of a capsule of `radius` around the z axis from −half_length to half_length (latitude
// rings on two hemispheres and the cylinder between).
CoverGeometry CapsuleSurface(double radius, double half_length) {
  CoverGeometry g;
  constexpr int kAround = 48, kRings = 12;  // rings per hemisphere
  std::vector<std::vector<int>> rings;
  for (int side = 0; side < 2; ++side) {
    for (int i = 0; i <= kRings; ++i) {
      const double polar = (side == 0 ? i : kRings - i) * (M_PI / 2) / kRings;  // 0 at the pole
      const double z = (side == 0 ? -1 : 1) * (half_length + radius * std::cos(polar));
      std::vector<int> ring;
      for (int j = 0; j < kAround; ++j) {
        const double a = 2.0 * M_PI * j / kAround;
        ring.push_back(static_cast<int>(g.vertices.size()));
        g.vertices.emplace_back(radius * std::sin(polar) * std::cos(a), radius * std::sin(polar) * std::sin(a), z);
      }
      rings.push_back(ring);
    }
  }
  for (size_t r = 0; r + 1 < rings.size(); ++r) {
    for (int j = 0; j < kAround; ++j) {
      const int a = rings[r][j], b = rings[r][(j + 1) % kAround], c = rings[r + 1][j], d = rings[r + 1][(j + 1) % kAround];
      g.triangles.emplace_back(a, b, d);
      g.triangles.emplace_back(a, d, c);
    }
  }
  return g;
}

TEST(CapsuleCover, AnLShapedMeshIsSplitAndEveryRandomSurfacePointIsInside) {
  CoverGeometry g;
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.translation() = Eigen::Vector3d(0.2, 0, 0);
  AppendBoxSurface(X, Eigen::Vector3d(0.4, 0.06, 0.06), &g);
  X.translation() = Eigen::Vector3d(0, 0, 0.15);
  AppendBoxSurface(X, Eigen::Vector3d(0.06, 0.06, 0.3), &g);
  // a capsule around a square bar sticks out by at least its radius beyond the bar's flat end (the cap's tip) and
  // the radius is at least the section's half diagonal, 42 mm: a tolerance of 50 mm is reachable, 20 mm is not
  CapsuleCoverOptions options;
  options.tolerance = 0.05;
  const CapsuleCover cover = FitCapsuleCover(g, options);
  EXPECT_GE(cover.capsules.size(), 2u);
  EXPECT_TRUE(cover.within_tolerance) << cover.max_excess;
  EXPECT_LE(cover.max_outside, 1e-9);
  EXPECT_LE(FarthestOutside(cover.capsules, RandomSurfacePoints(g, 20000, 7)), 1e-9);
  // one capsule over the L sticks out far more
  std::vector<Ball> corners;
  for (const Eigen::Vector3d& v : g.vertices) corners.push_back({v, 0.0});
  EXPECT_GT(MeasureCapsuleCover(g, {FitCapsuleToBalls(corners)}).max_excess, 0.1);
}

// the largest `distance` (an exact distance to the covered shape) over random points of the capsules' surfaces that
// lie outside the other capsules: how far the cover sticks out
template <typename Distance>
double ExactExcessOutside(const std::vector<math::Capsule>& capsules, Distance&& distance, std::uint32_t seed,
                          int samples_per_capsule = 4000) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> normal;
  std::uniform_real_distribution<double> u(0.0, 1.0);
  double worst = 0.0;
  for (size_t k = 0; k < capsules.size(); ++k) {
    const math::Capsule& c = capsules[k];
    const Eigen::Vector3d ab = c.p_WB - c.p_WA;
    const Eigen::Vector3d axis = ab.norm() > 1e-12 ? Eigen::Vector3d(ab.normalized()) : Eigen::Vector3d::UnitZ();
    for (int i = 0; i < samples_per_capsule; ++i) {
      // uniform on the surface: the cylinder (area 2πrL) or a hemisphere cap (area 2πr² each), then a direction
      Eigen::Vector3d dir = Eigen::Vector3d(normal(rng), normal(rng), normal(rng)).normalized();
      Eigen::Vector3d p;
      if (u(rng) * (ab.norm() + 2.0 * c.radius) < ab.norm()) {
        dir = (dir - dir.dot(axis) * axis).normalized();
        p = c.p_WA + u(rng) * ab + c.radius * dir;
      } else {
        p = (dir.dot(axis) >= 0.0 ? c.p_WB : c.p_WA) + c.radius * dir;
      }
      bool inside_other = false;
      for (size_t o = 0; o < capsules.size() && !inside_other; ++o) {
        inside_other = o != k && CapsuleSignedDistance(capsules[o], p) < -1e-9;
      }
      if (!inside_other) worst = std::max(worst, distance(p));
    }
  }
  return worst;
}

TEST(CapsuleCover, AThinPlateIsSplitAcrossItsWidthAndItsExcessMatchesAnExactReference) {
  // 20 x 10 x 1 cm: one capsule along x needs a radius of ~5 cm and sticks out ~4.5 cm above and below
  const Eigen::Vector3d size(0.2, 0.1, 0.01), h = 0.5 * size;
  CoverGeometry g;
  AppendBoxSurface(Eigen::Isometry3d::Identity(), size, &g);
  CapsuleCoverOptions options;
  options.tolerance = 0.012;
  options.max_capsules = 12;
  const CapsuleCover cover = FitCapsuleCover(g, options);
  EXPECT_GE(cover.capsules.size(), 4u);
  EXPECT_TRUE(cover.within_tolerance) << cover.max_excess;
  EXPECT_LE(FarthestOutside(cover.capsules, RandomSurfacePoints(g, 20000, 11)), 1e-9);
  // the excess against the exact box distance on random points of each capsule's surface outside the others
  const double worst = ExactExcessOutside(
      cover.capsules, [&](const Eigen::Vector3d& p) { return std::abs(BoxSurfaceDistance(h, p)); }, 3, 40000);
  // the cover measures on surface samples 2 mm apart: at most ~1.5 mm below the exact value
  EXPECT_NEAR(cover.max_excess, worst, 0.002);
  EXPECT_LE(worst, options.tolerance + 0.002);
}

TEST(CapsuleCover, ASphereAndARoundedBarAreTheirOwnCapsulesAndAFlatEndedBarIsCoveredBetterThanByOne) {
  CoverGeometry sphere;
  sphere.balls.push_back({Eigen::Vector3d(0.1, 0.2, 0.3), 0.05});
  const CapsuleCover s = FitCapsuleCover(sphere);
  ASSERT_EQ(s.capsules.size(), 1u);
  EXPECT_NEAR(s.capsules[0].radius, 0.05, 1e-6);
  EXPECT_LE(s.max_excess, s.sample_spacing);  // on its own surface, to the samples' spacing
  // a bar with rounded ends (a capsule's own triangulated surface) stays one capsule, its own
  const CoverGeometry bar = CapsuleSurface(0.04, 0.2);
  const CapsuleCover b = FitCapsuleCover(bar);
  ASSERT_EQ(b.capsules.size(), 1u);
  EXPECT_LE(b.max_outside, 1e-9);
  EXPECT_NEAR(b.capsules[0].radius, 0.04, 0.0005);
  EXPECT_LE(b.max_excess, 0.003);  // the triangulation's chords and the samples' spacing
  // a flat-ended bar: one capsule's caps stick out ~ its radius beyond the flat ends; balls at the ends do better
  CoverGeometry flat;
  AppendCylinderSurface(Eigen::Isometry3d::Identity(), 0.04, 0.4, 32, true, &flat);
  const CapsuleCover f = FitCapsuleCover(flat);
  EXPECT_LE(f.max_outside, 1e-9);
  std::vector<Ball> corners;
  for (const Eigen::Vector3d& v : flat.vertices) corners.push_back({v, 0.0});
  EXPECT_LT(f.max_excess, MeasureCapsuleCover(flat, {FitCapsuleToBalls(corners)}).max_excess - 0.005);
}

TEST(CapsuleCover, MaxCapsulesBoundsTheCoverAndSaysWhenTheToleranceIsNotMet) {
  CoverGeometry g;
  AppendBoxSurface(Eigen::Isometry3d::Identity(), Eigen::Vector3d(0.3, 0.3, 0.01), &g);
  CapsuleCoverOptions options;
  options.tolerance = 0.002;
  options.max_capsules = 3;
  const CapsuleCover cover = FitCapsuleCover(g, options);
  EXPECT_LE(cover.capsules.size(), 3u);
  EXPECT_FALSE(cover.within_tolerance);
  EXPECT_GT(cover.max_excess, options.tolerance);
  EXPECT_LE(cover.max_outside, 1e-9);
}

TEST(CapsuleCover, AnInscribedCoverSticksOutOfABoxNoMoreThanTheToleranceByAnExactReference) {
  // a 20 x 10 x 6 cm block: its 90° edges and corners are what a round capsule follows worst
  const Eigen::Vector3d size(0.2, 0.1, 0.06), h = 0.5 * size;
  CoverGeometry g;
  AppendBoxSurface(Eigen::Isometry3d::Identity(), size, &g);
  CapsuleCoverOptions options;
  options.method = CoverMethod::kInscribed;
  options.tolerance = 0.008;
  options.max_capsules = 64;
  const CapsuleCover cover = FitCapsuleCover(g, options);
  EXPECT_TRUE(cover.within_tolerance) << cover.max_excess << " " << cover.max_outside;
  EXPECT_FALSE(cover.reached_max_capsules);
  // every random surface point inside, up to the gaps between the fit's 2 mm samples (far below 0.5 mm)
  EXPECT_LE(FarthestOutside(cover.capsules, RandomSurfacePoints(g, 20000, 5)), 2e-4);
  // no capsule sticks out of the block by more than the tolerance (the fit's samples make it ~0.2 mm coarse)
  auto outside_box = [&](const Eigen::Vector3d& p) {
    return (p.cwiseAbs() - h).maxCoeff() > 0.0 ? BoxSurfaceDistance(h, p) : 0.0;
  };
  const double outside = ExactExcessOutside(cover.capsules, outside_box, 9);
  EXPECT_LE(outside, options.tolerance + 0.0005);
  EXPECT_NEAR(cover.max_excess, outside, 0.0015);
  // the plane cuts at the same tolerance and limit stick out much farther: their capsules hold the block's corners
  CapsuleCoverOptions cuts = options;
  cuts.method = CoverMethod::kCuts;
  const CapsuleCover c = FitCapsuleCover(g, cuts);
  EXPECT_GT(ExactExcessOutside(c.capsules, outside_box, 9), 2.0 * options.tolerance);
}

TEST(CapsuleCover, TheSolidTestReadsOverlappingInsideOutAndHoledMeshesAsABruteForceReferenceDoes) {
  // a cross of two overlapping bars: ray parity alone reads their overlap as outside
  const Eigen::Vector3d h1(0.08, 0.025, 0.025), h2(0.025, 0.08, 0.025);
  CoverGeometry cross;
  AppendBoxSurface(Eigen::Isometry3d::Identity(), 2.0 * h1, &cross);
  AppendBoxSurface(Eigen::Isometry3d::Identity(), 2.0 * h2, &cross);
  CoverGeometry flipped = cross;
  for (Eigen::Vector3i& t : flipped.triangles) std::swap(t[1], t[2]);
  CoverGeometry holed = cross;  // one triangle of the first bar's top face missing
  for (size_t t = 0; t < holed.triangles.size(); ++t) {
    const Eigen::Vector3d c = (holed.vertices[holed.triangles[t][0]] + holed.vertices[holed.triangles[t][1]] +
                               holed.vertices[holed.triangles[t][2]]) / 3.0;
    if (std::abs(c.z() - 0.025) < 1e-9 && std::abs(c.x()) > 0.03) {
      holed.triangles.erase(holed.triangles.begin() + static_cast<long>(t));
      break;
    }
  }
  holed.balls.push_back({Eigen::Vector3d(0.0, 0.0, 0.1), 0.02});
  const SolidTest a(cross), b(flipped), c(holed);
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-0.1, 0.13);
  int inside = 0, disagree_holed = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Vector3d p(u(rng), u(rng), u(rng));
    const bool truth = ((p.cwiseAbs() - h1).maxCoeff() < 0.0) || ((p.cwiseAbs() - h2).maxCoeff() < 0.0);
    inside += truth;
    ASSERT_EQ(a.Inside(p), truth) << p.transpose();
    ASSERT_EQ(b.Inside(p), truth) << p.transpose();
    const bool in_ball = (p - Eigen::Vector3d(0.0, 0.0, 0.1)).norm() < 0.02;
    disagree_holed += c.Inside(p) != (truth || in_ball);
  }
  EXPECT_GT(inside, 200);
  // a hole misleads one ray of three at most, except where two rays pass through it: none of these points
  EXPECT_EQ(disagree_holed, 0);
}

TEST(CapsuleCover, AnInscribedCoverNeedingMoreCapsulesThanAllowedFallsBackToCutsAndSaysSo) {
  CoverGeometry g;
  AppendBoxSurface(Eigen::Isometry3d::Identity(), Eigen::Vector3d(0.3, 0.3, 0.02), &g);
  CapsuleCoverOptions options;
  options.method = CoverMethod::kInscribed;
  options.tolerance = 0.002;
  options.max_capsules = 4;
  const CapsuleCover cover = FitCapsuleCover(g, options);
  EXPECT_LE(cover.capsules.size(), 4u);
  EXPECT_FALSE(cover.within_tolerance);
  EXPECT_TRUE(cover.reached_max_capsules);
  EXPECT_LE(cover.max_outside, 1e-9);
  // a sphere is its own capsule whatever the method
  CoverGeometry sphere;
  sphere.balls.push_back({Eigen::Vector3d(0.1, 0.2, 0.3), 0.05});
  const CapsuleCover s = FitCapsuleCover(sphere, options);
  ASSERT_EQ(s.capsules.size(), 1u);
  EXPECT_EQ(s.capsules[0].radius, 0.05);
}

TEST(CapsuleCover, RejectsBadInputNamingIt) {
  EXPECT_THROW(FitCapsuleCover(CoverGeometry{}), InputError);
  CoverGeometry g;
  AppendBoxSurface(Eigen::Isometry3d::Identity(), Eigen::Vector3d(0.1, 0.1, 0.1), &g);
  CapsuleCoverOptions bad;
  bad.tolerance = 0.0;
  try {
    FitCapsuleCover(g, bad);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("tolerance"), std::string::npos) << e.what();
  }
  CoverGeometry broken = g;
  broken.triangles.emplace_back(0, 1, 99);
  EXPECT_THROW(FitCapsuleCover(broken), InputError);
  CoverGeometry nan = g;
  nan.vertices[0].x() = NAN;
  EXPECT_THROW(FitCapsuleCover(nan), InputError);
}

}  // namespace
}  // namespace rmpmarl::setup
