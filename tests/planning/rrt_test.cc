// The RRT baseline (planning/rrt.h) on the Panda: its state validity against brute-force sampling of the capsule
// surfaces, IK against forward kinematics, a planned path around a wall checked at fine resolution, determinism per
// seed, invalidation by a moved obstacle, and the closed loop in MuJoCo. Thresholds are measured with margin; the
// numbers are printed.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <memory>
#include <random>
#include <vector>

#include "../kinematics/test_robots.h"
#include "../support/alloc_counter.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/planning/rrt.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::planning {
namespace {

// a search budget of RRT-Connect iterations instead of wall-clock time, so that a planning test finds the same path
// on any machine and under the sanitizers (which run it several times slower)
RrtOptions IterationBudget(RrtOptions options) {
  options.planning_time_budget = 3600.0;
  options.planning_iterations = 20000;
  return options;
}

using Eigen::Vector3d;
using Eigen::VectorXd;

kinematics::Robot Panda() { return kinematics::LoadShippedRobot("panda"); }

Vector3d EndEffector(const kinematics::Robot& robot, const VectorXd& q) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  return kinematics::CalcPointPosition(data, robot.end_effector.link, robot.end_effector.X_LE.translation());
}

// --- brute force: points sampled on and in the capsules, exact point distances (independent of math/geometry.cc)

// signed distance of point p to a box (Quilez's box SDF in the box frame).
double PointBoxDistance(const Vector3d& p_WP, const math::Box& box) {
  const Vector3d p = box.X_WB.inverse() * p_WP;
  const Vector3d q = p.cwiseAbs() - box.half_size;
  return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
}

double PointSegmentDistance(const Vector3d& p, const Vector3d& a, const Vector3d& b) {
  const Vector3d ab = b - a;
  const double t = ab.squaredNorm() > 0.0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

// points of a capsule: rings of `ring` points on the cylinder at `rows` axial stations and Fibonacci spheres of
// `cap` points around both end points (all on or inside the capsule; the closest point is on its surface).
std::vector<Vector3d> CapsulePoints(const math::Capsule& c, int rows, int ring, int cap) {
  std::vector<Vector3d> points;
  const Vector3d axis = c.p_WB - c.p_WA;
  const Vector3d u = axis.norm() > 1e-12 ? axis.normalized() : Vector3d::UnitZ();
  const Vector3d e1 = u.unitOrthogonal(), e2 = u.cross(e1);
  for (int i = 0; i <= rows; ++i) {
    const Vector3d a = c.p_WA + (static_cast<double>(i) / rows) * axis;
    for (int k = 0; k < ring; ++k) {
      const double phi = 2.0 * M_PI * k / ring;
      points.push_back(a + c.radius * (std::cos(phi) * e1 + std::sin(phi) * e2));
    }
  }
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (const Vector3d& centre : {c.p_WA, c.p_WB}) {
    for (int k = 0; k < cap; ++k) {
      const double z = 1.0 - 2.0 * (k + 0.5) / cap, r = std::sqrt(1.0 - z * z);
      points.push_back(centre + c.radius * Vector3d(r * std::cos(golden * k), r * std::sin(golden * k), z));
    }
  }
  return points;
}

// smallest distance between the robot's capsules at q and the box, and between checked capsule pairs, by sampling.
double BruteForceClearance(const kinematics::Robot& robot, const VectorXd& q, const math::Box& box) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  std::vector<math::Capsule> capsules;
  for (const auto& c : robot.capsules) {
    capsules.push_back({data.X_WL[c.link] * c.p_LA, data.X_WL[c.link] * c.p_LB, c.radius});
  }
  double d = INFINITY;
  for (size_t a = 0; a < capsules.size(); ++a) {
    for (const Vector3d& p : CapsulePoints(capsules[a], 60, 90, 1500)) {
      d = std::min(d, PointBoxDistance(p, box));
      for (size_t b = a + 1; b < capsules.size(); ++b) {
        const int la = robot.capsules[a].link, lb = robot.capsules[b].link;
        if (la == lb || robot.IsExcludedPair(la, lb)) continue;
        d = std::min(d, PointSegmentDistance(p, capsules[b].p_WA, capsules[b].p_WB) - capsules[b].radius);
      }
    }
  }
  return d;
}

