// The robot collision checker against an exhaustive search over every pair it is meant to check (written here from
// the capsule distance functions alone, no broad phase), on every shipped arm at random configurations with random
// boxes, spheres and cylinders near them; its edge check against the configurations of the edge checked one by one;
// its three ways of placing the capsules against each other; no allocation in a check.
#include "rmpmarl/collision/checker.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <initializer_list>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "../kinematics/test_robots.h"
#include "../support/alloc_counter.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::collision {
namespace {

using Eigen::Vector3d;
using Eigen::VectorXd;

const std::vector<std::string> kArms = {"panda", "ur5e", "iiwa14", "gen3", "xarm6", "irb120"};

// the obstacles of a trial: a box, a sphere and a cylinder placed around random capsules of the arm at q, some
// touching it, some clear of it
std::vector<rmp::Obstacle> ObstaclesNear(const kinematics::Robot& robot, const VectorXd& q, std::mt19937_64& rng) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  std::normal_distribution<double> N(0.0, 1.0);
  auto near_point = [&](double reach) {
    const auto& c = robot.capsules[rng() % robot.capsules.size()];
    const Vector3d p = data.X_WL[c.link] * (c.p_LA + U(rng) * (c.p_LB - c.p_LA));
    return Vector3d(p + Vector3d(N(rng), N(rng), N(rng)).normalized() * (c.radius + reach * U(rng)));
  };
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(N(rng), N(rng), N(rng), N(rng)).normalized().toRotationMatrix();
  X.translation() = near_point(0.15);
  std::vector<rmp::Obstacle> obstacles;
  obstacles.push_back(rmp::Obstacle::MakeBox(X, Vector3d(0.02 + 0.1 * U(rng), 0.02 + 0.1 * U(rng), 0.01 + 0.05 * U(rng))));
  obstacles.push_back(rmp::Obstacle::MakeSphere(near_point(0.12), 0.02 + 0.05 * U(rng)));
  X.linear() = Eigen::Quaterniond(N(rng), N(rng), N(rng), N(rng)).normalized().toRotationMatrix();
  X.translation() = near_point(0.2);
  obstacles.push_back(rmp::Obstacle::MakeCylinder(X, 0.02 + 0.04 * U(rng), 0.05 + 0.1 * U(rng)));
  return obstacles;
}

// the exhaustive answer: every capsule against every obstacle, the floor for capsules whose height can change (found
// here from the joint axes), every capsule pair of distinct links the robot does not exclude
struct Exhaustive {
  double obstacles = INFINITY, floor = INFINITY, self = INFINITY;
  double all() const { return std::min({obstacles, floor, self}); }
};

