// The manipulator environment: layouts, observation features against hand-computed values, the look-ahead block,
// a user's URDF, collisions and invalid input (rewards: manipulator_env_reward_test.cc; episodes:
// manipulator_env_episode_test.cc).
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/common/error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <set>

#include "../rl/rl_test_util.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/sim/pretrain_scenario.h"
#include "rmpmarl/rl/vec_env.h"

namespace rmpmarl::tasks {
namespace {

using rl::testing::Buffers;
using rl::testing::IndexOf;
using rl::testing::RandomActions;
using rl::testing::SmallConfig;

// ---------------------------------------------------------------------------------------------- layouts

TEST(ManipulatorEnvTest, PerJointSpecIsIdenticalAtEveryJointOfEveryArm) {
  std::vector<std::string> names;
  for (const auto& [robot, nq] : std::vector<std::pair<std::string, int>>{{"planar2", 2}, {"panda", 7}, {"ur5e", 6}}) {
    SCOPED_TRACE(robot);
    TaskConfig c = SmallConfig(TaskKind::kReachAvoid, robot, 1);
    auto context = MakeTaskContext(c);
    const EnvSpec& s = context->spec();
    EXPECT_EQ(s.num_agents, nq);
    EXPECT_EQ(s.local_obs_dim, control::LocalObs::kRmpSize);
    EXPECT_EQ(s.local_obs_names.size(), static_cast<size_t>(s.local_obs_dim));
    if (names.empty()) names = s.local_obs_names;
    EXPECT_EQ(s.local_obs_names, names);  // same size and meaning on every arm
    EXPECT_EQ(s.action.size(), 6);        // option + 4 scales + terminate
    EXPECT_EQ(s.action.num_options, 3);
    EXPECT_TRUE(s.action.has_termination);
    EXPECT_EQ(s.global_state_dim, 2 * nq + 16 + 2 * nq + 4 * nq + 16 * 4 + 2);
    EXPECT_EQ(s.global_state_names.size(), static_cast<size_t>(s.global_state_dim));
    EXPECT_EQ(s.reward_terms, (std::vector<std::string>{"joint_reach", "distance", "time", "collision"}));
    EXPECT_DOUBLE_EQ(s.control_dt, 0.01);
    EXPECT_DOUBLE_EQ(s.discount, 0.99);

    // every joint's row is filled with the same features: unit axes, finite values, the joint index ramp
    ManipulatorEnv env(context);
    Buffers b(s);
    std::mt19937_64 rng(3);
    env.Reset(rng, b.out());
    for (int i = 0; i < nq; ++i) {
      const Eigen::Vector3d axis(b.obs(s, i, control::LocalObs::kAxis), b.obs(s, i, control::LocalObs::kAxis + 1),
                                 b.obs(s, i, control::LocalObs::kAxis + 2));
      EXPECT_NEAR(axis.norm(), 1.0, 1e-6);
      EXPECT_NEAR(b.obs(s, i, control::LocalObs::kJointIndex), static_cast<float>(i) / (nq - 1), 1e-6);
      for (int k = 0; k < s.local_obs_dim; ++k) EXPECT_TRUE(std::isfinite(b.obs(s, i, k)));
    }

    // the other two interfaces
    c.interface = InterfaceMode::kPerJointDirect;
    const auto direct_context = MakeTaskContext(c);
    const EnvSpec& d = direct_context->spec();
    EXPECT_EQ(d.num_agents, nq);
    EXPECT_EQ(d.local_obs_dim, control::LocalObs::kBaseSize);
    EXPECT_EQ(d.action.size(), 1);
    EXPECT_EQ(d.action.num_options, 0);
    c.interface = InterfaceMode::kDirect;
    const auto single_context = MakeTaskContext(c);
    const EnvSpec& g = single_context->spec();
    EXPECT_EQ(g.num_agents, 1);
    EXPECT_EQ(g.action.size(), nq);
    EXPECT_EQ(g.local_obs_dim, g.global_state_dim);
  }
  // the fixed-horizon option interface has no termination flag
  TaskConfig c = SmallConfig(TaskKind::kPretrain2Link, "", 1);
  c.options.termination = OptionTermination::kFixed;
  EXPECT_EQ(MakeTaskContext(c)->spec().action.size(), 5);
}

// ------------------------------------------------------------------------- features at a constructed state

// the planar two-link arm (l1 = l2 = 0.5, capsule radius 0.04) at q with a sphere near link 2 and a static target.
struct Planar2Setup {
  double l1 = 0.5, l2 = 0.5, radius = 0.04;
  Eigen::Vector2d q0{0.3, 0.6};
  Eigen::Vector3d p_WT{0.4, 0.5, 0.0};
  double sphere_radius = 0.05;
  Eigen::Vector3d centre;  // 0.15 m from the middle of link 2, perpendicular to it: clearance 0.06 m

