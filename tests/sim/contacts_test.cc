// Warning contacts and collisions of the World against independent distance references: rmpmarl::math's signed
// distances and a brute-force minimisation of the box signed-distance function along the capsule axis.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/sim/world.h"
#include "sim_test_util.h"

namespace rmpmarl::sim {
namespace {

// MuJoCo's capsule–box collider agrees with the exact distance to this tolerance (measured maximum over the
// randomised test below, documented in docs/sim.md).
constexpr double kColliderTolerance = 1e-6;

// signed distance from point p_W to box: exact (outside: Euclidean; inside: minus the distance to the nearest face).
double BoxSdf(const math::Box& box, const Eigen::Vector3d& p_W) {
  const Eigen::Vector3d p_B = box.X_WB.inverse() * p_W;
  const Eigen::Vector3d q = p_B.cwiseAbs() - box.half_size;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

// min over the capsule axis of the (convex) box SDF, minus the radius: golden-section search, an independent reference.
double BruteForceCapsuleBox(const math::Capsule& capsule, const math::Box& box) {
  auto f = [&](double t) { return BoxSdf(box, capsule.p_WA + t * (capsule.p_WB - capsule.p_WA)); };
  double lo = 0.0, hi = 1.0;
  const double g = 0.5 * (std::sqrt(5.0) - 1.0);
  double x1 = hi - g * (hi - lo), x2 = lo + g * (hi - lo);
  double f1 = f(x1), f2 = f(x2);
  for (int it = 0; it < 200; ++it) {
    if (f1 < f2) {
      hi = x2; x2 = x1; f2 = f1; x1 = hi - g * (hi - lo); f1 = f(x1);
    } else {
      lo = x1; x1 = x2; f1 = f2; x2 = lo + g * (hi - lo); f2 = f(x2);
    }
  }
  return std::min({f(0.0), f(1.0), f(0.5 * (lo + hi))}) - capsule.radius;
}

math::Capsule WorldCapsule(const kinematics::Robot& robot, const kinematics::Data& kin, int c) {
  const kinematics::LinkCapsule& cap = robot.capsules[c];
  return {kin.X_WL[cap.link] * cap.p_LA, kin.X_WL[cap.link] * cap.p_LB, cap.radius};
}

math::Box WorldBox(const World& world, int j) {
  return {world.ObstaclePose(j), world.model().scene().obstacles[j].half_size};
}

// the smallest distance MuJoCo reports per (capsule, obstacle) pair.
std::map<std::pair<int, int>, double> MinDistancePerObstaclePair(const ContactReport& report) {
  std::map<std::pair<int, int>, double> out;
  for (const WarningContact& w : report.warnings) {
    if (w.other_kind != PartnerKind::kObstacle) continue;
    auto [it, inserted] = out.try_emplace({w.capsule, w.other_index}, w.distance);
    if (!inserted) it->second = std::min(it->second, w.distance);
  }
  return out;
}

TEST(ContactsTest, BoxTenCentimetresFromALinkIsAWarningNotACollision) {
  const kinematics::Robot robot = kinematics::MakePlanar2();  // link1 along x from 0 to 0.5, radius 0.04
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.1)};
  auto wm = std::make_shared<const WorldModel>(robot, scene);
  World world(wm);
  world.Reset(Eigen::Vector2d(0.0, 0.0));
  // cube bottom face 0.10 above the capsule's top (z = 0.04), over the middle of link1.
  world.SetObstaclePose(0, Eigen::Vector3d(0.25, 0.0, 0.04 + 0.10 + 0.05), Eigen::Matrix3d::Identity());
  const ContactReport& report = world.QueryContacts();
  EXPECT_EQ(report.num_collisions, 0);
  ASSERT_FALSE(report.warnings.empty());
  EXPECT_NEAR(report.min_clearance, 0.10, 1e-12);
  kinematics::Data kin(robot.model);
  kinematics::CalcForwardKinematics(robot.model, world.q(), &kin);
  const math::DistanceResult ref = math::CapsuleBoxDistance(WorldCapsule(robot, kin, 0), WorldBox(world, 0));
  EXPECT_NEAR(ref.distance, 0.10, 1e-12);
  for (const WarningContact& w : report.warnings) {
    EXPECT_EQ(w.link, 1);
    EXPECT_EQ(w.capsule, 0);
    EXPECT_EQ(w.other_kind, PartnerKind::kObstacle);
    EXPECT_EQ(w.other_index, 0);
    EXPECT_NEAR(w.distance, ref.distance, kColliderTolerance);
    // witness points on the two surfaces, normal from the box to the capsule (math::DistanceResult convention).
    EXPECT_NEAR(w.p_W1.z(), 0.04, 1e-12);
    EXPECT_NEAR(w.p_W2.z(), 0.14, 1e-12);
    EXPECT_NEAR(w.n_W.z(), -1.0, 1e-12);
    EXPECT_LT((w.p_W1 - (w.p_W2 + w.distance * w.n_W)).norm(), 1e-12);
  }