Exhaustive ExhaustiveClearance(const kinematics::Robot& robot, const VectorXd& q,
                               const std::vector<rmp::Obstacle>& obstacles, bool check_floor) {
  kinematics::Data data(robot.model), at_zero(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  kinematics::CalcForwardKinematics(robot.model, VectorXd::Zero(robot.model.nq()), &at_zero);
  Exhaustive e;
  for (size_t a = 0; a < robot.capsules.size(); ++a) {
    const kinematics::LinkCapsule& ca = robot.capsules[a];
    const math::Capsule wa = kinematics::WorldCapsule(ca, data);
    for (const rmp::Obstacle& o : obstacles) {
      e.obstacles = std::min(e.obstacles, rmp::CapsuleObstacleDistance(wa, o).distance);
    }
    bool fixed_height = true;
    for (int i : robot.model.link_dofs(ca.link)) {
      const kinematics::Link& joint = robot.model.link(robot.model.dof_link(i));
      fixed_height = fixed_height && joint.joint_type != kinematics::JointType::kPrismatic &&
                     robot.model.link_dofs(joint.parent).empty() &&
                     std::abs(std::abs(at_zero.axis_W.col(i).z()) - 1.0) < 1e-9;
    }
    if (check_floor && !fixed_height) {
      e.floor = std::min(e.floor, std::min(wa.p_WA.z(), wa.p_WB.z()) - wa.radius);
    }
  }
  // self pairs: of the self-collision set (the capsules themselves without one)
  const std::vector<kinematics::LinkCapsule>& self = robot.self_collision_capsules();
  for (size_t a = 0; a < self.size(); ++a) {
    for (size_t b = a + 1; b < self.size(); ++b) {
      if (self[a].link == self[b].link || robot.IsExcludedPair(self[a].link, self[b].link)) continue;
      e.self = std::min(e.self, math::CapsuleCapsuleDistance(kinematics::WorldCapsule(self[a], data),
                                                             kinematics::WorldCapsule(self[b], data)).distance);
    }
  }
  return e;
}

// the distance of the pair a ClearancePair names, from the capsules of its links
double PairDistance(const kinematics::Robot& robot, const VectorXd& q, const std::vector<rmp::Obstacle>& obstacles,
                    const ClearancePair& pair) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  double d = INFINITY;
  for (const kinematics::LinkCapsule& a : robot.capsules) {
    if (a.link != pair.link) continue;
    const math::Capsule wa = kinematics::WorldCapsule(a, data);
    if (pair.kind == ClearancePair::Kind::kObstacle) {
      d = std::min(d, rmp::CapsuleObstacleDistance(wa, obstacles[pair.obstacle]).distance);
    } else if (pair.kind == ClearancePair::Kind::kFloor) {
      d = std::min(d, std::min(wa.p_WA.z(), wa.p_WB.z()) - wa.radius);
    }
  }
  if (pair.kind == ClearancePair::Kind::kSelf) {
    for (const kinematics::LinkCapsule& a : robot.self_collision_capsules()) {
      for (const kinematics::LinkCapsule& b : robot.self_collision_capsules()) {
        if (a.link == pair.link && b.link == pair.other_link) {
          d = std::min(d, math::CapsuleCapsuleDistance(kinematics::WorldCapsule(a, data),
                                                       kinematics::WorldCapsule(b, data)).distance);
        }
      }
    }
  }
  return d;
}

TEST(RobotCollisionCheckerTest, ClearanceIsTheSmallestDistanceOfEveryCheckedPairOnEveryArm) {
  std::mt19937_64 rng(11);
  int obstacle = 0, floor = 0, self = 0, touching = 0;
  for (const std::string& name : kArms) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    const RobotCollisionModel model(robot);
    RobotCollisionData data(model);
    for (int trial = 0; trial < 60; ++trial) {
      const VectorXd q = testing::RandomConfiguration(robot.model, rng);
      const std::vector<rmp::Obstacle> obstacles =
          trial % 5 == 4 ? std::vector<rmp::Obstacle>{} : ObstaclesNear(robot, q, rng);
      const Exhaustive e = ExhaustiveClearance(robot, q, obstacles, true);
      const ClearancePair pair = CalcRobotClearance(model, q, obstacles, &data);
      // exact: the broad phase skips only pairs that cannot come closer
      ASSERT_EQ(pair.distance, e.all()) << name << " trial " << trial;
      ASSERT_EQ(PairDistance(robot, q, obstacles, pair), pair.distance) << name << " trial " << trial;
      // the capsules it names are the ones attaining it
      if (pair.kind != ClearancePair::Kind::kNone) {
        const math::Capsule a = data.capsule_W[pair.capsule];
        EXPECT_EQ(robot.capsules[pair.capsule].link, pair.link);
        const double d = pair.kind == ClearancePair::Kind::kObstacle
                             ? rmp::CapsuleObstacleDistance(a, obstacles[pair.obstacle]).distance
                         : pair.kind == ClearancePair::Kind::kFloor
                             ? std::min(a.p_WA.z(), a.p_WB.z()) - a.radius
                             : math::CapsuleCapsuleDistance(a, data.capsule_W[pair.other_capsule]).distance;
        EXPECT_EQ(d, pair.distance);
      }
      EXPECT_EQ(CalcObstacleClearance(model, data, obstacles), e.obstacles);
      EXPECT_EQ(CalcSelfCapsuleClearance(model, data), e.self);
      EXPECT_EQ(CalcSelfClearance(model, data), std::min(e.self, e.floor));
      obstacle += pair.kind == ClearancePair::Kind::kObstacle;
      floor += pair.kind == ClearancePair::Kind::kFloor;
      self += pair.kind == ClearancePair::Kind::kSelf;
      touching += pair.distance <= 0.0;
      // a check with a margin says the same as the clearance, whichever part returns early
      for (double margin : {0.0, 0.01, 0.05}) {
        EXPECT_EQ(CheckConfigCollisionFree(model, q, obstacles, margin, &data), e.all() > margin)
            << name << " trial " << trial << " margin " << margin;
      }
    }
    // without the floor, the floor is not what attains it
    const RobotCollisionModel no_floor(robot, {.check_floor = false});
    RobotCollisionData data_no_floor(no_floor);
    const VectorXd q = testing::RandomConfiguration(robot.model, rng);
    const std::vector<rmp::Obstacle> obstacles = ObstaclesNear(robot, q, rng);
    EXPECT_EQ(CalcRobotClearance(no_floor, q, obstacles, &data_no_floor).distance,
              ExhaustiveClearance(robot, q, obstacles, false).all());
  }
  std::printf("[ checker ] %zu arms x 60 configurations: closest to an obstacle %d, the floor %d, another link %d; "
              "%d in contact\n", kArms.size(), obstacle, floor, self, touching);
  EXPECT_GT(obstacle, 50);
  EXPECT_GT(self, 5);
  EXPECT_GT(touching, 30);
}

