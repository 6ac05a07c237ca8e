// RMPflow baseline: config loading (defaults, bad input), and open-loop sanity in pure kinematics — integrating
// q̈ with semi-implicit Euler at 1 kHz reaches a static target, and keeps clearance around an obstacle in the way.
#include "rmpmarl/rmp/rmpflow.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <random>

#include "rmp_test_util.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"

namespace rmpmarl::rmp {
namespace {

// every number of the options, in a fixed order
std::vector<double> Flatten(const RmpflowOptions& o) {
  const auto& ct = o.cspace_target;
  const auto& cd = o.cspace_damping;
  const auto& jl = o.joint_limit;
  const auto& vc = o.joint_velocity_cap;
  const auto& t = o.target;
  std::vector<double> v = {ct.metric_scalar, ct.position_gain, ct.damping_gain, ct.robust_position_term_thresh,
                           ct.inertia, cd.accel_d_gain, cd.metric_scalar, jl.metric_scalar, jl.metric_length_scale,
                           jl.metric_exploder_eps, jl.metric_velocity_gate_length_scale, jl.accel_damper_gain,
                           jl.accel_potential_gain, jl.accel_potential_exploder_length_scale,
                           jl.accel_potential_exploder_eps, vc.max_velocity, vc.velocity_damping_region,
                           vc.damping_gain, vc.metric_weight, t.accel_p_gain, t.accel_d_gain,
                           static_cast<double>(t.damping), t.accel_norm_eps, t.metric_alpha_length_scale,
                           t.min_metric_alpha, t.max_metric_scalar, t.min_metric_scalar,
                           t.proximity_metric_boost_scalar, t.proximity_metric_boost_length_scale,
                           static_cast<double>(o.self_collision_enabled), o.joint_limit_buffer,
                           o.max_acceleration_norm, o.resolve.relative_regularizer};
  for (const CollisionRmpParams* c : {&o.collision, &o.self_collision}) {
    v.insert(v.end(), {c->repulsion_gain, c->repulsion_std_dev, c->damping_gain, c->damping_std_dev,
                       c->damping_robustness_eps, c->damping_velocity_gate_length_scale, c->metric_scalar,
                       c->metric_exploder_std_dev, c->metric_exploder_eps, c->metric_modulation_radius});
  }
  v.insert(v.end(), o.home.begin(), o.home.end());
  return v;
}

std::filesystem::path WriteConfig(const std::string& name, const std::string& text) {
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) / name;
  std::ofstream(path) << text;
  return path;
}

// expects InputError whose message contains every fragment
void ExpectLoadError(const std::string& text, const std::vector<std::string>& fragments) {
  const std::filesystem::path path = WriteConfig("rmpflow_bad.yaml", text);
  try {
    LoadRmpflowOptions(path);
    FAIL() << "expected InputError for:\n" << text;
  } catch (const InputError& e) {
    for (const std::string& fragment : fragments) {
      EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << "'" << fragment << "' in " << e.what();
    }
  }
}

TEST(RmpflowConfigTest, DefaultFileEqualsDefaultOptions) {
  const std::filesystem::path path = RmpflowConfigDirectory() / "default.yaml";
  ASSERT_TRUE(std::filesystem::exists(path)) << path;
  EXPECT_EQ(Flatten(LoadRmpflowOptions(path)), Flatten(RmpflowOptions{}));
  EXPECT_EQ(RmpflowConfigPath("no_such_robot"), path);
  EXPECT_EQ(RmpflowOptions{}.target.damping, TargetDamping::kLinear);
  EXPECT_EQ(TargetRmpParams{}.damping, TargetDamping::kQuadratic);
}

TEST(RmpflowConfigTest, EveryShippedConfigLoads) {
  for (const auto& entry : std::filesystem::directory_iterator(RmpflowConfigDirectory())) {
    if (entry.path().extension() == ".yaml") {
      EXPECT_NO_THROW(LoadRmpflowOptions(entry.path())) << entry.path();
    }
  }
}

TEST(RmpflowConfigTest, PartialFileKeepsDefaults) {
  const RmpflowOptions o = LoadRmpflowOptions(WriteConfig("rmpflow_partial.yaml", R"(
rmp_params:
  target_rmp:
    accel_p_gain: 12.5
    damping: quadratic
home: [0.1, -0.2]
self_collision_enabled: false
)"));
  RmpflowOptions expected;
  expected.target.accel_p_gain = 12.5;
  expected.target.damping = TargetDamping::kQuadratic;
  expected.home = {0.1, -0.2};
  expected.self_collision_enabled = false;
  EXPECT_EQ(Flatten(o), Flatten(expected));
}

TEST(RmpflowConfigTest, BadInputNamesFileAndKey) {
  ExpectLoadError("rmp_params:\n  target_rmp:\n    accel_p_gian: 3\n",
                  {"rmpflow_bad.yaml", "rmp_params.target_rmp.accel_p_gian", "unknown key"});
  ExpectLoadError("rmp_params:\n  colision_rmp: {}\n", {"rmpflow_bad.yaml", "rmp_params.colision_rmp", "unknown key"});
  ExpectLoadError("speed: 3\n", {"speed", "unknown key"});
  ExpectLoadError("rmp_params:\n  collision_rmp:\n    repulsion_gain: .nan\n",
                  {"rmp_params.collision_rmp.repulsion_gain", "finite"});
  ExpectLoadError("rmp_params:\n  collision_rmp:\n    repulsion_gain: .inf\n",
                  {"rmp_params.collision_rmp.repulsion_gain", "finite"});
  ExpectLoadError("rmp_params:\n  target_rmp:\n    accel_d_gain: -3\n",
                  {"rmpflow_bad.yaml", "rmp_params.target_rmp.accel_d_gain", ">= 0"});
  ExpectLoadError("rmp_params:\n  joint_limit_rmp:\n    metric_scalar: -1\n",
                  {"rmp_params.joint_limit_rmp.metric_scalar"});
  ExpectLoadError("rmp_params:\n  self_collision_rmp:\n    metric_modulation_radius: 0\n",
                  {"rmp_params.self_collision_rmp.metric_modulation_radius", "> 0"});
  ExpectLoadError("rmp_params:\n  target_rmp:\n    min_metric_alpha: 1.5\n", {"min_metric_alpha", "[0, 1]"});
  ExpectLoadError("rmp_params:\n  target_rmp:\n    damping: cubic\n", {"rmp_params.target_rmp.damping", "cubic"});
  ExpectLoadError("rmp_params:\n  cspace_target_rmp:\n    position_gain: fast\n",
                  {"rmp_params.cspace_target_rmp.position_gain", "expected a number"});
  ExpectLoadError("canonical_resolve:\n  relative_regularizer: 0\n", {"canonical_resolve.relative_regularizer"});
  ExpectLoadError("joint_limit_buffer: -0.1\n", {"joint_limit_buffer"});
  ExpectLoadError("home: [0, .nan]\n", {"home[1]"});
  ExpectLoadError("self_collision_enabled: maybe\n", {"self_collision_enabled"});
  ExpectLoadError("rmp_params: [1, 2\n", {"rmpflow_bad.yaml", "malformed"});
  EXPECT_THROW(LoadRmpflowOptions("/nonexistent/rmpflow.yaml"), InputError);
}

TEST(RmpflowPolicyTest, RejectsBadConstructionAndInputs) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  RmpflowOptions options;
  options.home = {0.0, 0.0, 0.0};
  EXPECT_THROW(RmpflowPolicy(robot, options, 1), InputError);
  options.home.clear();
  options.joint_limit_buffer = 3.5;  // planar2 limits are ±3
  EXPECT_THROW(RmpflowPolicy(robot, options, 1), InputError);
  EXPECT_THROW(RmpflowPolicy(robot, RmpflowOptions{}, -1), InputError);
  RmpflowPolicy policy(robot, RmpflowOptions{}, 1);
  Scene scene;
  Eigen::VectorXd qdd(2);
  EXPECT_THROW(policy.Evaluate(Eigen::Vector3d::Zero(), Eigen::Vector2d::Zero(), scene, qdd), InputError);
  EXPECT_THROW(policy.Evaluate(Eigen::Vector2d(NAN, 0.0), Eigen::Vector2d::Zero(), scene, qdd), InputError);
  scene.obstacles.resize(2, Obstacle::MakeSphere(Eigen::Vector3d(2, 2, 2), 0.1));
  EXPECT_THROW(policy.Evaluate(Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero(), scene, qdd), InputError);
  EXPECT_THROW(policy.set_home(Eigen::Vector3d::Zero()), InputError);
}

// a moving C-space target (Scene::qd_T) adds μ k_d q̇_T to the C-space target's force and nothing to the metric;
// it is refused without q_T, of the wrong size or not finite
TEST(RmpflowPolicyTest, AMovingCSpaceTargetAddsItsVelocityTermOnly) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  const RmpflowOptions options;
  RmpflowPolicy policy(robot, options, 1);
  const Eigen::Vector2d q(0.3, -0.4), qd(0.5, 0.2), q_T(0.6, 0.1), qd_T(-0.7, 0.9);
  const double metric = 2500.0;
  policy.EvaluateStructure(q, qd, q_T, metric);
  const Eigen::VectorXd f0 = policy.data().f_root;
  const Eigen::MatrixXd M0 = policy.data().M_root;
  policy.EvaluateStructure(q, qd, q_T, metric, qd_T);
  const Eigen::VectorXd expected = f0 + metric * options.cspace_target.damping_gain * qd_T;
  EXPECT_LT((policy.data().f_root - expected).norm(), 1e-9 * expected.norm());
  EXPECT_EQ(policy.data().M_root, M0);
  // without a metric of its own the options' C-space target moves the same way
  policy.EvaluateStructure(q, qd, q_T);
  const Eigen::VectorXd g0 = policy.data().f_root;
  policy.EvaluateStructure(q, qd, q_T, 0.0, qd_T);
  const Eigen::VectorXd g = g0 + options.cspace_target.metric_scalar * options.cspace_target.damping_gain * qd_T;
  EXPECT_LT((policy.data().f_root - g).norm(), 1e-9 * g.norm());