  // overlapping the link by 2 cm: a collision of (link1, obstacle 0) with depth 0.02.
  world.SetObstaclePose(0, Eigen::Vector3d(0.25, 0.0, 0.04 - 0.02 + 0.05), Eigen::Matrix3d::Identity());
  const ContactReport& hit = world.QueryContacts();
  ASSERT_EQ(hit.num_collisions, 1);
  EXPECT_EQ(hit.colliding_pairs[0].link, 1);
  EXPECT_EQ(hit.colliding_pairs[0].other_kind, PartnerKind::kObstacle);
  EXPECT_EQ(hit.colliding_pairs[0].other_index, 0);
  EXPECT_NEAR(hit.colliding_pairs[0].depth, 0.02, 1e-9);
  EXPECT_NEAR(hit.min_clearance, -0.02, 1e-9);

  // beyond the margin: nothing reported.
  world.SetObstaclePose(0, Eigen::Vector3d(0.25, 0.0, 0.04 + 0.16 + 0.05), Eigen::Matrix3d::Identity());
  EXPECT_TRUE(world.QueryContacts().warnings.empty());
  EXPECT_TRUE(std::isinf(world.QueryContacts().min_clearance));
}

// a cylinder obstacle in MuJoCo (its general convex collider) against math::CapsuleCylinderDistance: a standing and a
// lying cylinder over link1, apart (no collision) and overlapping (one collision of that depth), in many poses
TEST(ContactsTest, CylinderCollisionsAgreeWithTheExactDistance) {
  const kinematics::Robot robot = kinematics::MakePlanar2();  // link1 along x from 0 to 0.5, radius 0.04
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cylinder(0.05, 0.1)};
  auto wm = std::make_shared<const WorldModel>(robot, scene, WorldOptions{.warning_margin = 0.0});
  World world(wm);
  world.Reset(Eigen::Vector2d(0.0, 0.0));
  kinematics::Data kin(robot.model);
  kinematics::CalcForwardKinematics(robot.model, world.q(), &kin);
  const math::Capsule link1 = WorldCapsule(robot, kin, 0);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> angle(-M_PI, M_PI), along(0.1, 0.4), gap(-0.03, 0.03);
  int collisions = 0, apart = 0;
  double worst = 0.0;
  for (int k = 0; k < 200; ++k) {
    const Eigen::Matrix3d R = (Eigen::AngleAxisd(angle(rng), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(k % 2 == 0 ? 0.0 : 0.5 * M_PI, Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    const double g = gap(rng);
    if (std::abs(g) < 2e-3) continue;  // too close to touching for a yes/no
    // place the cylinder above the link, then lower it to the exact gap g (its closest direction is vertical: the
    // lying cylinder's lowest line and the standing one's bottom cap face the horizontal capsule)
    Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
    X_WC.linear() = R;
    X_WC.translation() = Eigen::Vector3d(along(rng), 0.0, 1.0);
    const math::Cylinder at_zero{X_WC, 0.05, 0.1};
    const double d0 = math::CapsuleCylinderDistance(link1, at_zero).distance;
    X_WC.translation().z() += g - d0;
    const double d = math::CapsuleCylinderDistance(link1, {X_WC, 0.05, 0.1}).distance;
    ASSERT_NEAR(d, g, 1e-9);
    world.SetObstaclePose(0, X_WC.translation(), R);
    // link1's pair only (a cylinder near the elbow may touch link2 too)
    std::vector<CollidingPair> link1_pairs;
    for (const CollidingPair& p : world.QueryContacts().colliding_pairs) {
      if (p.link == 1) link1_pairs.push_back(p);
    }
    if (d > 0.0) {
      EXPECT_TRUE(link1_pairs.empty()) << "gap " << d;
      ++apart;
    } else {
      ASSERT_EQ(link1_pairs.size(), 1u) << "depth " << -d;
      EXPECT_EQ(link1_pairs[0].other_kind, PartnerKind::kObstacle);
      worst = std::max(worst, std::abs(link1_pairs[0].depth + d));
      ++collisions;
    }
  }
  fmt::print("  {} overlapping and {} apart; max |MuJoCo depth − math| = {:.2e} m\n", collisions, apart, worst);
  EXPECT_GT(collisions, 50);
  EXPECT_GT(apart, 50);
  EXPECT_LT(worst, 1e-3);
}

TEST(ContactsTest, TargetAndObstacleObstacleContactsNeverCount) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.2), ObstacleSpec::Sphere(0.1)};
  scene.target_radius = 0.3;
  World world(std::make_shared<const WorldModel>(robot, scene));
  // two overlapping obstacles far from the robot, and a big target sphere swallowing link 1.
  world.SetObstaclePose(0, Eigen::Vector3d(3.0, 0.0, 0.0), Eigen::Matrix3d::Identity());
  world.SetObstaclePose(1, Eigen::Isometry3d(Eigen::Translation3d(3.05, 0.0, 0.0)));
  world.SetTargetPosition(Eigen::Vector3d(0.25, 0.0, 0.0));
  const ContactReport& report = world.QueryContacts();
  EXPECT_EQ(report.num_collisions, 0);
  EXPECT_TRUE(report.warnings.empty());
  EXPECT_EQ(world.mj_data()->ncon, 0);  // not generated at all
}