TEST(RrtOptionsTest, BadOptionsThrowInputError) {
  const kinematics::Robot panda = Panda();
  EXPECT_NO_THROW(RrtPolicy(panda, RrtOptions{}));
  const std::vector<std::pair<const char*, RrtOptions>> bad = {
      {"evaluation_period", {.evaluation_period = 0.0}},
      {"replan_period", {.replan_period = -0.1}},
      {"retry_period", {.retry_period = NAN}},
      {"planning_time_budget", {.planning_time_budget = INFINITY}},
      {"ik_seeds", {.ik_seeds = 0}},
      {"ik_iterations", {.ik_iterations = 0}},
      {"ik_damping", {.ik_damping = 0.0}},
      {"ik_max_step", {.ik_max_step = -1.0}},
      {"ik_tolerance", {.ik_tolerance = 0.0}},
      {"floor_height", {.floor_height = NAN}},
      {"safety_margin", {.safety_margin = -0.01}},
      {"end_margin_distance", {.end_margin_distance = NAN}},
      {"validity_resolution", {.validity_resolution = 0.0}},
      {"path_speed_fraction", {.path_speed_fraction = 1.5}},
      {"range", {.range = -0.5}},
      {"kp", {.kp = 0.0}},
      {"kd", {.kd = -1.0}},
  };
  for (const auto& [field, options] : bad) {
    try {
      RrtPolicy policy(panda, options);
      ADD_FAILURE() << field << ": no InputError";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("RrtOptions.") + field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("expected"), std::string::npos) << e.what();
    }
  }
  RrtPolicy policy(panda, RrtOptions{});
  EXPECT_THROW(policy.Reset(VectorXd::Zero(3)), InputError);
  EXPECT_EQ(policy.name(), "rrt");
  EXPECT_EQ(policy.nq(), 7);
}

// Validity = every capsule–box and checked capsule–capsule distance > safety_margin, compared with sampling of the
// capsules (~1 mm spacing) on random Panda configurations with a random box placed near a random capsule.
TEST(RrtValidityTest, AgreesWithBruteForceSampling) {
  const kinematics::Robot panda = Panda();
  RrtPolicy policy(panda, {.check_floor = false});
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> U(0.0, 1.0);
  int valid = 0, invalid = 0, ambiguous = 0;
  double worst = 0.0;
  const double margin = policy.options().safety_margin;
  for (int trial = 0; trial < 150; ++trial) {
    const VectorXd q = testing::RandomConfiguration(panda.model, rng);
    kinematics::Data data(panda.model);
    kinematics::CalcForwardKinematics(panda.model, q, &data);
    const auto& c = panda.capsules[rng() % panda.capsules.size()];
    const Vector3d p_axis = data.X_WL[c.link] * (c.p_LA + U(rng) * (c.p_LB - c.p_LA));
    math::Box box;
    box.half_size = Vector3d(0.02 + 0.08 * U(rng), 0.02 + 0.08 * U(rng), 0.02 + 0.08 * U(rng));
    std::normal_distribution<double> N(0.0, 1.0);
    box.X_WB.linear() = Eigen::Quaterniond(N(rng), N(rng), N(rng), N(rng)).normalized().toRotationMatrix();
    const Vector3d dir = Vector3d(U(rng) - 0.5, U(rng) - 0.5, U(rng) - 0.5).normalized();
    box.X_WB.translation() = p_axis + dir * (c.radius + box.half_size.norm() + 0.15 * U(rng) - 0.03);
    rmp::Scene scene;
    scene.obstacles.push_back(rmp::Obstacle::MakeBox(box.X_WB, box.half_size));
    const double clearance = policy.Clearance(q, scene);
    const double brute = BruteForceClearance(panda, q, box);
    if (brute > 0.0) {
      EXPECT_GE(brute, clearance - 1e-9) << "trial " << trial;  // sampling never undercuts the exact distance
      worst = std::max(worst, brute - clearance);
    } else {
      EXPECT_LE(clearance, 1e-9) << "trial " << trial;
    }
    if (std::abs(brute - margin) < 2e-3) {
      ++ambiguous;
      continue;
    }
    const bool expected = brute > margin;
    EXPECT_EQ(policy.IsStateValid(q, scene), expected) << "trial " << trial << " brute " << brute;
    ++(expected ? valid : invalid);
  }
  std::printf("[ validity ] 150 random Panda configurations: %d valid, %d invalid, %d within 2 mm of the margin; "
              "sampling exceeds the exact clearance by <= %.2f mm\n", valid, invalid, ambiguous, 1000.0 * worst);
  EXPECT_LT(worst, 1e-3);  // measured 0.51 mm
  EXPECT_GT(valid, 40);    // measured 65 valid, 79 invalid
  EXPECT_GT(invalid, 40);
}