  Scene scene;
  scene.has_target = false;
  Eigen::VectorXd qdd(2);
  scene.qd_T = qd_T;  // without q_T
  EXPECT_THROW(ValidateScene(scene, "scene"), InputError);
  EXPECT_THROW(policy.Evaluate(q, qd, scene, qdd), InputError);
  scene.q_T = q_T;
  policy.Evaluate(q, qd, scene, qdd);
  EXPECT_TRUE(qdd.allFinite());
  scene.qd_T = Eigen::Vector3d::Zero();
  EXPECT_THROW(ValidateScene(scene, "scene"), InputError);
  EXPECT_THROW(policy.Evaluate(q, qd, scene, qdd), InputError);
  scene.qd_T = Eigen::Vector2d(NAN, 0.0);
  EXPECT_THROW(ValidateScene(scene, "scene"), InputError);
  EXPECT_THROW(policy.Evaluate(q, qd, scene, qdd), InputError);
}

// its acceleration (Scene::qdd_T) adds μ q̈_T and nothing to the metric; refused without qd_T, of the wrong size or not
// finite. With it, RMPflow's C-space target trails a reference that accelerates steadily by nothing in the end; without
// it, by q̈_T / k_p (the two-link arm, no obstacles, the reference weighted as a plan's).
TEST(RmpflowPolicyTest, AnAcceleratingCSpaceTargetIsFollowedWithoutLag) {
  const kinematics::Robot robot = kinematics::MakePlanar2();
  const RmpflowOptions options;
  RmpflowPolicy policy(robot, options, 1);
  const Eigen::Vector2d q(0.3, -0.4), qd(0.5, 0.2), q_T(0.6, 0.1), qd_T(-0.7, 0.9), qdd_T(2.0, -3.0);
  const double metric = 2500.0;
  policy.EvaluateStructure(q, qd, q_T, metric, qd_T);
  const Eigen::VectorXd f0 = policy.data().f_root;
  const Eigen::MatrixXd M0 = policy.data().M_root;
  policy.EvaluateStructure(q, qd, q_T, metric, qd_T, qdd_T);
  const Eigen::VectorXd expected = f0 + metric * qdd_T;
  EXPECT_LT((policy.data().f_root - expected).norm(), 1e-9 * expected.norm());
  EXPECT_EQ(policy.data().M_root, M0);

  Scene scene;
  scene.has_target = false;
  Eigen::VectorXd qdd(2);
  scene.q_T = q_T;
  scene.qdd_T = qdd_T;  // without qd_T
  EXPECT_THROW(ValidateScene(scene, "scene"), InputError);
  EXPECT_THROW(policy.Evaluate(q, qd, scene, qdd), InputError);
  scene.qd_T = qd_T;
  ValidateScene(scene, "scene");
  scene.qdd_T = Eigen::Vector3d::Zero();
  EXPECT_THROW(ValidateScene(scene, "scene"), InputError);
  EXPECT_THROW(policy.Evaluate(q, qd, scene, qdd), InputError);
  scene.qdd_T = Eigen::Vector2d(0.0, INFINITY);
  EXPECT_THROW(ValidateScene(scene, "scene"), InputError);

  // a reference from rest at 0.5 rad/s² on both joints for 2 s, the arm integrated at 0.2 ms from it
  const Eigen::Vector2d accel(0.5, 0.5), start(-0.5, -0.5);
  std::vector<double> lag;
  for (const bool feedforward : {false, true}) {
    Eigen::VectorXd x = start, v = Eigen::VectorXd::Zero(2);
    Scene follow;
    follow.has_target = false;
    follow.q_T_metric = 2.5e8;
    const double h = 2e-4;
    for (int k = 0; k < 10000; ++k) {
      const double t = k * h;
      follow.q_T = start + 0.5 * t * t * accel;
      follow.qd_T = t * accel;
      follow.qdd_T = feedforward ? Eigen::VectorXd(accel) : Eigen::VectorXd();
      policy.Evaluate(x, v, follow, qdd);
      v += h * qdd;
      x += h * v;
    }
    lag.push_back((start + 0.5 * 4.0 * accel - x).norm());
  }
  const double expected_lag = accel.norm() / options.cspace_target.position_gain;
  EXPECT_NEAR(lag[0], expected_lag, 0.25 * expected_lag) << "without the feed-forward: q̈_T / k_p";
  EXPECT_LT(lag[1], 0.1 * lag[0]) << "with it";
}

