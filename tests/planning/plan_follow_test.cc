// Plan, then react (planning/plan_follow.h) on the Panda in MuJoCo: a joint goal behind a wall reached open loop (the
// plan executed on the clock) and by RMPflow and the learned controller following the plan, without a collision
// event; the reference the layer is given, its yielding to what moves, the config file; the options refused by name. Planning runs on an iteration budget, so the plans are the same on any machine.
#include "rmpmarl/planning/plan_follow.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <thread>

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

// the wall problem as a controller sees it: the wall, the goal's end effector as target, the joint goal
rmp::Scene WallScene(const Problem& p) {
  rmp::Scene scene;
  scene.obstacles.push_back(p.wall.AsRmp(p.wall.X_WO));
  scene.p_WT = p.p_WT;
  scene.q_T = p.q_goal;
  return scene;
}

// the follower's defaults with a search ended by iterations alone (the same plans on any machine)
PlanFollowOptions IterationBudget() {
  PlanFollowOptions options;
  options.planner.planning_time_budget = 3600.0;
  options.planner.planning_iterations = 20000;
  return options;
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
  // around the wall and in: the plan, valid against the wall, outweighs the agents' repulsion from it (they alone hold
  // off a wall 1–2 cm away; measured 7.8 mm from the goal, RMPflow 1.4 mm)
  EXPECT_TRUE(o.metrics.reached);
  EXPECT_LT(o.metrics.final_tracking_error, 0.02);
  EXPECT_LT(o.joint_error, 0.02);
}

