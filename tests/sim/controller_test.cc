// ReactiveController: semi-implicit Euler on the commanded state against the closed-form sum, velocity/position
// clamps, velocity feed-forward, non-finite policy output never reaching MuJoCo, re-synchronisation, rates, errors.
#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/controlled_world.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "control_test_util.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/sim/episode.h"
#include "sim_test_util.h"

namespace rmpmarl::sim {
namespace {

using testing::ConstantPolicy;

std::shared_ptr<const WorldModel> Planar2World() {
  return std::make_shared<const WorldModel>(kinematics::MakePlanar2());
}

// expects InputError whose message contains every fragment
template <typename F>
void ExpectInputError(F&& f, const std::vector<std::string>& fragments) {
  try {
    f();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    for (const std::string& fragment : fragments) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << "'" << fragment << "' in " << e.what();
    }
  }
}

TEST(ControllerTest, PeriodAndSubstepsFollowTheRates) {
  auto wm = Planar2World();  // 2 ms physics
  struct Case {
    double rate, max_substep;
    int physics_steps, substeps;
  };
  for (const Case& c : {Case{100.0, 0.002, 5, 5}, Case{100.0, 0.01, 5, 1}, Case{100.0, 0.003, 5, 4},
                        Case{250.0, 0.002, 2, 2}, Case{500.0, 0.002, 1, 1}, Case{50.0, 0.002, 10, 10}}) {
    control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector2d::Zero()),
                           control::ControllerOptions{.control_rate = c.rate, .max_substep = c.max_substep});
    EXPECT_EQ(ctl.physics_steps_per_control(), c.physics_steps) << c.rate;
    EXPECT_EQ(ctl.substeps(), c.substeps) << c.rate << " " << c.max_substep;
    EXPECT_NEAR(ctl.control_period(), 1.0 / c.rate, 1e-15);
    EXPECT_NEAR(ctl.substep() * ctl.substeps(), 1.0 / c.rate, 1e-15);
    EXPECT_LE(ctl.substep(), c.max_substep + 1e-15);
  }
}

// one control step of n substeps from (q0, v0) with constant a: v_k = v0 + k h a, q_n = q0 + n h v0 + h² a n(n+1)/2.
TEST(ControllerTest, IntegratesSemiImplicitEulerOnTheCommandedState) {
  auto wm = Planar2World();
  World world(wm);
  const Eigen::Vector2d a(0.7, -1.3);
  control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(a),
                         control::ControllerOptions{.control_rate = 100.0, .max_substep = 0.002, .velocity_feedforward = false});
  const Eigen::Vector2d q0(0.2, -0.4);
  world.Reset(q0);
  sim::ResetController(ctl, world);
  const rmp::Scene scene;
  const int n = ctl.substeps();
  const double h = ctl.substep();
  Eigen::Vector2d q_expected = q0, v_expected = Eigen::Vector2d::Zero();
  for (int step = 1; step <= 4; ++step) {
    const control::ControlStepResult r = sim::StepController(ctl, world, scene);
    EXPECT_TRUE(r.finite);
    EXPECT_FALSE(r.resynced);
    q_expected += n * h * v_expected + h * h * a * (n * (n + 1) / 2.0);
    v_expected += n * h * a;
    EXPECT_LT((ctl.q_cmd() - q_expected).cwiseAbs().maxCoeff(), 1e-14) << step;
    EXPECT_LT((ctl.qd_cmd() - v_expected).cwiseAbs().maxCoeff(), 1e-14) << step;
    // without feed-forward the servo target is the commanded position itself
    EXPECT_EQ(world.joint_targets(), ctl.q_cmd());
    world.Step(ctl.physics_steps_per_control());
  }
  EXPECT_EQ(static_cast<ConstantPolicy&>(ctl.policy()).calls, 4L * n);  // evaluated at every substep
  EXPECT_EQ(ctl.stats().steps, 4);
}