TEST(RmpflowPolicyTest, BuildsTheUsualLeafSet) {
  const kinematics::Robot robot = testing::LoadTreeRobot();
  const RmpflowPolicy policy(robot, RmpflowOptions{}, 3);
  const Tree& tree = policy.tree();
  int limits = 0, caps = 0, obstacles = 0, selfs = 0;
  for (int i = 0; i < tree.num_nodes(); ++i) {
    const std::string& name = tree.name(i);
    limits += name.starts_with("joint_limit_");
    caps += name.starts_with("velocity_cap/");
    obstacles += name.starts_with("obstacle/");
    selfs += name.starts_with("self/");
    if (name.starts_with("self/")) {
      const auto& m = std::get<CapsuleCapsuleDistanceMap>(tree.map(i));
      EXPECT_FALSE(robot.IsExcludedPair(robot.capsules[m.capsule1].link, robot.capsules[m.capsule2].link));
    }
  }
  EXPECT_GE(tree.FindNode("ee"), 0);
  EXPECT_GE(tree.FindNode("cspace"), 0);
  EXPECT_EQ(limits, 2 * 5);  // five joints with finite limits, one continuous
  EXPECT_EQ(caps, 6);
  EXPECT_EQ(obstacles, 6 * 3);
  EXPECT_GT(selfs, 0);
}