TEST(RobotCollisionCheckerTest, ALazyCheckAnswersAsPlacingEveryCapsule) {
  // CheckConfigCollisionFree places only the capsules it reaches: its answer, against the obstacles or against them
  // prepared, is the exhaustive one and that of PlaceRobot + CheckPlacedCollisionFree, for split margins and
  // obstacles alone too, and what it placed is PlaceRobot's, bit for bit
  std::mt19937_64 rng(17);
  int reached = 0, total = 0, free = 0, checks = 0;
  for (const std::string& name : kArms) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    const RobotCollisionModel model(robot);
    RobotCollisionData lazy(model), eager(model);
    lazy.stamp = std::numeric_limits<std::uint32_t>::max() - 20;  // the stamp wraps around within the trials
    for (int trial = 0; trial < 40; ++trial) {
      const VectorXd q = testing::RandomConfiguration(robot.model, rng);
      // every other trial without obstacles: free often, when the arm is clear of itself and the floor
      const std::vector<rmp::Obstacle> obstacles =
          trial % 2 == 1 ? std::vector<rmp::Obstacle>{} : ObstaclesNear(robot, q, rng);
      const Exhaustive e = ExhaustiveClearance(robot, q, obstacles, true);
      for (const auto& [obstacle_margin, self_margin] : {std::pair{0.0, 0.0}, {0.01, 0.0}, {0.05, 0.01}}) {
        for (const bool obstacles_only : {false, true}) {
          const bool expected =
              e.obstacles > obstacle_margin && (obstacles_only || std::min(e.self, e.floor) > self_margin);
          const bool answer =
              CheckConfigCollisionFree(model, q, obstacles, obstacle_margin, self_margin, obstacles_only, &lazy);
          PlaceRobot(model, q, &eager);
          ASSERT_EQ(answer, expected) << name << " trial " << trial;
          ASSERT_EQ(CheckConfigCollisionFree(model, q, PreparedObstacles(obstacles), obstacle_margin, self_margin,
                                             obstacles_only, &lazy),
                    expected);
          ASSERT_EQ(CheckPlacedCollisionFree(model, obstacles, obstacle_margin, self_margin, obstacles_only, &eager),
                    expected);
          free += answer;
          ++checks;
          for (int c = 0; c < model.num_capsules(); ++c) {
            if (lazy.sphere_stamp[c] == lazy.stamp) {
              EXPECT_EQ(lazy.capsule_sphere[c], eager.capsule_sphere[c]);
            }
            if (lazy.capsule_stamp[c] != lazy.stamp) continue;
            EXPECT_EQ(lazy.capsule_W[c].p_WA, eager.capsule_W[c].p_WA);
            EXPECT_EQ(lazy.capsule_W[c].p_WB, eager.capsule_W[c].p_WB);
            ++reached;
          }
          total += model.num_capsules();
        }
      }
    }
  }
  std::printf("[ checker ] lazy checks: %d of %d free, %d of %d capsules placed\n", free, checks, reached, total);
  EXPECT_GT(free, checks / 5);
  EXPECT_LT(free, checks * 4 / 5);
  EXPECT_LT(reached, total);
}

