// The warning sensor against a brute-force reference: every capsule against every obstacle and every self pair the
// robot checks, each distance computed exactly with the same distance functions (so this checks the sensor's broad
// phase, its bounding spheres, which may skip only pairs beyond the margin, and its bookkeeping; the distance
// functions have their own tests against independent references in tests/math). Scenes of long, flat boxes (boards
// and walls, whose bounding spheres reach far beyond them), cubes, spheres and cylinders around the arm.
#include "rmpmarl/control/warning.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <tuple>
#include <vector>

#include "../kinematics/test_robots.h"
#include "rmpmarl/kinematics/forward_kinematics.h"

namespace rmpmarl::control {
namespace {

using Key = std::tuple<int, int, int, int>;  // capsule, partner kind, partner index, partner capsule

Key KeyOf(const WarningContact& c) {
  return {c.capsule, static_cast<int>(c.other_kind), c.other_index, c.other_capsule};
}

rmp::Scene RandomScene(std::mt19937_64& rng) {
  std::uniform_real_distribution<double> u(-1.0, 1.0), thin(0.005, 0.03), long_side(0.2, 0.8), size(0.03, 0.15);
  rmp::Scene scene;
  for (int j = 0; j < 8; ++j) {
    const Eigen::Vector3d p(0.8 * u(rng), 0.8 * u(rng), 0.5 + 0.5 * u(rng));
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
    X.translation() = p;
    switch (j % 4) {
      case 0:  // a board or a wall
        scene.obstacles.push_back(
            rmp::Obstacle::MakeBox(X, Eigen::Vector3d(long_side(rng), long_side(rng), thin(rng))));
        break;
      case 1:
        scene.obstacles.push_back(rmp::Obstacle::MakeBox(X, Eigen::Vector3d::Constant(size(rng))));
        break;
      case 2:
        scene.obstacles.push_back(rmp::Obstacle::MakeSphere(p, size(rng)));
        break;
      default:
        scene.obstacles.push_back(rmp::Obstacle::MakeCylinder(X, size(rng), long_side(rng)));
    }
  }
  return scene;
}

TEST(WarningSensorTest, ReportsExactlyThePairsWithinTheMarginAtTheirExactDistances) {
  for (const kinematics::Robot& robot : testing::AllTestRobots()) {
    const kinematics::Model& m = robot.model;
    WarningSensorOptions options;
    options.margin = 0.3;
    options.floor_height = 0.0;
    WarningSensor sensor(robot, options);
    kinematics::Data kin(m);
    std::mt19937_64 rng(23);
    int reported = 0, box_pairs_within = 0;
    for (int trial = 0; trial < 60; ++trial) {
      const rmp::Scene scene = RandomScene(rng);
      kinematics::CalcForwardKinematics(m, testing::RandomConfiguration(m, rng), &kin);
      sensor.Sense(kin, scene);
      // the reference: every pair, exact
      std::vector<std::pair<Key, double>> expected;
      const int nc = static_cast<int>(robot.capsules.size());
      for (int c = 0; c < nc; ++c) {
        const math::Capsule cap = kinematics::WorldCapsule(robot.capsules[c], kin);
        for (int j = 0; j < static_cast<int>(scene.obstacles.size()); ++j) {
          const double d = rmp::CapsuleObstacleDistance(cap, scene.obstacles[j]).distance;
          if (d < options.margin) {
            expected.push_back({{c, static_cast<int>(PartnerKind::kObstacle), j, -1}, d});
            box_pairs_within += scene.obstacles[j].shape == rmp::ObstacleShape::kBox ? 1 : 0;
          }
        }
        for (int d = c + 1; d < nc; ++d) {
          const int lc = robot.capsules[c].link, ld = robot.capsules[d].link;
          if (lc == ld || robot.IsExcludedPair(lc, ld)) continue;
          const math::Capsule other = kinematics::WorldCapsule(robot.capsules[d], kin);
          const double dist = math::CapsuleCapsuleDistance(cap, other).distance;
          if (dist < options.margin) expected.push_back({{c, static_cast<int>(PartnerKind::kLink), ld, d}, dist});
        }
      }
      std::vector<std::pair<Key, double>> got;
      for (const WarningContact& c : sensor.contacts()) {
        if (c.other_kind != PartnerKind::kFloor) got.push_back({KeyOf(c), c.distance});
      }
      std::sort(expected.begin(), expected.end());
      std::sort(got.begin(), got.end());
      ASSERT_EQ(got, expected) << robot.name << ", trial " << trial;  // the same pairs, bit-identical distances
      reported += static_cast<int>(got.size());
    }
    EXPECT_GT(reported, 60) << robot.name;
    if (m.nq() > 2) {
      EXPECT_GT(box_pairs_within, 10) << robot.name;
    }
  }
}

}  // namespace
}  // namespace rmpmarl::control