TEST(ControllerTest, VelocityFeedForwardAddsDampingOverStiffnessTimesVelocity) {
  auto wm = Planar2World();
  World world(wm);
  control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector2d(2.0, -1.0)));
  ASSERT_TRUE(ctl.options().velocity_feedforward);
  world.Reset(Eigen::Vector2d(0.1, 0.2));
  sim::ResetController(ctl, world);
  sim::StepController(ctl, world, rmp::Scene{});
  const ServoGains& g = wm->servo_gains();
  for (int i = 0; i < 2; ++i) {
    const double expected = ctl.q_cmd()[i] + g.damping[i] / g.kp[i] * ctl.qd_cmd()[i];
    EXPECT_DOUBLE_EQ(ctl.servo_target()[i], expected);
    EXPECT_DOUBLE_EQ(world.joint_targets()[i], expected);
  }
}

TEST(ControllerTest, CommandedAccelerationIsTheMeanOverThePeriod) {
  // a constant q̈ = a: the commanded velocity grows by a T per period, so qdd_cmd = a; a velocity clamp caps it at
  // (v_max − q̇ at the start) / T; zero after Reset
  auto wm = Planar2World();
  World world(wm);
  const Eigen::Vector2d a(3.0, -2.0);
  control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(a));
  world.Reset(Eigen::Vector2d(0.1, 0.2));
  sim::ResetController(ctl, world);
  EXPECT_EQ(ctl.qdd_cmd(), Eigen::Vector2d::Zero());
  const double T = ctl.control_period();
  Eigen::Vector2d v_start = ctl.qd_cmd();
  int clamped_steps = 0;
  for (int step = 0; step < 200; ++step) {
    const control::ControlStepResult r = sim::StepController(ctl, world, rmp::Scene{});
    ASSERT_FALSE(r.resynced);
    const Eigen::Vector2d expected = (ctl.qd_cmd() - v_start) / T;
    EXPECT_LT((ctl.qdd_cmd() - expected).cwiseAbs().maxCoeff(), 1e-9) << step;
    if (r.position_clamps > 0) break;  // a joint limit zeroes the velocity: the period's mean says so (checked above)
    if (r.velocity_clamps == 0) {
      EXPECT_LT((ctl.qdd_cmd() - a).cwiseAbs().maxCoeff(), 1e-9) << step;
    } else {
      ++clamped_steps;
      EXPECT_LT(ctl.qdd_cmd().cwiseAbs().maxCoeff(), a.cwiseAbs().maxCoeff() + 1e-9) << step;
    }
    v_start = ctl.qd_cmd();
    world.Step(ctl.physics_steps_per_control());
  }
  EXPECT_GT(clamped_steps, 0);  // the velocity limit was reached
  sim::ResetController(ctl, world);
  EXPECT_EQ(ctl.qdd_cmd(), Eigen::Vector2d::Zero());
}

TEST(ControllerTest, ClampsVelocityAndZeroesItAtAJointLimit) {
  const kinematics::Robot robot = kinematics::MakePlanar2();  // |q| ≤ 3 rad, |q̇| ≤ 3 rad/s
  auto wm = std::make_shared<const WorldModel>(robot);
  World world(wm);
  control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector2d(40.0, -40.0)),
                         control::ControllerOptions{.velocity_limit_scale = 0.5});
  EXPECT_DOUBLE_EQ(ctl.velocity_limits()[0], 1.5);
  world.Reset(Eigen::Vector2d(2.0, -2.0));
  sim::ResetController(ctl, world);
  const rmp::Scene scene;
  long velocity_clamps = 0, position_clamps = 0;
  bool reached = false;
  for (int step = 0; step < 200; ++step) {
    const Eigen::Vector2d q_before = ctl.q_cmd();
    const control::ControlStepResult r = sim::StepController(ctl, world, scene);
    velocity_clamps += r.velocity_clamps;
    position_clamps += r.position_clamps;
    EXPECT_LE(ctl.qd_cmd().cwiseAbs().maxCoeff(), 1.5 + 1e-15);
    EXPECT_LE((ctl.q_cmd() - q_before).cwiseAbs().maxCoeff(), 1.5 * ctl.control_period() + 1e-12);
    EXPECT_LE(ctl.q_cmd()[0], 3.0);
    EXPECT_GE(ctl.q_cmd()[1], -3.0);
    if (ctl.q_cmd()[0] == 3.0) {
      reached = true;
      EXPECT_EQ(ctl.q_cmd()[1], -3.0);
      EXPECT_EQ(ctl.qd_cmd()[0], 0.0);  // at the limit the outward velocity is gone
      EXPECT_EQ(ctl.qd_cmd()[1], 0.0);
    }
    world.Step(ctl.physics_steps_per_control());
  }
  EXPECT_TRUE(reached);
  EXPECT_GT(velocity_clamps, 0);
  EXPECT_GT(position_clamps, 0);
  EXPECT_EQ(ctl.stats().velocity_clamps, velocity_clamps);
  EXPECT_EQ(ctl.stats().position_clamps, position_clamps);
  EXPECT_NEAR(world.q()[0], 3.0, 0.01);  // the servo followed to the limit
}