// ClearanceWithPair: the same distance as Clearance, and the pair attaining it — an obstacle by its index, the floor,
// or two links — recomputed here from the capsules of the links it names
TEST(RrtValidityTest, ClearanceWithPairNamesWhatAttainsIt) {
  const kinematics::Robot panda = Panda();
  const VectorXd ready = sim::ReadyConfiguration(panda);
  kinematics::Data data(panda.model);
  kinematics::CalcForwardKinematics(panda.model, ready, &data);
  auto capsules_of = [&](int link) {
    std::vector<math::Capsule> out;
    for (const kinematics::LinkCapsule& c : panda.capsules) {
      if (c.link == link) out.push_back(kinematics::WorldCapsule(c, data));
    }
    return out;
  };
  // a far sphere (0) and a box whose top is 1 cm below the end effector (1)
  const Vector3d p_WE = EndEffector(panda, ready);
  rmp::Scene scene;
  scene.obstacles.push_back(rmp::Obstacle::MakeSphere(Vector3d(-1.0, -1.0, 1.0), 0.1));
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.translation() = p_WE - Vector3d(0.0, 0.0, 0.06);
  scene.obstacles.push_back(rmp::Obstacle::MakeBox(X_WB, Vector3d(0.1, 0.1, 0.05)));
  RrtPolicy policy(panda, {.check_floor = false});
  ClearancePair pair = policy.ClearanceWithPair(ready, scene);
  EXPECT_EQ(pair.distance, policy.Clearance(ready, scene));
  ASSERT_EQ(pair.kind, ClearancePair::Kind::kObstacle);
  EXPECT_EQ(pair.obstacle, 1);
  double d = INFINITY;
  for (const math::Capsule& c : capsules_of(pair.link)) {
    d = std::min(d, rmp::CapsuleObstacleDistance(c, scene.obstacles[1]).distance);
  }
  EXPECT_DOUBLE_EQ(d, pair.distance);
  // no obstacle: two links of the arm (the nearest checked pair)
  pair = policy.ClearanceWithPair(ready, {});
  ASSERT_EQ(pair.kind, ClearancePair::Kind::kSelf);
  EXPECT_FALSE(panda.IsExcludedPair(pair.link, pair.other_link));
  d = INFINITY;
  for (const math::Capsule& a : capsules_of(pair.link)) {
    for (const math::Capsule& b : capsules_of(pair.other_link)) {
      d = std::min(d, math::CapsuleCapsuleDistance(a, b).distance);
    }
  }
  EXPECT_DOUBLE_EQ(d, pair.distance);
  EXPECT_EQ(pair.distance, policy.Clearance(ready, {}));
  // the wrist below the mounting plane: the floor
  VectorXd down = ready;
  down[1] = 1.7;
  down[3] = -0.3;
  RrtPolicy floor(panda);
  pair = floor.ClearanceWithPair(down, {});
  EXPECT_EQ(pair.kind, ClearancePair::Kind::kFloor);
  EXPECT_LT(pair.distance, 0.0);
  EXPECT_EQ(pair.distance, floor.Clearance(down, {}));
}

TEST(RrtValidityTest, FloorChecksMovingLinksOnly) {
  const kinematics::Robot panda = Panda();
  RrtPolicy policy(panda);
  const VectorXd ready = sim::ReadyConfiguration(panda);
  EXPECT_TRUE(policy.IsStateValid(ready, {}));  // the joint-1 column resting on z = 0 is not a floor contact
  VectorXd down = ready;
  down[1] = 1.7;  // shoulder pitched forward and down: the wrist goes below the mounting plane
  down[3] = -0.3;
  EXPECT_LT(EndEffector(panda, down).z(), 0.0);
  EXPECT_FALSE(policy.IsStateValid(down, {}));
  RrtPolicy no_floor(panda, {.check_floor = false});
  EXPECT_TRUE(no_floor.IsStateValid(down, {}));
}