  Planar2Setup() {
    const double t2 = q0[0] + q0[1];
    const Eigen::Vector3d p1(l1 * std::cos(q0[0]), l1 * std::sin(q0[0]), 0.0);
    const Eigen::Vector3d u2(std::cos(t2), std::sin(t2), 0.0), n2(-std::sin(t2), std::cos(t2), 0.0);
    centre = p1 + 0.5 * l2 * u2 + 0.15 * n2;
  }

  std::shared_ptr<const TaskContext> Context(InterfaceMode mode) const {
    TaskConfig c = SmallConfig(TaskKind::kPretrain2Link, "", 1);
    c.interface = mode;
    c.planar2.link1_length = {l1, l1};
    c.planar2.link2_length = {l2, l2};
    c.planar2.link_radius = radius;
    c.randomization.initial_q_spread = 0.0;
    c.randomization.initial_qd_fraction = 0.0;
    sim::StaticSceneOptions scene;
    scene.q_start = Eigen::Vector2d(q0);
    scene.p_WT = p_WT;
    scene.obstacles = {sim::ObstacleSpec::Sphere(sphere_radius, centre)};
    return MakeTaskContext(c, [scene](const kinematics::Robot& robot) {
      return std::make_unique<sim::StaticScenario>(robot, scene);
    });
  }
};

// planar rotation of a world vector into a frame turned by angle a about z.
Eigen::Vector3d InFrame(double a, const Eigen::Vector3d& v) {
  return {std::cos(a) * v.x() + std::sin(a) * v.y(), -std::sin(a) * v.x() + std::cos(a) * v.y(), v.z()};
}

Eigen::Vector3d Feature3(const Buffers& b, const EnvSpec& s, int agent, int k) {
  return {b.obs(s, agent, k), b.obs(s, agent, k + 1), b.obs(s, agent, k + 2)};
}

// the features of both joints at state (q, q̇), computed by hand from the planar arm's geometry.
void ExpectPlanarFeatures(const Planar2Setup& p, const Buffers& b, const EnvSpec& s, const Eigen::Vector2d& q,
                          const Eigen::Vector2d& qd) {
  const double l = 0.5, warning = 0.15, a1 = q[0], a2 = q[0] + q[1], w1 = qd[0], w2 = qd[0] + qd[1];
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d p1(p.l1 * std::cos(a1), p.l1 * std::sin(a1), 0.0);
  const Eigen::Vector3d pE = p1 + Eigen::Vector3d(p.l2 * std::cos(a2), p.l2 * std::sin(a2), 0.0);
  const Eigen::Vector3d v1 = w1 * z.cross(p1);
  const Eigen::Vector3d vE = v1 + w2 * z.cross(pE - p1);
  // nearest point of link 2's axis to the sphere centre, and the witness pair
  const Eigen::Vector3d u = (pE - p1).normalized();
  const double t = std::clamp((p.centre - p1).dot(u), 0.0, p.l2);
  const Eigen::Vector3d axis_point = p1 + t * u;
  const Eigen::Vector3d n = (axis_point - p.centre).normalized();  // from the sphere to the arm
  const double distance = (axis_point - p.centre).norm() - p.radius - p.sphere_radius;
  const Eigen::Vector3d w_robot = axis_point - p.radius * n;
  const Eigen::Vector3d v_witness = v1 + w2 * z.cross(w_robot - p1);
  const double angles[2] = {a1, a2};
  const Eigen::Vector3d origins[2] = {Eigen::Vector3d::Zero(), p1};
  for (int i = 0; i < 2; ++i) {
    SCOPED_TRACE(i);
    const double a = angles[i];
    const Eigen::Vector3d& o = origins[i];
    const double tol = 2e-6;
    EXPECT_TRUE(Feature3(b, s, i, control::LocalObs::kEeToTarget).isApprox(InFrame(a, (pE - p.p_WT) / l), tol));
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kLogDistance), std::log1p((pE - p.p_WT).norm() / 0.001) / std::log(1001.0), tol);
    EXPECT_LT((Feature3(b, s, i, control::LocalObs::kEeVelocity) - InFrame(a, vE)).norm(), 1e-5);
    EXPECT_LT((Feature3(b, s, i, control::LocalObs::kLever) - InFrame(a, (pE - o) / l)).norm(), tol);
    EXPECT_LT((Feature3(b, s, i, control::LocalObs::kAxis) - Eigen::Vector3d::UnitZ()).norm(), tol);
    EXPECT_LT((Feature3(b, s, i, control::LocalObs::kEeJacobian) - InFrame(a, z.cross(pE - o) / l)).norm(), tol);
    // both joints move link 2, whose capsule is 0.06 m from the sphere (link 1's is beyond the warning distance)
    EXPECT_EQ(b.obs(s, i, control::LocalObs::kWarningFlag), 1.0f);
    EXPECT_LT((Feature3(b, s, i, control::LocalObs::kWarningDirection) - InFrame(a, -n)).norm(), 1e-5);
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kWarningDistance), distance / warning, 1e-5);
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kClosingSpeed), -n.dot(v_witness), 1e-5);
    EXPECT_LT((Feature3(b, s, i, control::LocalObs::kWitnessLever) - InFrame(a, (w_robot - o) / l)).norm(), 1e-5);
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kDistanceGradient), n.dot(z.cross(w_robot - o)) / l, 1e-5);
    EXPECT_EQ(b.obs(s, i, control::LocalObs::kWarningIsSelf), 0.0f);
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kJointPosition), q[i] / 3.0, tol);  // limits ±3 rad
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kJointSin), std::sin(q[i]), tol);
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kJointCos), std::cos(q[i]), tol);
    EXPECT_NEAR(b.obs(s, i, control::LocalObs::kJointVelocity), qd[i] / 3.0, 1e-5);  // v_max 3 rad/s
    EXPECT_EQ(b.obs(s, i, control::LocalObs::kJointIndex), static_cast<float>(i));
  }
  // the sphere–link-2 witness distance in the global state too
  const control::GlobalStateLayout g(InterfaceMode::kPerJointRmp, 2, 1);
  (void)g;
}