// randomised: every (capsule, box) pair within the margin is reported with the exact distance; none beyond.
void CheckObstacleContactsAgainstReferences(const kinematics::Robot& robot, int samples, double* worst_math,
                                            double* worst_brute, int* num_checked) {
  constexpr int kNumBoxes = 4;
  SceneSpec scene;
  for (int j = 0; j < kNumBoxes; ++j) scene.obstacles.push_back(ObstacleSpec::Cube(0.06 + 0.04 * j));
  scene.obstacles.push_back(ObstacleSpec::Sphere(0.05));
  auto wm = std::make_shared<const WorldModel>(robot, scene);
  World world(wm);
  const double margin = wm->options().warning_margin;
  kinematics::Data kin(robot.model);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int s = 0; s < samples; ++s) {
    const Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
    world.Reset(q);
    kinematics::CalcForwardKinematics(robot.model, q, &kin);
    // obstacles near a random capsule's axis so that most land within or just beyond the margin.
    for (int j = 0; j < kNumBoxes + 1; ++j) {
      const int c = std::uniform_int_distribution<int>(0, static_cast<int>(robot.capsules.size()) - 1)(rng);
      const math::Capsule cap = WorldCapsule(robot, kin, c);
      const double t = 0.5 * (unit(rng) + 1.0);
      const Eigen::Vector3d offset = Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).normalized() *
                                     (cap.radius + 0.3 * (0.5 * (unit(rng) + 1.0)));
      world.SetObstaclePose(j, cap.p_WA + t * (cap.p_WB - cap.p_WA) + offset, testing::RandomRotation(rng));
    }
    const ContactReport& report = world.QueryContacts();
    const auto reported = MinDistancePerObstaclePair(report);
    // the obstacles touch the capsules only (never a separate self-collision cover, numbered after them)
    for (const auto& [pair, distance] : reported) ASSERT_LT(pair.first, static_cast<int>(robot.capsules.size()));
    for (int c = 0; c < static_cast<int>(robot.capsules.size()); ++c) {
      for (int j = 0; j < kNumBoxes + 1; ++j) {
        const math::Capsule cap = WorldCapsule(robot, kin, c);
        double ref = 0.0;
        if (j < kNumBoxes) {
          ref = math::CapsuleBoxDistance(cap, WorldBox(world, j)).distance;
          const double brute = BruteForceCapsuleBox(cap, WorldBox(world, j));
          if (ref > 0.0) {  // the two references agree outside the box
            EXPECT_NEAR(ref, brute, 1e-9);
            *worst_brute = std::max(*worst_brute, std::abs(brute - ref));
          }
        } else {
          ref = math::CapsuleSphereDistance(cap, {world.ObstaclePose(j).translation(), 0.05}).distance;
        }
        const auto it = reported.find({c, j});
        if (ref < margin - 1e-6) {
          // penetration depths differ by definition (box SDF vs MuJoCo's contact depth): check the sign only.
          ASSERT_NE(it, reported.end()) << "capsule " << c << " obstacle " << j << " ref " << ref << " sample " << s;
          if (ref >= 0.0) {
            const double err = std::abs(it->second - ref);
            *worst_math = std::max(*worst_math, err);
            EXPECT_NEAR(it->second, ref, kColliderTolerance) << "capsule " << c << " obstacle " << j << " sample " << s;
            ++*num_checked;
          } else {
            EXPECT_LT(it->second, 0.0) << "capsule " << c << " obstacle " << j << " sample " << s;
          }
        } else if (ref > margin + 1e-6) {
          EXPECT_EQ(it, reported.end()) << "capsule " << c << " obstacle " << j << " ref " << ref;
        }
      }
    }
    // collisions agree with the sign of the reference distances.
    int expected_collisions = 0;
    for (int j = 0; j < kNumBoxes + 1; ++j) {
      std::vector<int> links;
      for (int c = 0; c < static_cast<int>(robot.capsules.size()); ++c) {
        const auto it = reported.find({c, j});
        if (it != reported.end() && it->second < 0.0 &&
            std::find(links.begin(), links.end(), robot.capsules[c].link) == links.end()) {
          links.push_back(robot.capsules[c].link);
        }
      }
      expected_collisions += static_cast<int>(links.size());
    }
    int obstacle_collisions = 0;
    for (const CollidingPair& p : report.colliding_pairs) obstacle_collisions += p.other_kind == PartnerKind::kObstacle;
    EXPECT_EQ(obstacle_collisions, expected_collisions);
  }
}