// a plan beside the loop: the step that starts it returns while it runs (the layer going for the scene's goal
// meanwhile), later steps switch to it when it is ready, and it is the plan the step would have made itself, waypoint
// for waypoint; a Reset drops a plan in flight
TEST(PlanFollowTest, APlanBesideTheLoopHoldsNoStepAndIsTheSamePlan) {
  const Problem p = WallProblem();
  const rmp::Scene scene = WallScene(p);
  PlanFollowOptions options = IterationBudget();
  options.planner.seed = 4;
  options.planner.validity_resolution = 0.001;  // ten times the checks: a plan of tens of ms on any machine
  const VectorXd qd = VectorXd::Zero(p.q_start.size());
  VectorXd qdd(p.q_start.size());

  PlanFollowPolicy inside(p.robot, std::make_unique<control::RmpflowAccelerationPolicy>(p.robot, 1), options);
  inside.Reset(p.q_start);
  inside.BeginControlStep(p.q_start, qd, scene);
  ASSERT_EQ(inside.stats().plans_succeeded, 1);
  EXPECT_FALSE(inside.planning());
  const double plan_s = inside.stats().planning_times_s.at(0);

  options.plan_beside_loop = true;
  PlanFollowPolicy beside(p.robot, std::make_unique<control::RmpflowAccelerationPolicy>(p.robot, 1), options);
  for (int episode = 0; episode < 2; ++episode) {
    beside.Reset(p.q_start);
    const auto start = std::chrono::steady_clock::now();
    beside.BeginControlStep(p.q_start, qd, scene);
    const double first_call_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_TRUE(beside.planning());  // the step returned with the plan still to be switched to (timings printed below)
    EXPECT_EQ(beside.stats().plans_attempted, 1);
    EXPECT_EQ(beside.stats().last_outcome, PlanOutcome::kNone);
    EXPECT_TRUE(beside.path().empty());
    if (episode == 0) continue;  // the next Reset drops the plan in flight
    beside.Evaluate(p.q_start, qd, scene, qdd);  // the layer alone, toward the scene's goal
    EXPECT_TRUE(qdd.allFinite());
    int steps = 0;
    while (beside.planning()) {
      beside.BeginControlStep(p.q_start, qd, scene);
      beside.Evaluate(p.q_start, qd, scene, qdd);
      ++steps;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
    std::printf("[ beside   ] plan %.1f ms inside the step; beside the loop: the first step %.3f ms, the plan arrived "
                "after %d more steps\n", 1e3 * plan_s, 1e3 * first_call_s, steps);
    EXPECT_EQ(beside.stats().plans_attempted, 1);
    EXPECT_EQ(beside.stats().plans_succeeded, 1);
    EXPECT_EQ(beside.stats().last_outcome, PlanOutcome::kPlanned);
    EXPECT_EQ(beside.stats().planning_times_s.size(), 1u);
    ASSERT_EQ(beside.path().size(), inside.path().size());
    for (size_t k = 0; k < inside.path().size(); ++k) EXPECT_EQ(beside.path()[k], inside.path()[k]) << k;
  }
  // open loop plans inside the call whatever the option says
  PlanFollowPolicy open_loop(p.robot, nullptr, options);
  open_loop.Reset(p.q_start);
  open_loop.BeginControlStep(p.q_start, qd, scene);
  EXPECT_FALSE(open_loop.planning());
  EXPECT_EQ(open_loop.stats().plans_succeeded, 1);
}

// the goal moving: a joint goal moved by more than the tolerance, or a target by more than goal_shift, is planned for
// anew; smaller moves keep the plan
TEST(PlanFollowTest, AMovedGoalIsPlannedForAnew) {
  const Problem p = WallProblem();
  const PlanFollowOptions options = IterationBudget();
  PlanFollowPolicy follower(p.robot, std::make_unique<control::RmpflowAccelerationPolicy>(p.robot, 1), options);
  rmp::Scene scene = WallScene(p);
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

// a reactive layer that records the scene the follower gives it and stands still
class RecordingLayer final : public control::AccelerationPolicy {
 public:
  explicit RecordingLayer(int nq) : nq_(nq) {}
  void Evaluate(const Eigen::Ref<const VectorXd>&, const Eigen::Ref<const VectorXd>&, const rmp::Scene& scene,
                Eigen::Ref<VectorXd> qdd) override {
    seen = scene;
    qdd.setZero();
  }
  std::string name() const override { return "recording"; }
  int nq() const override { return nq_; }
  rmp::Scene seen;

 private:
  int nq_;
};

// the reference: the plan's start moving along the path (q̇_T along the first segment, its slowest joint at most at
// path_speed_fraction × its limit), weighted posture_metric; near an obstacle that moves (not a static one) the
// weight yields geometrically to yield_metric and the reference slows to a stop, as the options say
TEST(PlanFollowTest, TheReferenceMovesAlongThePlanAndYieldsToWhatMoves) {
  const Problem p = WallProblem();
  const PlanFollowOptions options = IterationBudget();
  auto layer = std::make_unique<RecordingLayer>(7);
  RecordingLayer* recorded = layer.get();
  PlanFollowPolicy follower(p.robot, std::move(layer), options);
  const rmp::Scene scene = WallScene(p);
  const VectorXd qd = VectorXd::Zero(7);
  VectorXd qdd(7);
  // the first control step from the start (a reset: the same plan, the reference at the path's start)
  auto first_step = [&](const rmp::Scene& at) {
    follower.Reset(p.q_start);
    follower.BeginControlStep(p.q_start, qd, at);
    follower.Evaluate(p.q_start, qd, at, qdd);
  };
  first_step(scene);
  ASSERT_GE(follower.path().size(), 2u);
  const rmp::Scene seen = recorded->seen;
  EXPECT_EQ(seen.q_T_metric, options.posture_metric);  // the wall is static
  ASSERT_EQ(seen.q_T.size(), 7);
  EXPECT_LT((seen.q_T - p.q_start).norm(), 1e-12);
  ASSERT_EQ(seen.qd_T.size(), 7);
  // along the first segment, its slowest joint at most at path_speed_fraction × its limit (less when the segment
  // ends in a corner within lookahead)
  const VectorXd direction = (follower.path()[1] - follower.path()[0]).normalized();
  VectorXd v_max(7);
  for (int i = 0; i < 7; ++i) v_max[i] = options.planner.path_speed_fraction * p.robot.model.limits()[i].velocity;
  const double speed = 1.0 / (direction.cwiseAbs().cwiseQuotient(v_max)).maxCoeff();
  const double rate = seen.qd_T.norm();
  EXPECT_GT(rate, 0.0);
  EXPECT_LE(rate, speed * (1.0 + 1e-12));
  EXPECT_LT((seen.qd_T - rate * direction).norm(), 1e-9 * rate);

  // a sphere moving past the end effector at a hand-placed clearance d from the arm's nearest capsule
  kinematics::Data data(p.robot.model);
  kinematics::CalcForwardKinematics(p.robot.model, p.q_start, &data);
  const Vector3d p_WE = kinematics::CalcPointPosition(data, p.robot.end_effector.link,
                                                      p.robot.end_effector.X_LE.translation());
  auto clearance = [&](const rmp::Obstacle& o) {
    double d = INFINITY;
    for (const kinematics::LinkCapsule& lc : p.robot.capsules) {
      const Eigen::Isometry3d& X = data.X_WL[lc.link];
      d = std::min(d, rmp::CapsuleObstacleDistance({X * lc.p_LA, X * lc.p_LB, lc.radius}, o).distance);
    }
    return d;
  };
  for (const double target_d : {0.1, 0.5, 1.0}) {
    // above the end effector, lifted until the clearance is target_d (the nearest capsule may be another link's)
    double h = target_d;
    rmp::Obstacle sphere;
    for (int k = 0; k < 50; ++k) {
      sphere = rmp::Obstacle::MakeSphere(p_WE + Vector3d(0.0, 0.0, h), 0.05, Vector3d(0.0, 1.0, 0.0));
      h += target_d - clearance(sphere);
    }
    const double d = clearance(sphere);
    ASSERT_NEAR(d, target_d, 1e-6);
    rmp::Scene moving = scene;
    moving.obstacles.push_back(sphere);
    first_step(moving);
    const double f = std::clamp((d - options.yield_near) / (options.yield_far - options.yield_near), 0.0, 1.0);
    const double metric = options.yield_metric * std::pow(options.posture_metric / options.yield_metric, f);
    EXPECT_NEAR(recorded->seen.q_T_metric, metric, 1e-9 * metric) << "clearance " << d;
    EXPECT_LT((recorded->seen.qd_T - f * seen.qd_T).norm(), 1e-9 * rate) << "clearance " << d;
    // the same sphere standing still: the plan's full weight
    moving.obstacles.back().v_WO.setZero();
    first_step(moving);
    EXPECT_EQ(recorded->seen.q_T_metric, options.posture_metric);
    EXPECT_EQ(recorded->seen.qd_T, seen.qd_T);
  }
}

// at a waypoint the reference's velocity turns by at most corner_velocity_jump and its speed is at most the slower of
// its two segments' (the slowest joint at the path speed): the reference tracked perfectly (the arm put on it after
// every evaluation), its speed where it passes a waypoint is at most that hand-derived corner speed (up to the one step
// it moves past it), and it changes by at most the fastest segment's speed over lookahead per unit of arc length (it
// never drops at once, as it did when only a segment's own ends slowed it)
TEST(PlanFollowTest, TheReferenceSlowsDownSmoothlyForCorners) {
  const Problem p = WallProblem();
  const rmp::Scene scene = WallScene(p);
  std::vector<double> slowest_corner;  // per jump, the slowest speed at which the reference passed a waypoint
  for (const double jump : {1.0, 0.02}) {
    PlanFollowOptions options = IterationBudget();
    options.corner_velocity_jump = jump;
    auto layer = std::make_unique<RecordingLayer>(7);
    RecordingLayer* recorded = layer.get();
    PlanFollowPolicy follower(p.robot, std::move(layer), options);
    const VectorXd qd = VectorXd::Zero(7);
    VectorXd q = p.q_start, qdd(7);
    follower.Reset(q);
    follower.BeginControlStep(q, qd, scene);
    const std::vector<VectorXd> path = follower.path();
    ASSERT_GE(path.size(), 3u) << "the wall's plan has a corner";
    VectorXd v_max(7);
    for (int i = 0; i < 7; ++i) v_max[i] = options.planner.path_speed_fraction * p.robot.model.limits()[i].velocity;
    std::vector<double> s{0.0}, segment_speed;
    for (size_t k = 1; k < path.size(); ++k) {
      const VectorXd d = path[k] - path[k - 1];
      s.push_back(s.back() + d.norm());
      segment_speed.push_back(1.0 / (d.normalized().cwiseAbs().cwiseQuotient(v_max)).maxCoeff());
    }
    const double fastest = *std::max_element(segment_speed.begin(), segment_speed.end());
    const double dt = options.planner.evaluation_period;
    double s_ref = 0.0, last_rate = -1.0;
    size_t next = 1;  // the next interior waypoint the reference passes
    double slowest = INFINITY;
    // the acceleration the layer is given is the reference velocity's rate of change: against finite differences
    // between steps on one segment, where the ramp that limits the speed stays the same
    VectorXd last_qd_T, last_qdd_T;
    bool passed = true;
    int accelerations_checked = 0;
    for (int step = 0; step < 20000 && next + 1 < path.size(); ++step) {
      follower.Evaluate(q, qd, scene, qdd);
      const double rate = recorded->seen.qd_T.norm();
      if (last_rate >= 0.0) {
        EXPECT_LE(std::abs(rate - last_rate), fastest / options.lookahead * dt * last_rate * (1.0 + 1e-9) + 1e-12)
            << "step " << step << ", corner velocity jump " << jump;
      }
      last_rate = rate;
      const VectorXd& qd_T = recorded->seen.qd_T;
      const VectorXd& qdd_T = recorded->seen.qdd_T;
      ASSERT_EQ(qdd_T.size(), 7);
      // (the reference moves on by dt times its rate, and the rate is linear in s on a ramp: the difference quotient
      // is the last step's acceleration)
      if (!passed && last_qdd_T.norm() > 1.0 && (qdd_T - last_qdd_T).norm() <= 0.1 * last_qdd_T.norm()) {
        EXPECT_LE(((qd_T - last_qd_T) / dt - last_qdd_T).norm(), 1e-3 * last_qdd_T.norm()) << "step " << step;
        ++accelerations_checked;
      }
      last_qd_T = qd_T;
      last_qdd_T = qdd_T;
      passed = false;
      q = recorded->seen.q_T;  // the arm on the reference
      const double s_now = s_ref + dt * rate;
      if (s_now >= s[next]) {  // the reference passes waypoint `next` within this step
        const VectorXd d_in = (path[next] - path[next - 1]).normalized();
        const double turn = ((path[next + 1] - path[next]).normalized() - d_in).norm();
        const double corner = std::min({jump / turn, segment_speed[next - 1], segment_speed[next]});
        EXPECT_LE(rate, corner + fastest * (dt * rate) / options.lookahead + 1e-9)
            << "waypoint " << next << ", corner velocity jump " << jump;
        slowest = std::min(slowest, rate);
        ++next;
        passed = true;
      }
      s_ref = s_now;
    }
    EXPECT_EQ(next + 1, path.size()) << "the reference passed every corner";
    EXPECT_GT(accelerations_checked, 20) << "corner velocity jump " << jump;
    slowest_corner.push_back(slowest);
  }
  EXPECT_LT(slowest_corner[1], slowest_corner[0]) << "a smaller jump passes the sharpest corner more slowly";

  // without the feed-forward the layer is given no acceleration
  PlanFollowOptions options = IterationBudget();
  options.acceleration_feedforward = false;
  auto layer = std::make_unique<RecordingLayer>(7);
  RecordingLayer* recorded = layer.get();
  PlanFollowPolicy follower(p.robot, std::move(layer), options);
  VectorXd qdd(7);
  follower.Reset(p.q_start);
  follower.BeginControlStep(p.q_start, VectorXd::Zero(7), scene);
  follower.Evaluate(p.q_start, VectorXd::Zero(7), scene, qdd);
  EXPECT_GT(recorded->seen.qd_T.size(), 0);
  EXPECT_EQ(recorded->seen.qdd_T.size(), 0);
}

// configs/planning/follow.yaml documents the values built in: reading it changes nothing; a bad file is refused
// naming the file and key
TEST(PlanFollowTest, TheConfigFileHoldsTheBuiltInValuesAndBadFilesAreRefused) {
  const std::filesystem::path shipped = std::filesystem::path(RMPMARL_TEST_DATA_DIR) / "../../configs/planning/follow.yaml";
  const PlanFollowOptions d;
  const PlanFollowOptions o = LoadPlanFollowOptions(shipped);
  EXPECT_EQ(o.lookahead, d.lookahead);
  EXPECT_EQ(o.corner_velocity_jump, d.corner_velocity_jump);
  EXPECT_EQ(o.approach_distance, d.approach_distance);
  EXPECT_EQ(o.acceleration_feedforward, d.acceleration_feedforward);
  EXPECT_EQ(o.posture_metric, d.posture_metric);
  EXPECT_EQ(o.yield_metric, d.yield_metric);
  EXPECT_EQ(o.yield_near, d.yield_near);
  EXPECT_EQ(o.yield_far, d.yield_far);
  EXPECT_EQ(o.yield_slows, d.yield_slows);
  EXPECT_EQ(o.stall_time, d.stall_time);
  EXPECT_EQ(o.check_period, d.check_period);
  EXPECT_EQ(o.goal_tolerance, d.goal_tolerance);
  EXPECT_EQ(o.goal_shift, d.goal_shift);
  EXPECT_EQ(o.replan, d.replan);
  EXPECT_EQ(o.plan_beside_loop, d.plan_beside_loop);
  EXPECT_EQ(o.planner.path_speed_fraction, d.planner.path_speed_fraction);
  EXPECT_EQ(o.planner.validity_resolution, d.planner.validity_resolution);
  EXPECT_EQ(o.planner.retry_period, d.planner.retry_period);
  EXPECT_EQ(o.planner.kp, d.planner.kp);
  EXPECT_EQ(o.planner.kd, d.planner.kd);
  EXPECT_EQ(o.planner.shortcut_iterations, d.planner.shortcut_iterations);
  EXPECT_EQ(o.planner.range, d.planner.range);
  EXPECT_EQ(o.planner.end_margin_distance, d.planner.end_margin_distance);
  // a value read over what the caller had; the rest kept
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "rmpmarl-follow-config-test";
  std::filesystem::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    const std::filesystem::path file = dir / name;
    std::ofstream(file) << text;
    return file;
  };
  PlanFollowOptions base;
  base.planner.retry_period = 0.5;
  const PlanFollowOptions read = LoadPlanFollowOptions(write("one.yaml", "lookahead: 0.2\n"), base);
  EXPECT_EQ(read.lookahead, 0.2);
  EXPECT_EQ(read.planner.retry_period, 0.5);
  EXPECT_TRUE(LoadPlanFollowOptions(write("beside.yaml", "plan_beside_loop: true\n")).plan_beside_loop);
  for (const auto& [text, expected] : std::initializer_list<std::pair<const char*, const char*>>{
           {"look_ahead: 0.2\n", "look_ahead"},
           {"planner:\n  kp: fast\n", "planner.kp"},
           {"yield_near: 0.5\nyield_far: 0.4\n", "yield_far"},
           {"yield_metric: 1e9\n", "yield_metric"},
           {"lookahead: [1, 2\n", "malformed"}}) {
    const std::filesystem::path file = write("bad.yaml", text);
    try {
      LoadPlanFollowOptions(file);
      ADD_FAILURE() << "accepted " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    }
  }
  EXPECT_THROW(LoadPlanFollowOptions(dir / "missing.yaml"), InputError);
  std::filesystem::remove_all(dir);
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
           {"approach_distance", [](PlanFollowOptions& o) { o.approach_distance = 0.0; }},
           {"yield_metric", [](PlanFollowOptions& o) { o.yield_metric = 0.0; }},
           {"yield_near", [](PlanFollowOptions& o) { o.yield_near = -0.1; }},
           {"yield_far", [](PlanFollowOptions& o) { o.yield_far = o.yield_near; }},
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