TEST(ManipulatorEnvTest, ObservationMatchesHandComputedPlanarFeatures) {
  const Planar2Setup p;
  auto context = p.Context(InterfaceMode::kPerJointDirect);
  ManipulatorEnv env(context);
  const EnvSpec& s = env.spec();
  Buffers b(s);
  std::mt19937_64 rng(1);
  env.Reset(rng, b.out());
  ASSERT_NEAR(env.world().q()[0], p.q0[0], 1e-12);
  ExpectPlanarFeatures(p, b, s, p.q0, Eigen::Vector2d::Zero());
  EXPECT_NEAR(b.obs(s, 0, control::LocalObs::kWarningDistance), 0.06 / 0.15, 1e-6);
  EXPECT_NEAR(b.obs(s, 1, control::LocalObs::kWitnessLever), 0.25 / 0.5, 1e-6);      // middle of link 2 ...
  EXPECT_NEAR(b.obs(s, 1, control::LocalObs::kWitnessLever + 1), 0.04 / 0.5, 1e-6);  // ... on the capsule's surface
  EXPECT_NEAR(b.obs(s, 1, control::LocalObs::kDistanceGradient), -0.25 / 0.5, 1e-6);

  // global state at the reset
  const std::vector<std::string>& gn = s.global_state_names;
  const auto G = [&](const std::string& name) { return b.global_state[IndexOf(gn, name)]; };
  EXPECT_NEAR(G("q0"), 0.1, 1e-6);
  EXPECT_NEAR(G("q1"), 0.2, 1e-6);
  EXPECT_NEAR(G("target_x"), 0.8, 1e-6);
  EXPECT_NEAR(G("target_y"), 1.0, 1e-6);
  EXPECT_EQ(G("obstacle0_present"), 1.0f);
  EXPECT_NEAR(G("obstacle0_x"), p.centre.x() / 0.5, 1e-6);
  EXPECT_NEAR(G("obstacle0_half_x"), 0.1, 1e-6);
  EXPECT_NEAR(G("warning_distance1"), 0.4, 1e-6);
  EXPECT_EQ(G("progress"), 0.0f);
  EXPECT_NEAR(G("robot_reach"), 2.0, 0.02);  // reach 1 m (sampled) / ℓ

  // one step of a known action: the features follow the new state and velocity
  const float actions[2] = {1.0f, -0.5f};
  env.Step(actions, rng, b.out());
  const Eigen::Vector2d q(env.world().q()[0], env.world().q()[1]), qd(env.world().qd()[0], env.world().qd()[1]);
  EXPECT_GT(qd.norm(), 0.1);
  ExpectPlanarFeatures(p, b, s, q, qd);
  EXPECT_NEAR(env.last_step().dq_command[0], 0.03, 1e-12);  // 1 × v_max 3 rad/s × 10 ms
  EXPECT_NEAR(env.last_step().dq_command[1], -0.015, 1e-12);
  EXPECT_NEAR(G("progress"), 1.0 / 400.0, 1e-7);
}