// IK: targets at the end effector of random valid configurations are reached within ik_tolerance from the ready
// posture, and the solution is valid (checked by forward kinematics here).
TEST(RrtIkTest, ReachesTargetsOfRandomConfigurations) {
  const kinematics::Robot panda = Panda();
  RrtPolicy policy(panda);
  const VectorXd ready = sim::ReadyConfiguration(panda);
  std::mt19937_64 rng(11);
  int targets = 0, reached = 0;
  double worst = 0.0;
  while (targets < 100) {
    const VectorXd q = testing::RandomConfiguration(panda.model, rng);
    rmp::Scene scene;
    scene.p_WT = EndEffector(panda, q);
    if (scene.p_WT.z() < 0.15 || !policy.IsStateValid(q, scene)) continue;
    ++targets;
    const IkResult ik = policy.SolveIk(ready, scene);
    ASSERT_TRUE(ik.found);
    if (!ik.reached) continue;
    ++reached;
    const double error = (EndEffector(panda, ik.q) - scene.p_WT).norm();
    EXPECT_NEAR(error, ik.error, 1e-12);
    EXPECT_LE(error, policy.options().ik_tolerance);
    EXPECT_TRUE(policy.IsStateValid(ik.q, scene));
    worst = std::max(worst, error);
  }
  std::printf("[ ik       ] %d/%d targets reached, worst error %.3f mm\n", reached, targets, 1000.0 * worst);
  EXPECT_GE(reached, 95);
}

// A wall between the ready end effector and the target; the straight joint-space segment hits it.
struct WallSetup {
  VectorXd q_start;
  Vector3d p_WT;
  Eigen::Isometry3d X_WO = Eigen::Isometry3d::Identity();
  Vector3d half_size;
  rmp::Scene scene;
};

WallSetup MakeWall(const kinematics::Robot& panda) {
  WallSetup w;
  w.q_start = sim::ReadyConfiguration(panda);
  const Vector3d p0 = EndEffector(panda, w.q_start);
  w.p_WT = p0 + Vector3d(0.0, 0.45, -0.15);
  w.X_WO.translation() = 0.5 * (p0 + w.p_WT) + Vector3d(0.05, 0.0, 0.0);
  w.half_size = Vector3d(0.12, 0.02, 0.18);
  w.scene.obstacles.push_back(rmp::Obstacle::MakeBox(w.X_WO, w.half_size));
  w.scene.p_WT = w.p_WT;
  return w;
}

// smallest clearance along the path's straight segments sampled every `step` rad.
double PathClearance(RrtPolicy& policy, const std::vector<VectorXd>& path, const rmp::Scene& scene, double step) {
  double d = INFINITY;
  for (size_t k = 1; k < path.size(); ++k) {
    const int n = std::max(1, static_cast<int>(std::ceil((path[k] - path[k - 1]).norm() / step)));
    for (int i = 0; i <= n; ++i) {
      d = std::min(d, policy.Clearance(path[k - 1] + (double(i) / n) * (path[k] - path[k - 1]), scene));
    }
  }
  return d;
}

TEST(RrtPlanningTest, PathAroundAWallIsCollisionFreeAndReachesTheGoal) {
  const kinematics::Robot panda = Panda();
  const WallSetup w = MakeWall(panda);
  RrtPolicy policy(panda, IterationBudget({.seed = 3}));
  ASSERT_TRUE(policy.IsStateValid(w.q_start, w.scene));
  const IkResult ik = policy.SolveIk(w.q_start, w.scene);
  ASSERT_TRUE(ik.reached);
  const std::vector<VectorXd> straight = {w.q_start, ik.q};
  const double straight_clearance = PathClearance(policy, straight, w.scene, 1e-3);
  EXPECT_LT(straight_clearance, 0.0);  // the wall blocks the straight segment: the planner has to go around
  const auto t0 = std::chrono::steady_clock::now();
  const std::vector<VectorXd> path = policy.PlanPath(w.q_start, ik.q, w.scene);
  const double plan_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ASSERT_FALSE(path.empty());
  EXPECT_EQ(path.front(), w.q_start);
  EXPECT_EQ(path.back(), ik.q);
  const double clearance = PathClearance(policy, path, w.scene, 1e-3);
  std::printf("[ plan     ] wall: straight segment clearance %.1f mm; RRT-Connect + shortcut in %.2f ms: %zu "
              "waypoints, clearance %.2f mm at 1 mrad resolution\n", 1000.0 * straight_clearance, plan_ms, path.size(),
              1000.0 * clearance);
  EXPECT_GT(clearance, 0.0);
  EXPECT_LT((EndEffector(panda, path.back()) - w.p_WT).norm(), policy.options().ik_tolerance);

  // the iteration budget ends a search: one iteration does not get around the wall
  RrtPolicy starved(panda, {.planning_time_budget = 3600.0, .planning_iterations = 1, .seed = 3});
  EXPECT_TRUE(starved.PlanPath(w.q_start, ik.q, w.scene).empty());

  // the same seed gives the same path; the plan does not depend on other instances' sampling
  RrtPolicy other(panda, IterationBudget({.seed = 99}));
  const std::vector<VectorXd> other_path = other.PlanPath(w.q_start, ik.q, w.scene);
  ASSERT_GE(other_path.size(), 3u);
  EXPECT_NE(other_path[1], path[1]);  // another seed, another RRT state
  RrtPolicy again(panda, IterationBudget({.seed = 3}));
  const std::vector<VectorXd> repeat = again.PlanPath(w.q_start, ik.q, w.scene);
  ASSERT_EQ(repeat.size(), path.size());
  for (size_t k = 0; k < path.size(); ++k) EXPECT_EQ(repeat[k], path[k]);
}