struct RolloutResult {
  double final_error = 0.0;
  double min_clearance = 0.0;
  double time_to_1cm = -1.0;
  double min_self_distance = std::numeric_limits<double>::infinity();  // over the evaluated self pairs
  bool finite = true;
};

// semi-implicit Euler at 1 kHz in pure kinematics: q̇ += q̈ dt, q += q̇ dt
RolloutResult Rollout(const kinematics::Robot& robot, RmpflowPolicy* policy, Eigen::VectorXd q, const Scene& scene,
                      double duration) {
  const double dt = 1e-3;
  Eigen::VectorXd qd = Eigen::VectorXd::Zero(q.size()), qdd(q.size());
  kinematics::Data kin(robot.model);
  RolloutResult r;
  r.min_clearance = std::numeric_limits<double>::infinity();
  const int steps = static_cast<int>(duration / dt);
  for (int step = 0; step < steps; ++step) {
    policy->Evaluate(q, qd, scene, qdd);
    r.min_self_distance = std::min(r.min_self_distance, policy->diagnostics().min_self_distance);
    if (!qdd.allFinite()) {
      r.finite = false;
      return r;
    }
    qd += dt * qdd;
    q += dt * qd;
    // independent clearance check: every capsule against every obstacle
    kinematics::CalcForwardKinematics(robot.model, q, &kin);
    for (const kinematics::LinkCapsule& c : robot.capsules) {
      const math::Capsule capsule{kin.X_WL[c.link] * c.p_LA, kin.X_WL[c.link] * c.p_LB, c.radius};
      for (const Obstacle& o : scene.obstacles) {
        r.min_clearance = std::min(r.min_clearance, CapsuleObstacleDistance(capsule, o).distance);
      }
    }
    const Eigen::Vector3d p_WE =
        kinematics::CalcPointPosition(kin, robot.end_effector.link, robot.end_effector.X_LE.translation());
    r.final_error = (p_WE - scene.p_WT).norm();
    if (r.time_to_1cm < 0.0 && r.final_error < 0.01) r.time_to_1cm = (step + 1) * dt;
  }
  return r;
}