// ---------------------------------------------------------------------------------------------- rewards

TEST(ManipulatorEnvTest, LookaheadBlockMatchesSampledPaths) {
  TaskConfig c = SmallConfig(TaskKind::kLineCrossing, "panda", 1);
  c.observation.lookahead = 1.0;
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  const EnvSpec& s = env.spec();
  ASSERT_EQ(s.local_obs_dim, control::LocalObs::kRmpSize + control::LocalObs::kLookaheadSize);
  EXPECT_EQ(s.local_obs_names[control::LocalObs::kRmpSize + control::LocalObs::kLookaheadTime], "lookahead_time");
  const int base = control::LocalObs::kRmpSize;
  const double l = c.observation.length_scale, T = c.observation.lookahead;
  Buffers b(s);
  std::mt19937_64 rng(5);
  std::vector<float> actions(s.num_agents * s.action.size(), 0.0f);
  int checked = 0, threatened = 0;
  for (int episode = 0; episode < 4; ++episode) {
    env.Reset(rng, b.out());
    for (int step = 0; step < 120; ++step) {
      if (step % 20 == 0) {
        const kinematics::Robot& robot = env.world().model().robot();
        kinematics::Data kin(robot.model);
        kinematics::CalcForwardKinematics(robot.model, env.world().q(), &kin);
        const sim::SceneSpec& scene = env.scenario().scene_spec();
        for (int i = 0; i < s.num_agents; ++i) {
          // the block's time of closest approach, as a sample index of the paths
          const int k_obs = static_cast<int>(std::lround(20000.0 * b.obs(s, i, base + control::LocalObs::kLookaheadTime)));
          double best = std::numeric_limits<double>::infinity(), best_speed = 0.0;
          double at_block_time = std::numeric_limits<double>::infinity();  // smallest clearance at that instant
          for (int j = 0; j < env.scenario().num_obstacles(); ++j) {
            const sim::ObstacleState& o = env.scenario().obstacles()[j];
            const Eigen::Vector3d v = o.v_WO();
            if (v.norm() == 0.0) continue;
            const double rho = scene.obstacles[j].half_size.norm();
            for (const kinematics::LinkCapsule& lc : robot.capsules) {
              if (!robot.model.DofMovesLink(i, lc.link)) continue;
              const Eigen::Vector3d a = kin.X_WL[lc.link] * lc.p_LA, d = kin.X_WL[lc.link] * lc.p_LB - a;
              for (int k = 0; k <= 20000; ++k) {
                const Eigen::Vector3d p = o.p_WO() + (T * k / 20000.0) * v;
                const double u = d.squaredNorm() > 0.0 ? std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
                const double clearance = (p - a - u * d).norm() - lc.radius - rho;
                if (clearance < best) best = clearance, best_speed = v.norm();
                if (k == k_obs) at_block_time = std::min(at_block_time, clearance);
              }
            }
          }
          ++checked;
          if (best < 0.3) ++threatened;
          EXPECT_NEAR(b.obs(s, i, base + control::LocalObs::kLookaheadClearance), std::clamp(best / l, -1.0, 2.0), 5e-4)
              << "episode " << episode << " step " << step << " joint " << i;
          EXPECT_NEAR(b.obs(s, i, base + control::LocalObs::kLookaheadSpeed), best_speed / c.observation.speed_scale, 1e-5);
          // at the block's time some path passes at the smallest clearance (the time of a flat minimum, a path parallel
          // to a capsule axis, is any time of the flat part)
          if (std::isfinite(best)) {
            EXPECT_NEAR(at_block_time, best, 5e-4) << "episode " << episode << " step " << step << " joint " << i;
          }
        }
      }
      env.Step(actions.data(), rng, b.out());
      if (b.terminated || b.truncated) break;
    }
  }
  EXPECT_GT(threatened, checked / 10);  // the check saw cubes on collision courses, not only distant ones

  // a static scene: nothing moves, so the block says "no pass"
  TaskConfig cl = SmallConfig(TaskKind::kCluttered, "panda", 1);
  cl.observation.lookahead = 1.0;
  ManipulatorEnv still(MakeTaskContext(cl));
  Buffers bs(still.spec());
  still.Reset(rng, bs.out());
  for (int i = 0; i < still.spec().num_agents; ++i) {
    EXPECT_EQ(bs.obs(still.spec(), i, base + control::LocalObs::kLookaheadClearance), 2.0f);
    EXPECT_EQ(bs.obs(still.spec(), i, base + control::LocalObs::kLookaheadTime), 1.0f);
    EXPECT_EQ(bs.obs(still.spec(), i, base + control::LocalObs::kLookaheadSpeed), 0.0f);
  }
  // off by default: the paper's local observation size
  EXPECT_EQ(MakeTaskContext(SmallConfig(TaskKind::kLineCrossing, "panda", 1))->spec().local_obs_dim, control::LocalObs::kRmpSize);
}