TEST(ControllerTest, NonFinitePolicyOutputHoldsPositionAndNeverReachesMujoco) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  auto wm = std::make_shared<const WorldModel>(robot);
  for (const bool infinity : {false, true}) {
    World world(wm);
    const long good = 60;  // 12 control steps of 5 substeps
    control::ReactiveController ctl(wm->servos(), std::make_unique<testing::FailingPolicy>(
                                    std::make_unique<control::RmpflowAccelerationPolicy>(robot, 0), good, infinity));
    world.Reset(ReadyConfiguration(robot));
    sim::ResetController(ctl, world);
    rmp::Scene scene;
    scene.p_WT = Eigen::Vector3d(0.3, 0.3, 0.3);  // far enough to be moving when the policy fails
    Eigen::VectorXd held;
    for (int step = 0; step < 50; ++step) {
      const control::ControlStepResult r = sim::StepController(ctl, world, scene);
      EXPECT_EQ(r.finite, step < good / ctl.substeps()) << step;
      ASSERT_TRUE(world.joint_targets().allFinite());
      ASSERT_TRUE(ctl.q_cmd().allFinite());
      if (!r.finite) {
        EXPECT_TRUE(ctl.qd_cmd().isZero(0.0));
        if (held.size() == 0) held = ctl.q_cmd();
        EXPECT_EQ(ctl.q_cmd(), held);  // holds the last commanded position
        EXPECT_FALSE(ctl.qdd().allFinite());
        EXPECT_TRUE(ctl.qdd_cmd().isZero(0.0));  // no feed-forward of the dropped velocity
      }
      const StepResult s = world.Step(ctl.physics_steps_per_control());
      ASSERT_TRUE(s.ok);
      ASSERT_TRUE(world.q().allFinite() && world.qd().allFinite());
    }
    EXPECT_EQ(ctl.stats().nonfinite_outputs, 50 - good / ctl.substeps());
    // the arm settles where it was held
    EXPECT_LT((world.q() - held).cwiseAbs().maxCoeff(), 1e-3);
  }
}

TEST(ControllerTest, ResynchronisesWithTheMeasuredStateWhenPushedAway) {
  auto wm = Planar2World();
  World world(wm);
  control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector2d::Zero()),
                         control::ControllerOptions{.resync_threshold = 0.2});
  world.Reset(Eigen::Vector2d(0.5, 0.5));
  sim::ResetController(ctl, world);
  const rmp::Scene scene;
  control::ControlStepResult r = ctl.Update(Eigen::Vector2d(0.6, 0.4), Eigen::Vector2d(0.3, 0.0), scene);
  EXPECT_FALSE(r.resynced);  // within the threshold: the commanded state is kept
  EXPECT_EQ(ctl.q_cmd(), Eigen::Vector2d(0.5, 0.5));
  r = ctl.Update(Eigen::Vector2d(0.9, 0.4), Eigen::Vector2d(0.3, -5.0), scene);
  EXPECT_TRUE(r.resynced);
  // restarted from the measured state (velocity clamped to ±3 rad/s), then one control period at q̈ = 0
  EXPECT_NEAR(ctl.qd_cmd()[0], 0.3, 1e-15);
  EXPECT_NEAR(ctl.qd_cmd()[1], -3.0, 1e-15);
  EXPECT_NEAR(ctl.q_cmd()[0], 0.9 + 0.3 * ctl.control_period(), 1e-14);
  EXPECT_NEAR(ctl.q_cmd()[1], 0.4 - 3.0 * ctl.control_period(), 1e-14);
  EXPECT_EQ(ctl.stats().resyncs, 1);
}