// random shortcuts after the greedy one: the same ends, a path no longer than the greedy one's (shorter around the
// wall), valid at the margin and collision-free at a finer resolution than it was checked at, the same for the same
// seed
TEST(RrtPlanningTest, RandomShortcutsShortenThePathAndKeepItValid) {
  const kinematics::Robot panda = Panda();
  const WallSetup w = MakeWall(panda);
  RrtPolicy greedy(panda, IterationBudget({.seed = 3}));
  const IkResult ik = greedy.SolveIk(w.q_start, w.scene);
  ASSERT_TRUE(ik.reached);
  auto length = [](const std::vector<VectorXd>& path) {
    double l = 0.0;
    for (size_t k = 1; k < path.size(); ++k) l += (path[k] - path[k - 1]).norm();
    return l;
  };
  const std::vector<VectorXd> base = greedy.PlanPath(w.q_start, ik.q, w.scene);
  ASSERT_FALSE(base.empty());
  RrtOptions options = IterationBudget({.seed = 3});
  options.shortcut_iterations = 200;
  RrtPolicy shortcut(panda, options);
  const std::vector<VectorXd> path = shortcut.PlanPath(w.q_start, ik.q, w.scene);
  ASSERT_FALSE(path.empty());
  EXPECT_EQ(path.front(), w.q_start);
  EXPECT_EQ(path.back(), ik.q);
  std::printf("[ shortcut ] wall: greedy %.3f rad (%zu waypoints), + 200 random shortcuts %.3f rad (%zu)\n",
              length(base), base.size(), length(path), path.size());
  EXPECT_LT(length(path), length(base) - 1e-3);
  for (size_t k = 1; k < path.size(); ++k) {
    EXPECT_TRUE(shortcut.IsSegmentValid(path[k - 1], path[k], w.scene, options.safety_margin)) << "segment " << k;
  }
  EXPECT_GT(PathClearance(shortcut, path, w.scene, 1e-3), 0.0);
  RrtPolicy again(panda, options);
  const std::vector<VectorXd> repeat = again.PlanPath(w.q_start, ik.q, w.scene);
  ASSERT_EQ(repeat.size(), path.size());
  for (size_t k = 0; k < path.size(); ++k) EXPECT_EQ(repeat[k], path[k]);
  options.shortcut_iterations = -1;
  EXPECT_THROW(RrtPolicy(panda, options), InputError);
}