TEST(RobotCollisionCheckerTest, TwoLinksMoveApartNoFasterThanTheirReach) {
  // the self-pair memory's bound: a link pair's distance at q' is at least its distance at q less Σ reach |q'_i − q_i|
  // over the pair's dofs (self_pair_motion), at random nearby configurations of every arm (and the pairs' reach is
  // not trivially large: the bound is also met within a factor of a few on some pairs)
  std::mt19937_64 rng(23);
  std::uniform_real_distribution<double> U(-1.0, 1.0);
  int compared = 0, tight = 0;
  for (const std::string& name : kArms) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    const RobotCollisionModel model(robot);
    RobotCollisionData at_q(model), at_q2(model);
    const int nq = robot.model.nq();
    auto link_pair_distance = [&](const RobotCollisionData& d, const RobotCollisionModel::LinkPair& links) {
      double m = INFINITY;
      for (size_t i = links.begin; i < links.end; ++i) {
        const auto [a, b] = model.grouped_self_pairs()[i];
        m = std::min(m, math::CapsuleCapsuleDistance(d.capsule_W[a], d.capsule_W[b]).distance);
      }
      return m;
    };
    for (int trial = 0; trial < 100; ++trial) {
      const VectorXd q = testing::RandomConfiguration(robot.model, rng);
      VectorXd q2 = q;
      const double step = trial % 2 == 0 ? 0.02 : 0.3;
      for (int i = 0; i < nq; ++i) q2[i] += step * U(rng);
      PlaceRobot(model, q, &at_q);
      PlaceRobot(model, q2, &at_q2);
      for (size_t p = 0; p < model.self_link_pairs().size(); ++p) {
        double moved = 0.0;
        for (const auto& [dof, reach] : model.self_pair_motion(p)) moved += reach * std::abs(q2[dof] - q[dof]);
        const double before = link_pair_distance(at_q, model.self_link_pairs()[p]);
        const double after = link_pair_distance(at_q2, model.self_link_pairs()[p]);
        ASSERT_GE(after, before - moved - 1e-12) << name << " trial " << trial << " pair " << p;
        ASSERT_GE(before, after - moved - 1e-12) << name << " trial " << trial << " pair " << p;
        ++compared;
        tight += std::abs(after - before) > 0.2 * moved;
      }
    }
  }
  std::printf("[ checker ] %d link-pair moves within their reach, %d of them by more than a fifth of it\n", compared,
              tight);
  EXPECT_GT(tight, compared / 50);
}

TEST(RobotCollisionCheckerTest, ALazyCheckAlongAPathAnswersAsTheExhaustiveSearch) {
  // small steps along straight paths, as a planner checks an edge: the self-pair memory skips pairs, the answers stay
  // the exhaustive ones, near self-collision too
  std::mt19937_64 rng(29);
  int free = 0, checks = 0;
  for (const std::string& name : kArms) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    const RobotCollisionModel model(robot);
    RobotCollisionData lazy(model);
    for (int path = 0; path < 6; ++path) {
      const VectorXd a = testing::RandomConfiguration(robot.model, rng);
      const VectorXd b = testing::RandomConfiguration(robot.model, rng);
      for (int k = 0; k <= 200; ++k) {
        const VectorXd q = a + (b - a) * (k / 200.0);
        const Exhaustive e = ExhaustiveClearance(robot, q, {}, true);
        for (double margin : {0.0, 0.01, 0.05}) {
          const bool answer = CheckConfigCollisionFree(model, q, std::span<const rmp::Obstacle>{}, margin, margin,
                                                       false, &lazy);
          ASSERT_EQ(answer, std::min(e.self, e.floor) > margin) << name << " path " << path << " step " << k;
          free += answer;
          ++checks;
        }
      }
    }
  }
  std::printf("[ checker ] along paths: %d of %d checks free\n", free, checks);
  EXPECT_GT(free, checks / 5);
  EXPECT_LT(free, checks * 4 / 5);
}