TEST(ControllerTest, MeasuredInputEvaluatesOncePerControlStep) {
  auto wm = Planar2World();
  World world(wm);
  control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector2d(1.0, 1.0)),
                         control::ControllerOptions{.policy_input = control::PolicyInput::kMeasured});
  world.Reset(Eigen::Vector2d::Zero());
  sim::ResetController(ctl, world);
  sim::StepController(ctl, world, rmp::Scene{});
  EXPECT_EQ(static_cast<ConstantPolicy&>(ctl.policy()).calls, 1);
  // q̈ held over the substeps: the same closed form as above from rest
  const int n = ctl.substeps();
  const double h = ctl.substep();
  EXPECT_NEAR(ctl.q_cmd()[0], h * h * n * (n + 1) / 2.0, 1e-15);
}

TEST(ControllerTest, RmpflowAdapterEqualsRmpflowPolicy) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("xarm6");
  control::RmpflowAccelerationPolicy adapter(robot, 2);
  rmp::RmpflowPolicy direct(robot, rmp::LoadRmpflowOptions(rmp::RmpflowConfigPath(robot.name)), 2);
  std::mt19937_64 rng(3);
  rmp::Scene scene;
  scene.p_WT = Eigen::Vector3d(0.4, 0.1, 0.3);
  scene.obstacles.push_back(rmp::Obstacle::MakeSphere(Eigen::Vector3d(0.3, 0.0, 0.5), 0.05, Eigen::Vector3d(0, 1, 0)));
  scene.obstacles.push_back(rmp::Obstacle::MakeBox(Eigen::Isometry3d(Eigen::Translation3d(0.4, -0.2, 0.3)),
                                                   Eigen::Vector3d::Constant(0.05)));
  Eigen::VectorXd a(6), b(6);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
    Eigen::VectorXd qd(6);
    for (int i = 0; i < 6; ++i) qd[i] = std::uniform_real_distribution<double>(-1.0, 1.0)(rng);
    adapter.Evaluate(q, qd, scene, a);
    direct.Evaluate(q, qd, scene, b);
    EXPECT_EQ(a, b);
  }
  EXPECT_EQ(adapter.name(), "rmpflow");
  EXPECT_EQ(adapter.nq(), 6);
  EXPECT_EQ(adapter.rmpflow().max_obstacles(), 2);
}

TEST(ControllerTest, BadInputThrowsInputErrorWithExpectedVsGot) {
  auto wm = Planar2World();
  auto make = [&](control::ControllerOptions o) {
    control::ReactiveController(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector2d::Zero()), o);
  };
  ExpectInputError([&] { make({.control_rate = 300.0}); }, {"control_rate", "whole number", "300"});
  ExpectInputError([&] { make({.control_rate = 1000.0}); }, {"control_rate", "whole number", "1000"});
  ExpectInputError([&] { make({.control_rate = -1.0}); }, {"control_rate", "> 0", "-1"});
  ExpectInputError([&] { make({.max_substep = 0.0}); }, {"max_substep", "> 0"});
  ExpectInputError([&] { make({.velocity_limit_scale = NAN}); }, {"velocity_limit_scale"});
  ExpectInputError([&] { make({.resync_threshold = 0.0}); }, {"resync_threshold", "+inf"});
  EXPECT_NO_THROW(make({.resync_threshold = std::numeric_limits<double>::infinity()}));
  ExpectInputError([&] { control::ReactiveController(wm->servos(), nullptr); }, {"AccelerationPolicy", "null"});
  ExpectInputError([&] { control::ReactiveController(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector3d::Zero())); },
                   {"3 joints", "planar2", "has 2"});
  control::ReactiveController ctl(wm->servos(), std::make_unique<ConstantPolicy>(Eigen::Vector2d::Zero()));
  ExpectInputError([&] { ctl.Update(Eigen::Vector3d::Zero(), Eigen::Vector2d::Zero(), rmp::Scene{}); },
                   {"2 finite entries", "sizes 3 and 2"});
  ExpectInputError([&] { ctl.Update(Eigen::Vector2d(NAN, 0.0), Eigen::Vector2d::Zero(), rmp::Scene{}); },
                   {"non-finite"});
}

}  // namespace
}  // namespace rmpmarl::sim