// every shipped arm (the tree robot until they land)
std::vector<kinematics::Robot> Arms() {
  std::vector<kinematics::Robot> arms;
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    if (testing::ShippedRobotAvailable(name)) arms.push_back(kinematics::LoadShippedRobot(name));
  }
  if (arms.empty()) arms.push_back(testing::LoadTreeRobot());
  return arms;
}

// world position of the end effector at configuration q
Eigen::Vector3d EndEffectorAt(const kinematics::Robot& robot, const Eigen::VectorXd& q) {
  kinematics::Data kin(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &kin);
  return kinematics::CalcPointPosition(kin, robot.end_effector.link, robot.end_effector.X_LE.translation());
}

// smallest signed distance between the robot's capsules at q and the obstacle
double Clearance(const kinematics::Robot& robot, const Eigen::VectorXd& q, const Obstacle& obstacle) {
  kinematics::Data kin(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &kin);
  double clearance = std::numeric_limits<double>::infinity();
  for (const kinematics::LinkCapsule& c : robot.capsules) {
    const math::Capsule capsule{kin.X_WL[c.link] * c.p_LA, kin.X_WL[c.link] * c.p_LB, c.radius};
    clearance = std::min(clearance, CapsuleObstacleDistance(capsule, obstacle).distance);
  }
  return clearance;
}

// A reaching task from the home posture: the target is the end effector at a random configuration (so it is
// reachable) at least 0.3 m away; with_obstacle adds a 4 cm sphere halfway along the straight line, at least 5 cm
// clear of the arm at the start and at the goal configuration.
struct ReachTask {
  Eigen::VectorXd q_start;
  Scene scene;
  double start_error = 0.0;
};

std::vector<ReachTask> ReachTasks(const kinematics::Robot& robot, const Eigen::VectorXd& home, bool with_obstacle,
                                  int count, std::mt19937_64& rng) {
  std::vector<ReachTask> tasks;
  const Eigen::Vector3d start = EndEffectorAt(robot, home);
  for (int attempt = 0; attempt < 1000 && static_cast<int>(tasks.size()) < count; ++attempt) {
    Eigen::VectorXd q_goal = home;
    for (int i = 0; i < q_goal.size(); ++i) {
      const auto& lim = robot.model.limits()[i];
      const double lo = std::isfinite(lim.lower) ? lim.lower + 0.3 : -M_PI;
      const double hi = std::isfinite(lim.upper) ? lim.upper - 0.3 : M_PI;
      q_goal[i] = std::clamp(home[i] + testing::Uniform(rng, -1.0, 1.0), lo, hi);
    }
    ReachTask task;
    task.q_start = home;
    task.scene.p_WT = EndEffectorAt(robot, q_goal);
    task.start_error = (task.scene.p_WT - start).norm();
    if (task.start_error < 0.3) continue;
    if (with_obstacle) {
      const Obstacle sphere = Obstacle::MakeSphere(0.5 * (start + task.scene.p_WT), 0.04);
      if (Clearance(robot, home, sphere) < 0.05 || Clearance(robot, q_goal, sphere) < 0.05) continue;
      task.scene.obstacles.push_back(sphere);
    }
    tasks.push_back(task);
  }
  EXPECT_EQ(static_cast<int>(tasks.size()), count) << robot.name;
  return tasks;
}