// a start inside the safety margin (a sphere 4 mm above the hand) is planned from with half its clearance (2 mm) as
// the margin. The straight way to a goal 1 rad of the first joint away passes 5 mm from a second sphere half-way:
// planned with the relaxed margin everywhere (end_margin_distance 0) the path is that straight way; with the margin
// relaxed only within 0.3 rad of the start, every waypoint keeps the margin growing linearly from 2 mm to
// safety_margin over that distance, and beyond it the path keeps safety_margin at a finer resolution than it was
// checked at (to a tenth of it)
TEST(RrtPlanningTest, AStartInsideTheMarginRelaxesItOnlyNearTheStart) {
  const kinematics::Robot panda = Panda();
  const VectorXd q_start = sim::ReadyConfiguration(panda);
  VectorXd q_goal = q_start;
  q_goal[0] += 1.0;
  RrtPolicy probe(panda, IterationBudget({}));
  // a 3 cm sphere above the hand at q, lifted until the clearance there is d
  auto sphere_above = [&](const rmp::Scene& scene, const VectorXd& q, double d) {
    const Vector3d p_WE = EndEffector(panda, q);
    double h = 0.1;
    rmp::Scene s = scene;
    s.obstacles.emplace_back();
    for (int k = 0; k < 50; ++k) {
      s.obstacles.back() = rmp::Obstacle::MakeSphere(p_WE + Vector3d(0.0, 0.0, h), 0.03);
      h += d - probe.Clearance(q, s);
    }
    return s;
  };
  rmp::Scene scene = sphere_above(rmp::Scene{}, q_start, 0.004);
  scene = sphere_above(scene, 0.5 * (q_start + q_goal), 0.005);
  ASSERT_NEAR(probe.Clearance(q_start, scene), 0.004, 1e-6);
  // the smallest clearance of a path's states at least `from` away from the start, sampled every 1 mrad
  auto clearance_beyond = [&](const std::vector<VectorXd>& path, double from) {
    double d = INFINITY;
    for (size_t k = 1; k < path.size(); ++k) {
      const int n = static_cast<int>(std::ceil((path[k] - path[k - 1]).norm() / 1e-3));
      for (int i = 0; i <= n; ++i) {
        const VectorXd q = path[k - 1] + (double(i) / n) * (path[k] - path[k - 1]);
        if ((q - q_start).norm() >= from) d = std::min(d, probe.Clearance(q, scene));
      }
    }
    return d;
  };
  RrtOptions options = IterationBudget({.seed = 5});
  const double safety = options.safety_margin, relaxed = 0.002, distance = 0.3;
  RrtPolicy everywhere(panda, options);
  const std::vector<VectorXd> straight = everywhere.PlanPath(q_start, q_goal, scene);
  ASSERT_EQ(straight.size(), 2u) << "valid at 2 mm, the straight way is the path";
  const double straight_clearance = clearance_beyond(straight, distance);
  EXPECT_LT(straight_clearance, 0.006);

  options.end_margin_distance = distance;
  RrtPolicy near_start(panda, options);
  const std::vector<VectorXd> path = near_start.PlanPath(q_start, q_goal, scene);
  ASSERT_GE(path.size(), 3u) << "the straight way passes the second sphere inside the margin";
  EXPECT_NEAR(near_start.last_plan_margin(), relaxed, 1e-9);
  for (size_t k = 1; k < path.size(); ++k) {
    const double f = std::min(1.0, (path[k] - q_start).norm() / distance);
    EXPECT_GT(probe.Clearance(path[k], scene), relaxed + (safety - relaxed) * f) << "waypoint " << k;
  }
  const double far_clearance = clearance_beyond(path, distance);
  std::printf("[ margin   ] start 4.0 mm from a sphere: beyond %.1f rad of it the straight way passes %.2f mm from "
              "the other, the path (%zu waypoints) %.2f mm\n", distance, 1e3 * straight_clearance, path.size(),
              1e3 * far_clearance);
  EXPECT_GT(far_clearance, 0.9 * safety);
}

// the margin near the ends is the obstacles': an arm that keeps two of its links (or a link and the floor) inside the
// margin everywhere — here a 20 cm margin, inside which the Panda's checked self pairs stay at its ready posture — still
// plans, its self-collision and floor margin half the ends' own clearance on the whole path, as without
// end_margin_distance. Turning the first joint by 1 rad moves no link relative to another: the straight way is the path.
TEST(RrtPlanningTest, LinksThatStayInsideTheMarginDoNotBlockARelaxedPlan) {
  const kinematics::Robot panda = Panda();
  const VectorXd q_start = sim::ReadyConfiguration(panda);
  VectorXd q_goal = q_start;
  q_goal[0] += 1.0;
  RrtOptions options = IterationBudget({.safety_margin = 0.2, .seed = 5});
  options.end_margin_distance = 0.3;
  RrtPolicy policy(panda, options);
  const rmp::Scene empty;
  const double clearance = policy.Clearance(q_start, empty);
  ASSERT_GT(clearance, 0.0);
  ASSERT_LT(clearance, options.safety_margin) << "a pair inside the margin at the start";
  const std::vector<VectorXd> path = policy.PlanPath(q_start, q_goal, empty);
  ASSERT_EQ(path.size(), 2u);
  EXPECT_NEAR(policy.last_plan_margin(), 0.5 * clearance, 1e-9);
}