// the robot with each capsule cut into `pieces` along its segment: the same union, many capsules per link (as a tight
// cover has), so that the checker's clusters come into play
kinematics::Robot Sliced(kinematics::Robot robot, int pieces) {
  std::vector<kinematics::LinkCapsule> sliced;
  for (const kinematics::LinkCapsule& c : robot.capsules) {
    for (int k = 0; k < pieces; ++k) {
      kinematics::LinkCapsule piece = c;
      piece.p_LA = c.p_LA + (c.p_LB - c.p_LA) * (static_cast<double>(k) / pieces);
      piece.p_LB = c.p_LA + (c.p_LB - c.p_LA) * (static_cast<double>(k + 1) / pieces);
      sliced.push_back(piece);
    }
  }
  robot.capsules = std::move(sliced);
  return robot;
}

// lazy self and floor checks at `steps` + 1 configurations along each of 3 random straight paths (where the self-pair
// memory skips link pairs) answer as the exhaustive search; counts the free answers and the checks
void CheckPathsAgainstTheExhaustiveSearch(const kinematics::Robot& robot, const RobotCollisionModel& model, int steps,
                                          std::initializer_list<double> margins, std::mt19937_64& rng,
                                          RobotCollisionData* lazy, int* free, int* checks) {
  for (int path = 0; path < 3; ++path) {
    const VectorXd a = testing::RandomConfiguration(robot.model, rng);
    const VectorXd b = testing::RandomConfiguration(robot.model, rng);
    for (int k = 0; k <= steps; ++k) {
      const VectorXd q = a + (b - a) * (static_cast<double>(k) / steps);
      const Exhaustive e = ExhaustiveClearance(robot, q, {}, true);
      for (double margin : margins) {
        const bool answer =
            CheckConfigCollisionFree(model, q, std::span<const rmp::Obstacle>{}, margin, margin, false, lazy);
        ASSERT_EQ(answer, std::min(e.self, e.floor) > margin) << robot.name << " path " << path << " step " << k;
        *free += answer;
        ++*checks;
      }
    }
  }
}

TEST(RobotCollisionCheckerTest, ClustersOfManyCapsulesPerLinkAnswerAsTheExhaustiveSearch) {
  std::mt19937_64 rng(41);
  int free = 0, checks = 0;
  for (const std::string& name : {std::string("panda"), std::string("ur5e")}) {
    const kinematics::Robot robot = Sliced(kinematics::LoadShippedRobot(name), 12);
    const RobotCollisionModel model(robot);
    // the clusters partition each group, hold at most kClusterSize capsules, and their spheres hold the capsules'
    size_t clustered = 0;
    for (const RobotCollisionModel::LinkGroup& g : model.link_groups()) {
      std::vector<int> members;
      for (int k : g.clusters) {
        const RobotCollisionModel::Cluster& cluster = model.clusters()[k];
        EXPECT_LE(static_cast<int>(cluster.capsules.size()), RobotCollisionModel::kClusterSize);
        EXPECT_EQ(model.link_groups()[cluster.group].link, g.link);
        const Eigen::Vector4d& s = model.cluster_sphere_L(k);
        for (int c : cluster.capsules) {
          const Eigen::Vector4d& cs = model.capsule_sphere_L(c);
          EXPECT_LE((cs.head<3>() - s.head<3>()).norm() + cs[3], s[3]);
        }
        members.insert(members.end(), cluster.capsules.begin(), cluster.capsules.end());
      }
      std::sort(members.begin(), members.end());
      EXPECT_EQ(members, g.capsules);
      clustered += g.clusters.size() > 1;
    }
    EXPECT_GE(clustered, 5u) << name;
    RobotCollisionData data(model), lazy(model);
    for (int trial = 0; trial < 30; ++trial) {
      const VectorXd q = testing::RandomConfiguration(robot.model, rng);
      const std::vector<rmp::Obstacle> obstacles = ObstaclesNear(robot, q, rng);
      const Exhaustive e = ExhaustiveClearance(robot, q, obstacles, true);
      const ClearancePair pair = CalcRobotClearance(model, q, obstacles, &data);
      ASSERT_EQ(pair.distance, e.all()) << name << " trial " << trial;
      ASSERT_EQ(PairDistance(robot, q, obstacles, pair), pair.distance) << name << " trial " << trial;
      EXPECT_EQ(CalcSelfClearance(model, data), std::min(e.self, e.floor));
      for (double margin : {0.0, 0.01, 0.05}) {
        EXPECT_EQ(CheckConfigCollisionFree(model, q, obstacles, margin, &lazy), e.all() > margin);
      }
    }
    // along straight paths, where the self-pair memory skips link pairs
    CheckPathsAgainstTheExhaustiveSearch(robot, model, 100, {0.0, 0.02}, rng, &lazy, &free, &checks);
  }
  EXPECT_GT(free, checks / 10);
  EXPECT_LT(free, checks * 9 / 10);
}

