// Plan, then react (planning/plan_follow.h) on the Panda in MuJoCo: a joint goal behind a wall reached open loop (the
// plan executed on the clock) and by RMPflow following the plan, and approached by the learned controller following
// it, without a collision event; the options refused by name. Planning runs on an iteration budget, so the plans are the same on any machine.
#include "rmpmarl/planning/plan_follow.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <memory>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::planning {
namespace {

using Eigen::Vector3d;
using Eigen::VectorXd;

// the Panda reaching 45 cm to its left and 15 cm down, a 24 × 4 × 36 cm wall across the straight way
struct Problem {
  kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  VectorXd q_start, q_goal;
  Vector3d p_WT;
  sim::ObstacleSpec wall;
};

Problem WallProblem() {
  Problem p;
  p.q_start = sim::ReadyConfiguration(p.robot);
  kinematics::Data data(p.robot.model);
  kinematics::CalcForwardKinematics(p.robot.model, p.q_start, &data);
  const kinematics::EndEffector& ee = p.robot.end_effector;
  const Vector3d p0 = kinematics::CalcPointPosition(data, ee.link, ee.X_LE.translation());
  const Vector3d target = p0 + Vector3d(0.0, 0.45, -0.15);
  Eigen::Isometry3d X_WO = Eigen::Isometry3d::Identity();
  X_WO.translation() = 0.5 * (p0 + target) + Vector3d(0.05, 0.0, 0.0);
  p.wall = sim::ObstacleSpec::Box(Vector3d(0.12, 0.02, 0.18), X_WO);
  // the joint goal: a collision-free IK solution at the target
  rmp::Scene scene;
  scene.obstacles.push_back(p.wall.AsRmp(X_WO));
  scene.p_WT = target;
  RrtPolicy ik(p.robot, {.seed = 2});
  const IkResult solution = ik.SolveIk(p.q_start, scene);
  EXPECT_TRUE(solution.reached);
  p.q_goal = solution.q;
  kinematics::CalcForwardKinematics(p.robot.model, p.q_goal, &data);
  p.p_WT = kinematics::CalcPointPosition(data, ee.link, ee.X_LE.translation());
  return p;
}

struct Outcome {
  sim::EpisodeMetrics metrics;
  double joint_error = 0.0;
  PlanFollowStats stats;
};

// one 8 s episode in MuJoCo: `reactive` (null: open loop) following plans toward the joint goal
Outcome Follow(const Problem& p, std::unique_ptr<control::AccelerationPolicy> reactive,
            const control::ControllerOptions& controller_options = {}) {
  sim::StaticScenario scenario(p.robot, {.q_start = p.q_start, .p_WT = p.p_WT, .obstacles = {p.wall},
                                         .q_goal = p.q_goal});
  auto model = std::make_shared<const sim::WorldModel>(p.robot, scenario.scene_spec(),
                                                       sim::WorldOptions{.warning_margin = 0.0});
  sim::World world(model);
  PlanFollowOptions options;
  const double period = 1.0 / controller_options.control_rate;
  options.planner.evaluation_period = period / control::ControlSubsteps(period, controller_options);
  options.planner.planning_time_budget = 3600.0;
  options.planner.planning_iterations = 20000;
  options.planner.seed = 4;
  if (!reactive) options.replan = false;
  auto follower = std::make_unique<PlanFollowPolicy>(p.robot, std::move(reactive), options);
  PlanFollowPolicy* f = follower.get();
  control::ReactiveController controller(model->servos(), std::move(follower), controller_options);
  Outcome o;
  o.metrics = sim::RunEpisode({.duration = 8.0}, world, controller, scenario);
  o.joint_error = (world.q() - p.q_goal).cwiseAbs().maxCoeff();
  o.stats = f->stats();
  std::printf("[ follow   ] %s: final error %.2f mm, joint error %.4f rad, reached after %.2f s, min clearance "
              "%.1f mm, %d collision events, %d plans (%d stalled, %d blocked)\n", f->name().c_str(),
              1e3 * o.metrics.final_tracking_error, o.joint_error, o.metrics.time_to_reach,
              1e3 * o.metrics.min_clearance, o.metrics.collisions, o.stats.plans_attempted,
              o.stats.replans_stalled, o.stats.replans_blocked);
  return o;
}

TEST(PlanFollowTest, OpenLoopExecutesThePlanToTheJointGoal) {
  const Problem p = WallProblem();
  const Outcome o = Follow(p, nullptr);
  EXPECT_EQ(o.stats.plans_attempted, 1);
  EXPECT_EQ(o.stats.plans_succeeded, 1);
  EXPECT_GT(o.stats.first_path_length, (p.q_goal - p.q_start).norm());  // around the wall, not straight through
  EXPECT_EQ(o.metrics.collisions, 0);
  EXPECT_LT(o.joint_error, 0.01);
  EXPECT_LT(o.metrics.final_tracking_error, 0.005);
}

TEST(PlanFollowTest, RmpflowFollowsThePlanAroundTheWall) {
  const Problem p = WallProblem();
  const Outcome o = Follow(p, std::make_unique<control::RmpflowAccelerationPolicy>(p.robot, 1));
  EXPECT_GE(o.stats.plans_succeeded, 1);
  EXPECT_EQ(o.metrics.collisions, 0);
  EXPECT_TRUE(o.metrics.reached);
  EXPECT_LT(o.metrics.final_tracking_error, 0.02);
}

TEST(PlanFollowTest, TheLearnedControllerFollowsThePlanAroundTheWall) {
  const Problem p = WallProblem();
  const std::filesystem::path path = kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp";
  auto learned = control::MakeLearnedController(p.robot, control::LoadPolicyFile(path), path.string(), 1);
  const control::ControllerOptions options = learned->controller_options();
  const Outcome o = Follow(p, std::move(learned), options);
  EXPECT_GE(o.stats.plans_succeeded, 1);
  EXPECT_EQ(o.metrics.collisions, 0);
  // around the wall and most of the way back in: the shipped agents, trained among small cubes in the open, hold off
  // the wall near the goal (measured 119 mm short of the 0.37 m reach; RMPflow: 4 mm)
  const double start_error = (p.p_WT - [&] {
    kinematics::Data data(p.robot.model);
    kinematics::CalcForwardKinematics(p.robot.model, p.q_start, &data);
    return kinematics::CalcPointPosition(data, p.robot.end_effector.link, p.robot.end_effector.X_LE.translation());
  }()).norm();
  EXPECT_LT(o.metrics.final_tracking_error, 0.5 * start_error);
}

// the goal moving: a joint goal moved by more than the tolerance, or a target by more than goal_shift, is planned for
// anew; smaller moves keep the plan
TEST(PlanFollowTest, AMovedGoalIsPlannedForAnew) {
  const Problem p = WallProblem();
  PlanFollowOptions options;
  options.planner.planning_time_budget = 3600.0;
  options.planner.planning_iterations = 20000;
  PlanFollowPolicy follower(p.robot, std::make_unique<control::RmpflowAccelerationPolicy>(p.robot, 1), options);
  rmp::Scene scene;
  scene.obstacles.push_back(p.wall.AsRmp(p.wall.X_WO));
  scene.p_WT = p.p_WT;
  scene.q_T = p.q_goal;
  const VectorXd qd = VectorXd::Zero(7);
  VectorXd qdd(7);
  follower.Reset(p.q_start);
  auto step = [&](int n) {
    for (int k = 0; k < n; ++k) {
      follower.BeginControlStep(p.q_start, qd, scene);
      follower.Evaluate(p.q_start, qd, scene, qdd);
    }
  };
  step(10);
  EXPECT_EQ(follower.stats().plans_attempted, 1);
  scene.q_T[0] += 0.5 * options.goal_tolerance;  // within the tolerance: the same plan
  step(10);
  EXPECT_EQ(follower.stats().replans_moved, 0);
  scene.q_T[0] += 2.0 * options.goal_tolerance;
  step(10);
  EXPECT_EQ(follower.stats().replans_moved, 1);
  EXPECT_EQ(follower.path().back(), scene.q_T);
  // an end-effector target alone (the goal by IK)
  scene.q_T.resize(0);
  step(10);
  EXPECT_EQ(follower.stats().replans_moved, 2);
  scene.p_WT.z() += 0.5 * options.goal_shift;
  step(10);
  EXPECT_EQ(follower.stats().replans_moved, 2);
  scene.p_WT.z() += 2.0 * options.goal_shift;
  step(10);
  EXPECT_EQ(follower.stats().replans_moved, 3);
}

TEST(PlanFollowTest, BadOptionsAndLayersAreRefusedByName) {
  const kinematics::Robot panda = kinematics::LoadShippedRobot("panda");
  for (auto [field, set] : std::initializer_list<std::pair<const char*, void (*)(PlanFollowOptions&)>>{
           {"lookahead", [](PlanFollowOptions& o) { o.lookahead = 0.0; }},
           {"stall_time", [](PlanFollowOptions& o) { o.stall_time = -1.0; }},
           {"check_period", [](PlanFollowOptions& o) { o.check_period = NAN; }},
           {"goal_tolerance", [](PlanFollowOptions& o) { o.goal_tolerance = 0.0; }},
           {"posture_metric", [](PlanFollowOptions& o) { o.posture_metric = INFINITY; }},
           {"goal_shift", [](PlanFollowOptions& o) { o.goal_shift = -0.1; }},
           {"planning_time_budget", [](PlanFollowOptions& o) { o.planner.planning_time_budget = 0.0; }}}) {
    PlanFollowOptions options;
    set(options);
    try {
      PlanFollowPolicy policy(panda, nullptr, options);
      ADD_FAILURE() << "accepted a bad " << field;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
    }
  }
  try {
    PlanFollowPolicy policy(panda, std::make_unique<control::RmpflowAccelerationPolicy>(
                                       kinematics::LoadShippedRobot("ur5e"), 0), {});
    ADD_FAILURE() << "accepted a six-joint layer for the Panda";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("6 joints"), std::string::npos) << e.what();
  }
  EXPECT_EQ(PlanFollowPolicy(panda, nullptr, {}).name(), "rrt-connect");
  EXPECT_EQ(PlanFollowPolicy(panda, std::make_unique<control::RmpflowAccelerationPolicy>(panda, 0), {}).name(),
            "plan+rmpflow");
}

}  // namespace
}  // namespace rmpmarl::planning