// A sphere dropped onto the path being executed invalidates it at the next evaluation: the policy brakes, and replans
// around the sphere once retry_period has passed since the last attempt. Between replans Evaluate allocates nothing.
TEST(RrtPolicyTest, MovedObstacleInvalidatesThePathAndTriggersAReplan) {
  const kinematics::Robot panda = Panda();
  const RrtOptions options{.evaluation_period = 0.01, .retry_period = 0.05, .seed = 5};
  RrtPolicy policy(panda, options);
  const VectorXd q0 = sim::ReadyConfiguration(panda);
  rmp::Scene scene;
  scene.p_WT = EndEffector(panda, q0) + Vector3d(0.0, 0.3, -0.1);
  scene.obstacles.push_back(rmp::Obstacle::MakeSphere(Vector3d(0.0, 0.0, -10.0), 0.05));  // parked
  policy.Reset(q0);
  VectorXd qdd(7);
  const VectorXd qd = VectorXd::Constant(7, 0.1);
  policy.Evaluate(q0, qd, scene, qdd);  // t = 0: plans
  ASSERT_EQ(policy.stats().plans_succeeded, 1);
  ASSERT_FALSE(policy.path().empty());
  EXPECT_EQ(policy.path().front(), q0);
  const long before = rmpmarl::testing::AllocationCount();
  policy.Evaluate(q0, qd, scene, qdd);  // t = 0.01: tracks the path
  EXPECT_EQ(rmpmarl::testing::AllocationCount(), before);
  const VectorXd middle = 0.5 * (policy.path().front() + policy.path().back());
  scene.obstacles[0].sphere.p_WC = EndEffector(panda, middle);
  policy.Evaluate(q0, qd, scene, qdd);  // t = 0.02: the path is invalid, the robot brakes
  EXPECT_EQ(policy.stats().invalidations, 1);
  EXPECT_TRUE(policy.path().empty());
  EXPECT_EQ(policy.stats().plans_attempted, 1);
  EXPECT_TRUE(qdd.isApprox(-options.kd * qd));
  for (int k = 0; k < 3; ++k) policy.Evaluate(q0, qd, scene, qdd);  // t = 0.03 .. 0.05: replans at 0.05
  EXPECT_EQ(policy.stats().plans_attempted, 2);
  EXPECT_EQ(policy.stats().plans_succeeded, 2);
  ASSERT_FALSE(policy.path().empty());
  EXPECT_GT(PathClearance(policy, policy.path(), scene, 1e-3), 0.0);
  policy.Reset(q0);
  EXPECT_EQ(policy.stats().plans_attempted, 0);
  EXPECT_TRUE(policy.stats().planning_times_s.empty());
  EXPECT_TRUE(policy.path().empty());
}

// a ReactiveController (default options) driving an RrtPolicy evaluated at its substep.
struct Rig {
  Rig(const sim::Scenario& scenario, RrtOptions options)
      : model(std::make_shared<const sim::WorldModel>(scenario.robot(), scenario.scene_spec())), world(model) {
    const control::ControllerOptions controller_options;
    const double period = 1.0 / controller_options.control_rate;
    options.evaluation_period = period / std::ceil(period / controller_options.max_substep - 1e-9);
    auto rrt = std::make_unique<RrtPolicy>(scenario.robot(), options);
    policy = rrt.get();
    controller = std::make_unique<control::ReactiveController>(model->servos(), std::move(rrt), controller_options);
  }
  std::shared_ptr<const sim::WorldModel> model;
  sim::World world;
  RrtPolicy* policy = nullptr;
  std::unique_ptr<control::ReactiveController> controller;
};

std::pair<double, double> MeanMaxMs(const std::vector<double>& times) {
  double sum = 0.0, max = 0.0;
  for (double t : times) {
    sum += t;
    max = std::max(max, t);
  }
  return {1000.0 * sum / std::max<size_t>(1, times.size()), 1000.0 * max};
}