TEST(RobotCollisionCheckerTest, ASeparateSelfCollisionSetIsWhatTheSelfPairsAreCheckedOn) {
  // a tight cover of many capsules for the obstacles and the floor, a coarse one for self-collision: the obstacles see
  // only the first, the self pairs only the second (the exhaustive search reads them from the robot's two lists)
  std::mt19937_64 rng(43);
  int free = 0, checks = 0, self_differs = 0;
  for (const std::string& name : {std::string("panda"), std::string("iiwa14")}) {
    const kinematics::Robot shipped = kinematics::LoadShippedRobot(name);
    kinematics::Robot robot = Sliced(shipped, 6);
    for (kinematics::LinkCapsule& c : robot.capsules) c.radius *= 0.8;
    robot.self_capsules = shipped.capsules;
    for (kinematics::LinkCapsule& c : robot.self_capsules) c.radius += 0.03;
    kinematics::Robot fine_only = robot;
    fine_only.self_capsules.clear();
    const RobotCollisionModel model(robot);
    ASSERT_EQ(model.num_capsules(), static_cast<int>(robot.capsules.size()));
    ASSERT_EQ(model.num_placed_capsules(), static_cast<int>(robot.capsules.size() + shipped.capsules.size()));
    for (const auto& [a, b] : model.self_pairs()) {
      ASSERT_GE(a, model.num_capsules());
      ASSERT_GE(b, model.num_capsules());
    }
    RobotCollisionData data(model), lazy(model);
    for (int trial = 0; trial < 40; ++trial) {
      const VectorXd q = testing::RandomConfiguration(robot.model, rng);
      const std::vector<rmp::Obstacle> obstacles = ObstaclesNear(robot, q, rng);
      const Exhaustive e = ExhaustiveClearance(robot, q, obstacles, true);
      self_differs += e.self != ExhaustiveClearance(fine_only, q, obstacles, true).self;
      const ClearancePair pair = CalcRobotClearance(model, q, obstacles, &data);
      ASSERT_EQ(pair.distance, e.all()) << name << " trial " << trial;
      ASSERT_EQ(PairDistance(robot, q, obstacles, pair), pair.distance) << name << " trial " << trial;
      if (pair.kind == ClearancePair::Kind::kSelf) {
        EXPECT_EQ(model.capsule(pair.capsule).link, pair.link);
        EXPECT_EQ(model.capsule(pair.other_capsule).link, pair.other_link);
      } else if (pair.kind != ClearancePair::Kind::kNone) {
        EXPECT_LT(pair.capsule, model.num_capsules());
      }
      EXPECT_EQ(CalcObstacleClearance(model, data, obstacles), e.obstacles);
      EXPECT_EQ(CalcSelfCapsuleClearance(model, data), e.self);
      EXPECT_EQ(CalcSelfClearance(model, data), std::min(e.self, e.floor));
      for (double margin : {0.0, 0.01, 0.05}) {
        EXPECT_EQ(CheckConfigCollisionFree(model, q, obstacles, margin, &lazy), e.all() > margin);
      }
    }
    CheckPathsAgainstTheExhaustiveSearch(robot, model, 60, {0.01}, rng, &lazy, &free, &checks);
  }
  EXPECT_GT(self_differs, 60);  // the two sets' self clearances differ: the test tells them apart
  EXPECT_GT(free, checks / 10);
  EXPECT_LT(free, checks * 9 / 10);
}

