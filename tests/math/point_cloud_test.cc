// The point-cloud index against exhaustive search, and the capsule–cloud distance against the capsule–sphere one.
#include "rmpmarl/math/point_cloud.h"

#include <gtest/gtest.h>

#include <random>

namespace rmpmarl::math {
namespace {

Eigen::Matrix3Xd UniformCloud(int n, std::mt19937_64& rng, double half = 1.0) {
  std::uniform_real_distribution<double> u(-half, half);
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) p.col(i) = Eigen::Vector3d(u(rng), u(rng), u(rng));
  return p;
}

void ExpectSame(const SegmentNearestPoint& a, const SegmentNearestPoint& b) {
  EXPECT_EQ(a.index, b.index);
  EXPECT_NEAR(a.distance, b.distance, 1e-9);
  EXPECT_LT((a.p_Wpoint - b.p_Wpoint).norm(), 1e-9);
  EXPECT_LT((a.p_Wsegment - b.p_Wsegment).norm(), 1e-9);
}

TEST(PointCloudIndexTest, EqualsBruteForceOnRandomSegments) {
  std::mt19937_64 rng(1);
  for (int n : {1, 2, 15, 16, 17, 100, 2000, 20000}) {
    const Eigen::Matrix3Xd p = UniformCloud(n, rng);
    const PointCloudIndex index(p);
    ASSERT_EQ(index.size(), n);
    std::uniform_real_distribution<double> u(-1.5, 1.5);
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector3d a(u(rng), u(rng), u(rng));
      // long, short and zero-length segments
      const Eigen::Vector3d b = k % 3 == 0 ? a : a + Eigen::Vector3d(u(rng), u(rng), u(rng)) * (k % 3 == 1 ? 0.1 : 1.0);
      ExpectSame(index.NearestToSegment(a, b), NearestToSegmentBruteForce(p, a, b));
    }
  }
}

TEST(PointCloudIndexTest, StructuredCloudsWithDuplicatesAndTiesGoToTheLowerIndex) {
  // a grid (many equal coordinates and exact distance ties) with every point duplicated
  Eigen::Matrix3Xd p(3, 2 * 1000);
  int k = 0;
  for (int x = 0; x < 10; ++x)
    for (int y = 0; y < 10; ++y)
      for (int z = 0; z < 10; ++z) p.col(k++) = Eigen::Vector3d(0.1 * x, 0.1 * y, 0.1 * z);
  p.rightCols(1000) = p.leftCols(1000);
  const PointCloudIndex index(p);
  std::mt19937_64 rng(2);
  std::uniform_real_distribution<double> u(-0.3, 1.2);
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d a(u(rng), u(rng), u(rng)), b(u(rng), u(rng), u(rng));
    const SegmentNearestPoint r = index.NearestToSegment(a, b);
    ExpectSame(r, NearestToSegmentBruteForce(p, a, b));
    EXPECT_LT(r.index, 1000) << "a duplicate's lower index wins";
  }
  // a query point exactly between two grid points: a tie the lower index wins
  const SegmentNearestPoint mid = index.NearestToSegment(Eigen::Vector3d(0.05, 0, 0), Eigen::Vector3d(0.05, 0, 0));
  EXPECT_EQ(mid.index, 0);
}

TEST(PointCloudIndexTest, EmptyAndRebuiltIndex) {
  PointCloudIndex index;
  EXPECT_TRUE(index.empty());
  EXPECT_EQ(index.NearestToSegment(Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX()).index, -1);
  std::mt19937_64 rng(3);
  const Eigen::Matrix3Xd big = UniformCloud(5000, rng), small = UniformCloud(300, rng, 0.2);
  index.Build(big);
  index.Build(small);  // a rebuild forgets the old points
  EXPECT_EQ(index.size(), 300);
  EXPECT_TRUE(index.bounds().contains(small.col(7)));
  EXPECT_LT(index.bounds().max().maxCoeff(), 0.2 + 1e-12);
  const Eigen::Vector3d a(0.9, 0.9, 0.9);
  ExpectSame(index.NearestToSegment(a, -a), NearestToSegmentBruteForce(small, a, -a));
  for (int i : {0, 150, 299}) EXPECT_EQ(index.point(i), Eigen::Vector3d(small.col(i)));
  index.Build(Eigen::Matrix3Xd(3, 0));
  EXPECT_TRUE(index.empty());
}

TEST(PointCloudIndexTest, CapsuleDistanceMatchesTheSphereDistanceOfTheNearestPoint) {
  std::mt19937_64 rng(4);
  const Eigen::Matrix3Xd p = UniformCloud(3000, rng);
  const PointCloudIndex index(p);
  std::uniform_real_distribution<double> u(-1.0, 1.0), r(0.0, 0.1);
  for (int k = 0; k < 300; ++k) {
    const Capsule capsule{Eigen::Vector3d(u(rng), u(rng), u(rng)), Eigen::Vector3d(u(rng), u(rng), u(rng)), r(rng)};
    const double point_radius = k % 2 ? 0.0 : 0.01;
    const DistanceResult d = CapsulePointCloudDistance(capsule, index, point_radius);
    // the nearest point by brute force over every point as a sphere (an independent distance routine)
    double best = std::numeric_limits<double>::infinity();
    DistanceResult ref;
    for (int i = 0; i < p.cols(); ++i) {
      const DistanceResult s = CapsuleSphereDistance(capsule, Sphere{p.col(i), point_radius});
      if (s.distance < best) {
        best = s.distance;
        ref = s;
      }
    }
    EXPECT_NEAR(d.distance, ref.distance, 1e-9);
    EXPECT_LT((d.p_W1 - ref.p_W1).norm(), 1e-9);
    EXPECT_LT((d.p_W2 - ref.p_W2).norm(), 1e-9);
    EXPECT_LT((d.n_W - ref.n_W).norm(), 1e-9);
    // the conventions of geometry.h: p_W1 ≈ p_W2 + distance n_W
    EXPECT_LT((d.p_W1 - (d.p_W2 + d.distance * d.n_W)).norm(), 1e-9);
  }
}

TEST(PointCloudIndexTest, PointOnTheAxisGetsAPerpendicularNormalAndPenetrationDepth) {
  Eigen::Matrix3Xd p(3, 1);
  p.col(0) = Eigen::Vector3d(0.5, 0, 0);
  const PointCloudIndex index(p);
  const Capsule capsule{Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.05};
  const DistanceResult d = CapsulePointCloudDistance(capsule, index, 0.01);
  EXPECT_DOUBLE_EQ(d.distance, -0.06);
  EXPECT_NEAR(d.n_W.norm(), 1.0, 1e-12);
  EXPECT_NEAR(d.n_W.dot(Eigen::Vector3d::UnitX()), 0.0, 1e-12);
}

}  // namespace
}  // namespace rmpmarl::math