// The closed loop in MuJoCo: ReactiveController + World + StaticScenario with the wall; the end effector reaches the
// target without a collision event.
TEST(RrtClosedLoopTest, ReachesTheTargetBehindAWallWithoutCollision) {
  const kinematics::Robot panda = Panda();
  const WallSetup w = MakeWall(panda);
  sim::StaticScenario scenario(panda, {.q_start = w.q_start, .p_WT = w.p_WT,
                                       .obstacles = {sim::ObstacleSpec::Box(w.half_size, w.X_WO)}});
  Rig rig(scenario, IterationBudget({.seed = 1}));
  ASSERT_NEAR(rig.controller->substep(), rig.policy->options().evaluation_period, 1e-12);
  const sim::EpisodeMetrics r = sim::RunEpisode({.duration = 6.0, .seed = 0}, rig.world, *rig.controller, scenario);
  const RrtStats& s = rig.policy->stats();
  const auto [mean_ms, max_ms] = MeanMaxMs(s.planning_times_s);
  std::printf("[ closed   ] wall: final error %.2f mm, within 1 cm after %.2f s, min clearance %.1f mm, %d collision "
              "events; %d/%d plans, %d IK failures, %d invalidations, planning %.2f ms mean / %.2f ms max, control "
              "step %.0f us mean\n", 1000.0 * r.final_tracking_error, r.time_to_reach, 1000.0 * r.min_clearance,
              r.collisions, s.plans_succeeded, s.plans_attempted, s.ik_failures, s.invalidations, mean_ms,
              max_ms, r.mean_control_us);
  EXPECT_EQ(r.collisions, 0);
  EXPECT_GT(1000.0 * r.min_clearance, 0.0);
  EXPECT_LT(1000.0 * r.final_tracking_error, 5.0);  // measured 0.26 mm
  EXPECT_GT(r.time_to_reach, 0.0);
  EXPECT_EQ(r.nonfinite_policy_outputs, 0);
  EXPECT_GT(s.plans_succeeded, 0);
}

// static-obstacle on every shipped arm (Gen3 has continuous joints): a 4 cm sphere in the middle of the straight
// segment from the start end effector to the target; reached without collision.
TEST(RrtClosedLoopTest, ReachesStaticTargetsBehindASphereOnEveryArm) {
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    sim::StaticReachScenario scenario(robot, {.obstacle_on_path = true});
    Rig rig(scenario, IterationBudget({.seed = 2}));
    double worst = 0.0, slowest = 0.0, max_ms = 0.0;
    for (std::uint64_t seed = 0; seed < 3; ++seed) {
      const sim::EpisodeMetrics r =
          sim::RunEpisode({.duration = 6.0, .seed = seed}, rig.world, *rig.controller, scenario);
      EXPECT_LT(1000.0 * r.final_tracking_error, 5.0) << name << " seed " << seed;
      EXPECT_EQ(r.collisions, 0) << name << " seed " << seed;
      worst = std::max(worst, 1000.0 * r.final_tracking_error);
      slowest = std::max(slowest, r.time_to_reach);
      max_ms = std::max(max_ms, MeanMaxMs(rig.policy->stats().planning_times_s).second);
    }
    std::printf("[ reach    ] %-7s 3 targets behind a 4 cm sphere: worst final error %.2f mm, within 1 cm after <= "
                "%.2f s, longest replan %.2f ms\n", name.c_str(), worst, slowest, max_ms);
  }
}

// the paper's crossing scenario (moving target, four crossing cubes): finite throughout; the numbers are printed.
TEST(RrtClosedLoopTest, CrossingScenarioStaysFinite) {
  const kinematics::Robot panda = Panda();
  sim::CrossingScenario scenario(panda);
  Rig rig(scenario, IterationBudget({.seed = 4}));
  const sim::EpisodeMetrics r = sim::RunEpisode({.duration = 10.0, .seed = 0}, rig.world, *rig.controller, scenario);
  const RrtStats& s = rig.policy->stats();
  const auto [mean_ms, max_ms] = MeanMaxMs(s.planning_times_s);
  std::printf("[ crossing ] panda 10 s: tracking %.1f mm mean, %.1f mm max, %d collision events, %d/%d plans, %d IK failures, "
              "%d invalidations, planning %.2f / %.2f ms, control step %.0f us mean / %.0f us max\n",
              1000.0 * r.mean_tracking_error, 1000.0 * r.max_tracking_error, r.collisions, s.plans_succeeded,
              s.plans_attempted, s.ik_failures, s.invalidations, mean_ms, max_ms, r.mean_control_us,
              r.max_control_us);
  EXPECT_FALSE(r.invalid);
  EXPECT_EQ(r.nonfinite_policy_outputs, 0);
  EXPECT_GT(s.plans_succeeded, 0);
}

}  // namespace
}  // namespace rmpmarl::planning