TEST(RmpflowPolicyTest, OpenLoopReachesStaticTargets) {
  std::mt19937_64 rng(52);
  for (const kinematics::Robot& robot : Arms()) {
    RmpflowPolicy policy(robot, LoadRmpflowOptions(RmpflowConfigPath(robot.name)), 0);
    double worst = 0.0, slowest = 0.0, min_self = std::numeric_limits<double>::infinity();
    for (const ReachTask& task : ReachTasks(robot, policy.home(), false, 5, rng)) {
      const RolloutResult r = Rollout(robot, &policy, task.q_start, task.scene, 5.0);
      ASSERT_TRUE(r.finite);
      min_self = std::min(min_self, r.min_self_distance);
      EXPECT_GT(r.min_self_distance, 0.0) << robot.name;  // self-collision avoidance keeps the links apart
      EXPECT_LT(r.final_error, 0.01) << robot.name << " start error " << task.start_error;
      worst = std::max(worst, r.final_error);
      slowest = std::max(slowest, r.time_to_1cm < 0 ? 99.0 : r.time_to_1cm);
    }
    std::printf("[ reach    ] %-7s 5 targets >= 0.3 m away: worst final error %.2e m, all within 1 cm after %.2f s, "
                "min self distance %.3f m\n", robot.name.c_str(), worst, slowest, min_self);
  }
}

TEST(RmpflowPolicyTest, OpenLoopKeepsClearanceAroundObstacleInTheWay) {
  std::mt19937_64 rng(53);
  for (const kinematics::Robot& robot : Arms()) {
    RmpflowPolicy policy(robot, LoadRmpflowOptions(RmpflowConfigPath(robot.name)), 1);
    double min_clearance = std::numeric_limits<double>::infinity(), worst = 0.0;
    for (const ReachTask& task : ReachTasks(robot, policy.home(), true, 5, rng)) {
      const RolloutResult r = Rollout(robot, &policy, task.q_start, task.scene, 5.0);
      ASSERT_TRUE(r.finite);
      EXPECT_GT(r.min_clearance, 0.0) << robot.name << " start error " << task.start_error;
      min_clearance = std::min(min_clearance, r.min_clearance);
      worst = std::max(worst, r.final_error);
    }
    std::printf("[ obstacle ] %-7s 5 targets behind a sphere: min clearance %.4f m, worst final error %.3f m\n",
                robot.name.c_str(), min_clearance, worst);
  }
}

TEST(RmpflowPolicyTest, EveryShippedRobotGivesFiniteAccelerations) {
  std::mt19937_64 rng(51);
  std::vector<kinematics::Robot> robots = {testing::LoadTreeRobot(), kinematics::MakePlanar2()};
  for (const std::string& name : kinematics::ShippedRobotNames()) {
    if (testing::ShippedRobotAvailable(name)) robots.push_back(kinematics::LoadShippedRobot(name));
  }
  for (const kinematics::Robot& robot : robots) {
    RmpflowPolicy policy(robot, LoadRmpflowOptions(RmpflowConfigPath(robot.name)), 4);
    Eigen::VectorXd qdd(robot.model.nq());
    for (int trial = 0; trial < 200; ++trial) {
      Scene scene;
      for (int k = 0; k < 4; ++k) {
        scene.obstacles.push_back(Obstacle::MakeSphere(
            testing::RandomVector3(rng, -0.6, 0.6) + Eigen::Vector3d(0, 0, 0.4), 0.05,
            testing::RandomVector3(rng, -1.0, 1.0)));
      }
      scene.p_WT = testing::RandomVector3(rng, -0.6, 0.6);
      // include states at and beyond the joint limits and fast velocities
      Eigen::VectorXd q = testing::RandomConfiguration(robot.model, rng);
      if (trial % 4 == 0) q = robot.model.UpperLimits().cwiseMin(1e3) + Eigen::VectorXd::Constant(q.size(), 0.1);
      const Eigen::VectorXd qd = 3.0 * testing::RandomVelocity(robot.model, rng);
      policy.Evaluate(q, qd, scene, qdd);
      ASSERT_TRUE(qdd.allFinite()) << robot.name;
      EXPECT_LE(qdd.norm(), policy.options().max_acceleration_norm * (1.0 + 1e-12));
    }
  }
}

}  // namespace
}  // namespace rmpmarl::rmp