// a learning task on a user's robot: `robot: <file>.urdf` loads it as `demo --urdf` does — here a URDF
// with mimic joints and no YAML, so capsules, exclusions and home are fitted in memory; one agent per independent
// joint, and random per-joint RMP actions step it without invalid steps or collisions of the robot with itself.
TEST(ManipulatorEnvTest, AUserUrdfRunsAsATaskRobot) {
  TaskConfig c = SmallConfig(TaskKind::kReachAvoid, "", 1);
  c.robot = std::string(RMPMARL_TEST_DATA_DIR) + "/robots/mimic/mimic_arm.urdf";
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  EXPECT_EQ(env.spec().num_agents, 4);  // j1, j2, j3 and the gripper; the 3 mimic joints follow
  Buffers b(env.spec());
  std::mt19937_64 rng(3), arng(4);
  env.Reset(rng, b.out());
  std::vector<float> actions(env.spec().num_agents * env.spec().action.size());
  for (int step = 0; step < 150 && !b.terminated && !b.truncated; ++step) {
    RandomActions(env.spec(), arng, actions.data());
    env.Step(actions.data(), rng, b.out());
    ASSERT_FALSE(env.last_step().invalid) << step;
  }
  TaskConfig missing = c;
  missing.robot = "/no/such/robot.urdf";
  EXPECT_THROW(ValidateTaskConfig(missing, "test"), rmpmarl::InputError);
}

TEST(ManipulatorEnvTest, CollisionCostsSeventyFivePerEvent) {
  Planar2Setup p;
  p.centre = Eigen::Vector3d(0.0, 0.75, 0.0);  // in link 2's sweep when joint 1 turns the arm up
  p.q0 = Eigen::Vector2d(0.8, 0.0);
  p.sphere_radius = 0.1;
  auto context = p.Context(InterfaceMode::kDirect);
  ManipulatorEnv env(context);
  const EnvSpec& s = env.spec();
  Buffers b(s);
  std::mt19937_64 rng(1);
  env.Reset(rng, b.out());
  const float push[2] = {1.0f, 0.0f};  // joint 1 at full speed towards the sphere
  int events = 0, steps = 0;
  while (!b.terminated && !b.truncated && steps < 400) {
    env.Step(push, rng, b.out());
    ++steps;
    events += env.last_step().collision_events;
    EXPECT_EQ(b.reward_terms[3], -75.0f * env.last_step().collision_events);
    if (events > 0) break;
  }
  ASSERT_EQ(events, 1);
  EXPECT_EQ(b.reward_terms[3], -75.0f);
  EXPECT_EQ(env.metrics().collisions, 1);
  EXPECT_LT(env.metrics().min_clearance, 0.0);
  // keep pushing: the pair stays in contact (no new event) until the episode ends, which is not a success
  while (!b.terminated && !b.truncated) env.Step(push, rng, b.out());
  EXPECT_TRUE(b.truncated);
  EXPECT_FALSE(b.metrics.success);
  EXPECT_FALSE(b.metrics.invalid);
  EXPECT_GE(b.metrics.collisions, 1);
  EXPECT_EQ(b.metrics.length, 400);
}