TEST(RobotCollisionCheckerTest, AnEdgeIsFreeWhenEveryConfigurationAlongItIs) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const RobotCollisionModel model(robot);
  RobotCollisionData data(model);
  std::mt19937_64 rng(5);
  int free_edges = 0, blocked = 0;
  VectorXd scratch(robot.model.nq());
  // edges around the Panda's ready posture (clear of itself and the floor), some through the obstacles
  VectorXd ready(7);
  ready << 0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785;
  std::uniform_real_distribution<double> U(-0.5, 0.5);
  auto near_ready = [&] {
    VectorXd q = ready;
    for (int i = 0; i < q.size(); ++i) q[i] += U(rng);
    return q;
  };
  for (int trial = 0; trial < 40; ++trial) {
    const VectorXd q0 = near_ready();
    const VectorXd q1 = near_ready();
    // one of the three obstacles placed near the edge's end
    const std::vector<rmp::Obstacle> obstacles = {ObstaclesNear(robot, q1, rng)[trial % 3]};
    const double resolution = 0.02;
    // the states the edge check promises to look at, checked one by one against the exhaustive clearance
    const int n = std::max(1, static_cast<int>(std::ceil((q1 - q0).norm() / resolution)));
    bool expected = true;
    for (int k = 1; k <= n && expected; ++k) {
      const VectorXd q = q0 + (static_cast<double>(k) / n) * (q1 - q0);
      expected = ExhaustiveClearance(robot, q, obstacles, true).all() > 0.0;
    }
    EXPECT_EQ(CheckEdgeCollisionFree(model, q0, q1, obstacles, 0.0, resolution, &data, &scratch), expected)
        << "trial " << trial;
    ++(expected ? free_edges : blocked);
  }
  EXPECT_GT(free_edges, 5);
  EXPECT_GT(blocked, 5);
}

TEST(RobotCollisionCheckerTest, CoarseToFineVisitsEveryStateOnceTheEndFirst) {
  for (int n = 0; n <= 70; ++n) {
    std::vector<int> order;
    EXPECT_TRUE(VisitEdgeStatesCoarseToFine(n, [&](int k) {
      order.push_back(k);
      return true;
    }));
    ASSERT_EQ(static_cast<int>(order.size()), n) << "n=" << n;
    if (n > 0) {
      EXPECT_EQ(order.front(), n);
    }
    std::vector<int> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    for (int k = 1; k <= n; ++k) EXPECT_EQ(sorted[k - 1], k) << "n=" << n;
    // coarse first: the largest gap left after the first half of the visits is at most twice the smallest step
    if (n >= 8) {
      std::vector<int> first(order.begin(), order.begin() + n / 2);
      first.push_back(0);
      std::sort(first.begin(), first.end());
      int gap = 0;
      for (size_t i = 1; i < first.size(); ++i) gap = std::max(gap, first[i] - first[i - 1]);
      EXPECT_LE(gap, 4) << "n=" << n;
    }
  }
  // it stops at the first refusal
  int visits = 0;
  EXPECT_FALSE(VisitEdgeStatesCoarseToFine(100, [&](int k) {
    ++visits;
    return k != 64;
  }));
  EXPECT_EQ(visits, 2);  // 100, then 64
}

