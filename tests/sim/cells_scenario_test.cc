// `cells`: the target is the end effector at a joint goal MuJoCo finds clear of the cell (its own forward kinematics
// and distances), the cell encloses the target as its kind says (rays from the target against the boards' boxes as
// MuJoCo places them), the object reached for sits at its drawn clearance (brute force over its surface), every
// kind is drawn, the same seed gives the same cell, and bad options name their key.
#include <gtest/gtest.h>

#include <cmath>
#include <map>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/scenario.h"
#include "sim_test_util.h"

namespace rmpmarl::sim {
namespace {

const ContactReport kNoContacts{};

// distance along the ray p + t d (t ≥ 0, d unit) to the box of half sizes h at X_WO, +inf when it misses (slab test
// in the box's frame)
double RayToBox(const Eigen::Vector3d& p, const Eigen::Vector3d& d, const Eigen::Isometry3d& X_WO,
                const Eigen::Vector3d& h) {
  const Eigen::Vector3d a = X_WO.inverse() * p;
  const Eigen::Vector3d u = X_WO.linear().transpose() * d;
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    if (std::abs(u[k]) < 1e-12) {
      if (std::abs(a[k]) > h[k]) return std::numeric_limits<double>::infinity();
      continue;
    }
    double ta = (-h[k] - a[k]) / u[k], tb = (h[k] - a[k]) / u[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return std::numeric_limits<double>::infinity();
  }
  return t0;
}

// the nearest board the ray from p along d meets [m] (+inf: none)
double NearestBoard(World& world, const CellsScenario& s, const Eigen::Vector3d& p, const Eigen::Vector3d& d) {
  double t = std::numeric_limits<double>::infinity();
  for (int j = 0; j < s.options().num_panels; ++j) {
    t = std::min(t, RayToBox(p, d.normalized(), world.ObstaclePose(j), s.scene_spec().obstacles[j].half_size));
  }
  return t;
}

// smallest robot–obstacle distance MuJoCo reports for the world's current state (+inf beyond its margin)
double MujocoObstacleClearance(World& world, int skip = -1) {
  double d = std::numeric_limits<double>::infinity();
  for (const WarningContact& c : world.QueryContacts().warnings) {
    if (c.other_kind == PartnerKind::kObstacle && c.other_index != skip) d = std::min(d, c.distance);
  }
  return d;
}

// brute force: the smallest distance between the arm's capsules at q and points on the surface of the box of half
// sizes h at X_WO (a 41 × 41 grid on each face)
double BoxClearance(const kinematics::Robot& robot, const Eigen::VectorXd& q, const Eigen::Isometry3d& X_WO,
                    const Eigen::Vector3d& h) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  double d = std::numeric_limits<double>::infinity();
  for (const auto& cap : robot.capsules) {
    const math::Capsule w = kinematics::WorldCapsule(cap, data);
    const Eigen::Vector3d ab = w.p_WB - w.p_WA;
    auto to_axis = [&](const Eigen::Vector3d& x) {
      const double s = ab.squaredNorm() > 0 ? std::clamp((x - w.p_WA).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
      return (x - (w.p_WA + s * ab)).norm() - w.radius;
    };
    for (int face = 0; face < 6; ++face) {
      const int k = face / 2, u = (k + 1) % 3, v = (k + 2) % 3;
      for (int i = 0; i <= 40; ++i) {
        for (int j = 0; j <= 40; ++j) {
          Eigen::Vector3d p_O;
          p_O[k] = (face % 2 == 0 ? -1.0 : 1.0) * h[k];
          p_O[u] = h[u] * (-1.0 + 2.0 * i / 40.0);
          p_O[v] = h[v] * (-1.0 + 2.0 * j / 40.0);
          d = std::min(d, to_axis(X_WO * p_O));
        }
      }
    }
  }
  return d;
}

TEST(CellsScenarioTest, EachKindEnclosesATargetTheArmReachesClearOfTheCell) {
  for (const std::string name : {"panda", "ur5e", "iiwa14"}) {
    const kinematics::Robot robot = kinematics::LoadShippedRobot(name);
    for (int kind = 0; kind < kNumCellKinds; ++kind) {
      SCOPED_TRACE(name + " " + std::string(CellKindName(static_cast<CellKind>(kind))));
      CellsOptions o;
      o.kind_weights = {0, 0, 0, 0};
      o.kind_weights[kind] = 1.0;
      o.num_crossing = 0;
      CellsScenario scenario(robot, o);
      WorldOptions wo;
      wo.warning_margin = 0.05;
      World world(std::make_shared<const WorldModel>(robot, scenario.scene_spec(), wo));
      const int grasp = o.num_panels + o.num_objects;
      int graspable = 0;
      for (std::uint64_t seed = 0; seed < 6; ++seed) {
        scenario.Reset(seed, world);
        ASSERT_EQ(static_cast<int>(scenario.cell_kind()), kind);
        const Eigen::VectorXd q_goal = scenario.q_goal();
        // the controllers get the joint goal; the target is its end effector (MuJoCo's kinematics)
        rmp::Scene scene;
        scenario.FillScene(&scene);
        ASSERT_EQ(scene.q_T.size(), robot.model.nq());
        EXPECT_EQ((scene.q_T - q_goal).norm(), 0.0);
        EXPECT_TRUE(scene.v_WT.isZero(0.0));
        for (int i = 0; i < robot.model.nq(); ++i) {
          EXPECT_GE(q_goal[i], robot.model.limits()[i].lower);
          EXPECT_LE(q_goal[i], robot.model.limits()[i].upper);
        }
        // at the start: clear of the cell by start_clearance
        EXPECT_GE(MujocoObstacleClearance(world), o.start_clearance - 1e-6);
        EXPECT_EQ(world.QueryContacts().num_collisions, 0);
        world.Reset(q_goal);
        const Eigen::Vector3d p_T = scene.p_WT;
        EXPECT_LT((world.EndEffectorPosition() - p_T).norm(), 1e-9);
        // at the goal: clear of every board and cube by goal_clearance, of the object reached for by its clearance
        EXPECT_GE(MujocoObstacleClearance(world, grasp), o.goal_clearance - 1e-6);
        EXPECT_EQ(world.QueryContacts().num_collisions, 0);
        const Eigen::Isometry3d X_WG = world.ObstaclePose(grasp);
        if (X_WG.translation().z() > -5.0) {  // placed
          ++graspable;
          const double d = BoxClearance(robot, q_goal, X_WG, scenario.scene_spec().obstacles[grasp].half_size);
          EXPECT_GE(d, o.grasp_clearance[0] - 1e-3);
          EXPECT_LE(d, o.grasp_clearance[1] + 1e-3);
          EXPECT_GE(MujocoObstacleClearance(world), std::min(o.goal_clearance, o.grasp_clearance[0]) - 1e-6);
          // beside the target, not around it, and not into a board (vertically: rays from its centre)
          EXPECT_GT((X_WG.translation() - p_T).head<2>().norm(), o.grasp_object_half_width);
          EXPECT_GE(NearestBoard(world, scenario, X_WG.translation(), Eigen::Vector3d::UnitZ()),
                    o.grasp_object_half_length - 1e-9);
          EXPECT_GE(NearestBoard(world, scenario, X_WG.translation(), -Eigen::Vector3d::UnitZ()),
                    o.grasp_object_half_length - 1e-9);
        }
        // the enclosure, seen from the target
        const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
        int walled = 0;  // of 16 horizontal directions, those meeting a board within 0.6 m
        for (int k = 0; k < 16; ++k) {
          const double a = 2.0 * M_PI * k / 16.0;
          walled += NearestBoard(world, scenario, p_T, Eigen::Vector3d(std::cos(a), std::sin(a), 0.0)) < 0.6;
        }
        switch (static_cast<CellKind>(kind)) {
          case CellKind::kShelf:
            EXPECT_LT(NearestBoard(world, scenario, p_T, up), o.opening_height[1]);
            EXPECT_LT(NearestBoard(world, scenario, p_T, -up), o.opening_height[1]);
            EXPECT_GE(walled, 8);  // back and sides: the front stays open
            EXPECT_LT(walled, 16);
            break;
          case CellKind::kBox:
            EXPECT_LT(NearestBoard(world, scenario, p_T, -up), o.box_height[1] + 1e-9);
            EXPECT_EQ(NearestBoard(world, scenario, p_T, up), std::numeric_limits<double>::infinity());
            if (p_T.z() < world.ObstaclePose(0).translation().z() + 0.5 * o.panel_thickness + o.box_height[0]) {
              EXPECT_EQ(walled, 16);  // below the walls' top edge: walls all round
            }
            break;
          case CellKind::kTable:
            EXPECT_LT(NearestBoard(world, scenario, p_T, -up), 0.15 + 1e-9);
            EXPECT_EQ(NearestBoard(world, scenario, p_T, up), std::numeric_limits<double>::infinity());
            break;
          case CellKind::kUnderTable:
            EXPECT_LT(NearestBoard(world, scenario, p_T, up), o.table_gap[1] + 1e-9);
            EXPECT_GT(NearestBoard(world, scenario, p_T, up), o.table_gap[0] - 1e-9);
            break;
        }
      }
      EXPECT_GT(graspable, 0);
    }
  }
}

TEST(CellsScenarioTest, DrawsEveryKindTheSameForTheSameSeedAndCrossesOnTop) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  const std::unique_ptr<Scenario> made = MakeScenario("cells", robot);
  const auto& scenario = static_cast<const CellsScenario&>(*made);
  const CellsOptions& o = scenario.options();
  EXPECT_EQ(scenario.num_obstacles(), o.num_panels + o.num_objects + 1 + o.num_crossing);
  World world(std::make_shared<const WorldModel>(robot, made->scene_spec()));
  std::map<CellKind, int> kinds;
  for (std::uint64_t seed = 0; seed < 24; ++seed) {
    made->Reset(seed, world);
    ++kinds[scenario.cell_kind()];
    // the crossing cube moves; the cell does not
    const int crossing = scenario.num_obstacles() - 1;
    EXPECT_GT(scenario.obstacles()[crossing].v_WO().norm(), o.crossing_speed - 1e-12);
    EXPECT_LE(scenario.obstacles()[crossing].v_WO().norm(), o.crossing_speed_max + 1e-12);
    for (int j = 0; j < crossing; ++j) EXPECT_TRUE(scenario.obstacles()[j].v_WO().isZero(0.0));
  }
  EXPECT_EQ(kinds.size(), 4u);
  // the same seed: the same start, goal, cell, object and crossing, after another episode
  made->Reset(5, world);
  const Eigen::VectorXd q5 = scenario.q_goal(), start5 = scenario.q_start();
  const std::vector<ObstacleState> obstacles5 = scenario.obstacles();
  made->Reset(6, world);
  made->Reset(5, world);
  EXPECT_EQ((scenario.q_goal() - q5).norm(), 0.0);
  EXPECT_EQ((scenario.q_start() - start5).norm(), 0.0);
  for (int j = 0; j < scenario.num_obstacles(); ++j) {
    EXPECT_EQ(scenario.obstacles()[j].p_WO(), obstacles5[j].p_WO()) << j;
    EXPECT_EQ(scenario.obstacles()[j].R_WO, obstacles5[j].R_WO) << j;
    EXPECT_EQ(scenario.obstacles()[j].v_WO(), obstacles5[j].v_WO()) << j;
  }
  // the overrides: the crossing cubes' speed and count
  std::unique_ptr<Scenario> fixed = MakeScenario("cells", robot, {.obstacle_speed = 0.7, .num_obstacles = 2});
  EXPECT_EQ(fixed->num_obstacles(), o.num_panels + o.num_objects + 1 + 2);
  World fixed_world(std::make_shared<const WorldModel>(robot, fixed->scene_spec()));
  fixed->Reset(3, fixed_world);
  for (int j = fixed->num_obstacles() - 2; j < fixed->num_obstacles(); ++j) {
    EXPECT_NEAR(fixed->obstacles()[j].v_WO().norm(), 0.7, 1e-12);
  }
  EXPECT_THROW(MakeScenario("cells", robot, {.target_speed = 0.1}), InputError);
}

TEST(CellsScenarioTest, BadOptionsNameTheirKey) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  auto message = [&](const CellsOptions& o) {
    try {
      CellsScenario s(robot, o);
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  CellsOptions none;
  none.kind_weights = {0, 0, 0, 0};
  EXPECT_NE(message(none).find("CellsOptions.kind_weights"), std::string::npos);
  CellsOptions few;
  few.num_panels = 3;
  EXPECT_NE(message(few).find("CellsOptions.num_panels"), std::string::npos);
  CellsOptions inverted;
  inverted.opening_width = {0.6, 0.3};
  EXPECT_NE(message(inverted).find("CellsOptions.opening_width"), std::string::npos);
  EXPECT_NE(message(inverted).find("got [0.6, 0.3]"), std::string::npos) << message(inverted);
  CellsOptions narrow;  // too narrow for the target's margins: refused, not drawn from an empty range
  narrow.opening_width = {0.05, 0.1};
  EXPECT_NE(message(narrow).find("CellsOptions.opening_width"), std::string::npos);
  CellsOptions small_boards;
  small_boards.panel_width = 0.1;
  EXPECT_NE(message(small_boards).find("CellsOptions.panel_width"), std::string::npos);
  CellsOptions deep;
  deep.depth = {0.3, 0.9};  // deeper than a board
  EXPECT_NE(message(deep).find("CellsOptions.depth"), std::string::npos);
  CellsOptions bad_probability;
  bad_probability.grasp_object_probability = std::nan("");
  EXPECT_NE(message(bad_probability).find("CellsOptions.grasp_object_probability"), std::string::npos);
  EXPECT_THROW(CellsScenario(kinematics::MakePlanar2()), InputError);  // cells are 3-D
  // options no cell satisfies: InputError after max_attempts, naming the scene
  CellsOptions impossible;
  impossible.goal_clearance = 0.5;
  impossible.max_attempts = 200;
  CellsScenario s(robot, impossible);
  World world(std::make_shared<const WorldModel>(robot, s.scene_spec()));
  try {
    s.Reset(0, world);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("scenario 'cells'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace rmpmarl::sim