TEST(ContactsTest, ObstacleDistancesMatchExactReferences) {
  double worst_math = 0.0, worst_brute = 0.0;
  int checked = 0;
  std::vector<kinematics::Robot> robots = {testing::LoadTreeRobot(), kinematics::MakePlanar2()};
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    robots.push_back(kinematics::LoadShippedRobot(name));
  }
  // with a separate self-collision cover, fatter than the capsules: the obstacles still see the capsules alone
  kinematics::Robot separate = kinematics::LoadShippedRobot("panda");
  separate.name = "panda, separate self set";
  separate.self_capsules = separate.capsules;
  for (kinematics::LinkCapsule& c : separate.self_capsules) c.radius += 0.05;
  robots.push_back(separate);
  for (const kinematics::Robot& robot : robots) {
    SCOPED_TRACE(robot.name);
    CheckObstacleContactsAgainstReferences(robot, 100, &worst_math, &worst_brute, &checked);
  }
  fmt::print("  {} warning distances checked; max |MuJoCo − math| = {:.2e} m; max |brute force − math| = {:.2e} m\n",
             checked, worst_math, worst_brute);
  RecordProperty("max_contact_distance_error", fmt::format("{:.3e}", worst_math));
  EXPECT_GT(checked, 100);
}

TEST(ContactsTest, SelfContactsOnlyForCheckedLinkPairs) {
  std::vector<kinematics::Robot> robots = {testing::LoadTreeRobot()};
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    robots.push_back(kinematics::LoadShippedRobot(name));
  }
  // a robot with a separate self-collision set: thinner capsules for the scene, fatter ones between its links
  kinematics::Robot separate = kinematics::LoadShippedRobot("panda");
  separate.name = "panda, separate self set";
  separate.self_capsules = separate.capsules;
  for (kinematics::LinkCapsule& c : separate.capsules) c.radius *= 0.7;
  for (kinematics::LinkCapsule& c : separate.self_capsules) c.radius += 0.01;
  robots.push_back(separate);
  for (const kinematics::Robot& robot : robots) {
    SCOPED_TRACE(robot.name);
    auto wm = std::make_shared<const WorldModel>(robot);
    World world(wm);
    kinematics::Data kin(robot.model);
    std::mt19937_64 rng(11);
    const double margin = wm->options().warning_margin;
    // the self pairs are the self-collision set's, numbered after the capsules
    const std::vector<kinematics::LinkCapsule>& self = robot.self_collision_capsules();
    const int offset = robot.self_capsules.empty() ? 0 : static_cast<int>(robot.capsules.size());
    int seen = 0, seen_collisions = 0;
    double worst = 0.0;
    for (int s = 0; s < 200; ++s) {
      const Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
      world.Reset(q);
      kinematics::CalcForwardKinematics(robot.model, q, &kin);
      const ContactReport& report = world.QueryContacts();
      std::map<std::pair<int, int>, double> reported;
      for (const WarningContact& w : report.warnings) {
        ASSERT_EQ(w.other_kind, PartnerKind::kLink);
        EXPECT_TRUE(wm->IsCheckedLinkPair(w.link, w.other_index));
        EXPECT_LT(w.link, w.other_index);
        ASSERT_GE(w.capsule, offset);
        ASSERT_GE(w.other_capsule, offset);
        auto [it, inserted] = reported.try_emplace({w.capsule - offset, w.other_capsule - offset}, w.distance);
        if (!inserted) it->second = std::min(it->second, w.distance);
      }
      for (int a = 0; a < static_cast<int>(self.size()); ++a) {
        for (int b = 0; b < static_cast<int>(self.size()); ++b) {
          const int la = self[a].link, lb = self[b].link;
          if (la >= lb || !wm->IsCheckedLinkPair(la, lb)) continue;
          const double ref = math::CapsuleCapsuleDistance(kinematics::WorldCapsule(self[a], kin),
                                                          kinematics::WorldCapsule(self[b], kin)).distance;
          const auto it = reported.find({a, b});
          if (ref < margin - 1e-6) {
            ASSERT_NE(it, reported.end()) << "capsules " << a << "," << b << " ref " << ref << " sample " << s;
            EXPECT_NEAR(it->second, ref, 1e-9);
            worst = std::max(worst, std::abs(it->second - ref));
            ++seen;
            seen_collisions += ref < 0.0;
          } else if (ref > margin + 1e-6) {
            EXPECT_EQ(it, reported.end());
          }
        }
      }
    }
    fmt::print("  {:>10}: {} self warning pairs checked ({} colliding), max |MuJoCo − math| = {:.1e} m\n",
               robot.name, seen, seen_collisions, worst);
    if (!robot.self_capsules.empty()) {
      EXPECT_GT(seen_collisions, 0);
    }
  }
  // the self-collision capsules weigh nothing: the separate set's links are as heavy as the thinner capsules make them
  kinematics::Robot thin = separate;
  thin.self_capsules.clear();
  const WorldModel with_set(separate), without(thin);
  ASSERT_EQ(with_set.mj_model()->nbody, without.mj_model()->nbody);
  for (int b = 0; b < with_set.mj_model()->nbody; ++b) {
    EXPECT_EQ(with_set.mj_model()->body_mass[b], without.mj_model()->body_mass[b]) << "body " << b;
  }
}