TEST(RobotCollisionCheckerTest, TheThreeWaysOfPlacingTheCapsulesAgree) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("iiwa14");
  const RobotCollisionModel model(robot);
  RobotCollisionData by_q(model), by_kin(model), by_poses(model);
  std::mt19937_64 rng(3);
  const VectorXd q = testing::RandomConfiguration(robot.model, rng);
  kinematics::Data kin(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &kin);
  PlaceRobot(model, q, &by_q);
  PlaceRobot(model, kin, &by_kin);
  PlaceRobot(model, std::span<const Eigen::Isometry3d>(kin.X_WL), &by_poses);
  for (int c = 0; c < model.num_capsules(); ++c) {
    for (const RobotCollisionData* d : {&by_kin, &by_poses}) {
      EXPECT_EQ(d->capsule_W[c].p_WA, by_q.capsule_W[c].p_WA);
      EXPECT_EQ(d->capsule_W[c].p_WB, by_q.capsule_W[c].p_WB);
      EXPECT_EQ(d->capsule_sphere[c], by_q.capsule_sphere[c]);
    }
  }
  // each capsule's and each link group's sphere holds its capsules
  for (int c = 0; c < model.num_capsules(); ++c) {
    const math::Capsule& w = by_q.capsule_W[c];
    for (const Vector3d& p : {w.p_WA, w.p_WB}) {
      EXPECT_LE((p - by_q.capsule_sphere[c].head<3>()).norm() + w.radius, by_q.capsule_sphere[c][3]);
    }
  }
  for (size_t g = 0; g < model.link_groups().size(); ++g) {
    for (int c : model.link_groups()[g].capsules) {
      const math::Capsule& w = by_q.capsule_W[c];
      for (const Vector3d& p : {w.p_WA, w.p_WB}) {
        EXPECT_LE((p - by_q.group_sphere[g].head<3>()).norm() + w.radius, by_q.group_sphere[g][3]);
      }
    }
  }
}

TEST(RobotCollisionCheckerTest, ModelListsTheCheckedPairsBothWaysAndTheFloorCapsules) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const RobotCollisionModel model(robot);
  std::vector<std::pair<int, int>> grouped = model.grouped_self_pairs();
  for (auto& [a, b] : grouped) {
    if (a > b) std::swap(a, b);
  }
  std::sort(grouped.begin(), grouped.end());
  EXPECT_EQ(grouped, model.self_pairs());
  for (size_t i = 1; i < model.self_pairs().size(); ++i) EXPECT_LT(model.self_pairs()[i - 1], model.self_pairs()[i]);
  // the Panda's base and joint-1 column cannot reach the floor; its wrist can
  const int link0 = robot.model.LinkIndex("panda_link0"), link1 = robot.model.LinkIndex("panda_link1");
  const int link6 = robot.model.LinkIndex("panda_link6");
  for (int c = 0; c < model.num_capsules(); ++c) {
    const int link = robot.capsules[c].link;
    if (link == link0 || link == link1) {
      EXPECT_FALSE(model.floor_checked(c));
    }
    if (link == link6) {
      EXPECT_TRUE(model.floor_checked(c));
    }
  }
  EXPECT_THROW(RobotCollisionModel(robot, {.check_floor = true, .floor_height = NAN}), InputError);
}

TEST(RobotCollisionCheckerTest, ACheckAllocatesNothing) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const RobotCollisionModel model(robot);
  RobotCollisionData data(model);
  std::mt19937_64 rng(9);
  const VectorXd q0 = testing::RandomConfiguration(robot.model, rng);
  const VectorXd q1 = testing::RandomConfiguration(robot.model, rng);
  const std::vector<rmp::Obstacle> obstacles = ObstaclesNear(robot, q0, rng);
  VectorXd scratch(robot.model.nq());
  const long before = testing::AllocationCount();
  bool any = CheckConfigCollisionFree(model, q0, obstacles, 0.01, &data);
  any = CheckEdgeCollisionFree(model, q0, q1, obstacles, 0.01, 0.05, &data, &scratch) || any;
  const ClearancePair pair = CalcRobotClearance(model, q1, obstacles, &data);
  EXPECT_EQ(testing::AllocationCount(), before);
  EXPECT_TRUE(std::isfinite(pair.distance));
  (void)any;
}

}  // namespace
}  // namespace rmpmarl::collision