TEST(ManipulatorEnvTest, TerminateOnCollisionEndsTheEpisode) {
  Planar2Setup p;
  p.centre = Eigen::Vector3d(0.0, 0.75, 0.0);
  p.q0 = Eigen::Vector2d(0.8, 0.0);
  p.sphere_radius = 0.1;
  TaskConfig c = SmallConfig(TaskKind::kPretrain2Link, "", 1);
  c.interface = InterfaceMode::kDirect;
  c.episode.terminate_on_collision = true;
  c.planar2.link1_length = c.planar2.link2_length = {0.5, 0.5};
  sim::StaticSceneOptions scene;
  scene.q_start = Eigen::Vector2d(p.q0);
  scene.obstacles = {sim::ObstacleSpec::Sphere(p.sphere_radius, p.centre)};
  ManipulatorEnv env(MakeTaskContext(c, [scene](const kinematics::Robot& r) {
    return std::make_unique<sim::StaticScenario>(r, scene);
  }));
  Buffers b(env.spec());
  std::mt19937_64 rng(1);
  env.Reset(rng, b.out());
  const float push[2] = {1.0f, 0.0f};
  int steps = 0;
  while (!b.terminated && !b.truncated) {
    env.Step(push, rng, b.out());
    ++steps;
  }
  EXPECT_TRUE(b.terminated);
  EXPECT_LT(steps, 400);
  EXPECT_EQ(b.metrics.collisions, 1);
  EXPECT_FALSE(b.metrics.success);
  EXPECT_FALSE(b.metrics.invalid);
}

// ---------------------------------------------------------------------------------------------- options

// option_started of agent 0 over `steps` steps of the target option, with agent 0's termination flag from `flags`.
TEST(ManipulatorEnvTest, InvalidActionsEndTheEpisodeWithoutNaN) {
  auto context = MakeTaskContext(SmallConfig(TaskKind::kReachAvoid, "panda", 1));
  ManipulatorEnv env(context);
  const EnvSpec& s = env.spec();
  const int n = s.num_agents * s.action.size();
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  struct Case {
    const char* what;
    int index;
    float value;
  };
  const Case cases[] = {{"NaN scale", 3, nan}, {"Inf scale", 8, inf},        {"NaN option", 6, nan},
                        {"option 1.5", 0, 1.5f}, {"option 3", 12, 3.0f},     {"option -1", 18, -1.0f},
                        {"NaN flag", 5, nan},    {"-Inf flag", 11, -inf}};
  std::mt19937_64 rng(1);
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    Buffers b(s);
    env.Reset(rng, b.out());
    std::vector<float> actions(n, 0.0f);
    env.Step(actions.data(), rng, b.out());  // a valid step first
    ASSERT_FALSE(b.terminated);
    actions[c.index] = c.value;
    env.Step(actions.data(), rng, b.out());
    EXPECT_TRUE(b.terminated);
    EXPECT_FALSE(b.truncated);
    EXPECT_TRUE(b.metrics.invalid);
    EXPECT_FALSE(b.metrics.success);
    EXPECT_EQ(b.reward, 0.0f);
    for (float v : b.local_obs) EXPECT_TRUE(std::isfinite(v));
    for (float v : b.global_state) EXPECT_TRUE(std::isfinite(v));
    for (float v : b.reward_terms) EXPECT_TRUE(std::isfinite(v));
  }
  // a wrongly sized action (checked form) and a step without a reset
  Buffers b(s);
  env.Reset(rng, b.out());
  std::vector<float> actions(n + 1, 0.0f);
  env.Step(std::span<const float>(actions.data(), n + 1), rng, b.out());
  EXPECT_TRUE(b.terminated && b.metrics.invalid);
  env.Step(std::span<const float>(actions.data(), n), rng, b.out());  // the episode already ended
  EXPECT_TRUE(b.terminated && b.metrics.invalid);
  // a reset recovers
  env.Reset(rng, b.out());
  env.Step(std::span<const float>(actions.data(), n), rng, b.out());
  EXPECT_FALSE(b.terminated);
  EXPECT_FALSE(env.last_step().invalid);
}

}  // namespace
}  // namespace rmpmarl::tasks