TEST(ContactsTest, BaseLinkSeesObstaclesThroughExplicitPairs) {
  // the tree robot's torso is the first moving link; its base has no capsule, so give one to a robot whose root has:
  // planar2 with a capsule on its base link (link 0, welded to the world like every robot base).
  kinematics::Robot robot = kinematics::MakePlanar2();
  robot.capsules.push_back({0, Eigen::Vector3d(0, 0, -0.2), Eigen::Vector3d(0, 0, -0.05), 0.05});
  SceneSpec scene;
  scene.obstacles = {ObstacleSpec::Cube(0.1)};
  World world(std::make_shared<const WorldModel>(robot, scene));
  world.SetObstaclePose(0, Eigen::Vector3d(0.05 + 0.08 + 0.05, 0.0, -0.15), Eigen::Matrix3d::Identity());
  const ContactReport& report = world.QueryContacts();
  bool base_seen = false;
  for (const WarningContact& w : report.warnings) {
    if (w.link == 0) {
      base_seen = true;
      EXPECT_NEAR(w.distance, 0.08, 1e-9);
    }
  }
  EXPECT_TRUE(base_seen);
}

TEST(ContactsTest, FloorCollisionsAreReported) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  SceneSpec scene;
  scene.has_floor = true;
  scene.floor_height = -0.03;  // the arm (radius 0.04) moving in z = 0 dips 1 cm into it
  World world(std::make_shared<const WorldModel>(robot, scene));
  const ContactReport& report = world.QueryContacts();
  ASSERT_EQ(report.num_collisions, 2);
  for (const CollidingPair& p : report.colliding_pairs) {
    EXPECT_EQ(p.other_kind, PartnerKind::kFloor);
    EXPECT_NEAR(p.depth, 0.01, 1e-9);
  }
}

}  // namespace
}  // namespace rmpmarl::sim
