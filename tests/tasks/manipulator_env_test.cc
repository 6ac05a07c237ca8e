// The manipulator environment: layouts, observation features and rewards against hand-computed values, options,
// domain randomisation and the variant pool, determinism, invalid input.
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/common/error.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <set>

#include "../rl/rl_test_util.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/tasks/pretrain_scenario.h"
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
    EXPECT_EQ(s.local_obs_dim, LocalObs::kRmpSize);
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
      const Eigen::Vector3d axis(b.obs(s, i, LocalObs::kAxis), b.obs(s, i, LocalObs::kAxis + 1),
                                 b.obs(s, i, LocalObs::kAxis + 2));
      EXPECT_NEAR(axis.norm(), 1.0, 1e-6);
      EXPECT_NEAR(b.obs(s, i, LocalObs::kJointIndex), static_cast<float>(i) / (nq - 1), 1e-6);
      for (int k = 0; k < s.local_obs_dim; ++k) EXPECT_TRUE(std::isfinite(b.obs(s, i, k)));
    }

    // the other two interfaces
    c.interface = InterfaceMode::kPerJointDirect;
    const auto direct_context = MakeTaskContext(c);
    const EnvSpec& d = direct_context->spec();
    EXPECT_EQ(d.num_agents, nq);
    EXPECT_EQ(d.local_obs_dim, LocalObs::kBaseSize);
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
    EXPECT_TRUE(Feature3(b, s, i, LocalObs::kEeToTarget).isApprox(InFrame(a, (pE - p.p_WT) / l), tol));
    EXPECT_NEAR(b.obs(s, i, LocalObs::kLogDistance), std::log1p((pE - p.p_WT).norm() / 0.001) / std::log(1001.0), tol);
    EXPECT_LT((Feature3(b, s, i, LocalObs::kEeVelocity) - InFrame(a, vE)).norm(), 1e-5);
    EXPECT_LT((Feature3(b, s, i, LocalObs::kLever) - InFrame(a, (pE - o) / l)).norm(), tol);
    EXPECT_LT((Feature3(b, s, i, LocalObs::kAxis) - Eigen::Vector3d::UnitZ()).norm(), tol);
    EXPECT_LT((Feature3(b, s, i, LocalObs::kEeJacobian) - InFrame(a, z.cross(pE - o) / l)).norm(), tol);
    // both joints move link 2, whose capsule is 0.06 m from the sphere (link 1's is beyond the warning distance)
    EXPECT_EQ(b.obs(s, i, LocalObs::kWarningFlag), 1.0f);
    EXPECT_LT((Feature3(b, s, i, LocalObs::kWarningDirection) - InFrame(a, -n)).norm(), 1e-5);
    EXPECT_NEAR(b.obs(s, i, LocalObs::kWarningDistance), distance / warning, 1e-5);
    EXPECT_NEAR(b.obs(s, i, LocalObs::kClosingSpeed), -n.dot(v_witness), 1e-5);
    EXPECT_LT((Feature3(b, s, i, LocalObs::kWitnessLever) - InFrame(a, (w_robot - o) / l)).norm(), 1e-5);
    EXPECT_NEAR(b.obs(s, i, LocalObs::kDistanceGradient), n.dot(z.cross(w_robot - o)) / l, 1e-5);
    EXPECT_EQ(b.obs(s, i, LocalObs::kWarningIsSelf), 0.0f);
    EXPECT_NEAR(b.obs(s, i, LocalObs::kJointPosition), q[i] / 3.0, tol);  // limits ±3 rad
    EXPECT_NEAR(b.obs(s, i, LocalObs::kJointSin), std::sin(q[i]), tol);
    EXPECT_NEAR(b.obs(s, i, LocalObs::kJointCos), std::cos(q[i]), tol);
    EXPECT_NEAR(b.obs(s, i, LocalObs::kJointVelocity), qd[i] / 3.0, 1e-5);  // v_max 3 rad/s
    EXPECT_EQ(b.obs(s, i, LocalObs::kJointIndex), static_cast<float>(i));
  }
  // the sphere–link-2 witness distance in the global state too
  const GlobalStateLayout g(InterfaceMode::kPerJointRmp, 2, 1);
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
  EXPECT_NEAR(b.obs(s, 0, LocalObs::kWarningDistance), 0.06 / 0.15, 1e-6);
  EXPECT_NEAR(b.obs(s, 1, LocalObs::kWitnessLever), 0.25 / 0.5, 1e-6);      // middle of link 2 ...
  EXPECT_NEAR(b.obs(s, 1, LocalObs::kWitnessLever + 1), 0.04 / 0.5, 1e-6);  // ... on the capsule's surface
  EXPECT_NEAR(b.obs(s, 1, LocalObs::kDistanceGradient), -0.25 / 0.5, 1e-6);

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

TEST(ManipulatorEnvTest, RewardTermsFollowTheirDefinitions) {
  TaskConfig c = SmallConfig(TaskKind::kReachAvoid, "panda", 2);
  c.reward.joint_reach_weights = {1, 2, 3, 4, 5, 6, 7};
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  const EnvSpec& s = env.spec();
  Buffers b(s);
  std::mt19937_64 rng(5), arng(6);
  env.Reset(rng, b.out());
  const int e = IndexOf(s.global_state_names, "ee_to_target_x");
  const auto distance = [&] {
    return 0.5 * Eigen::Vector3d(b.global_state[e], b.global_state[e + 1], b.global_state[e + 2]).norm();
  };
  std::vector<float> actions(s.num_agents * s.action.size());
  int reached_terms = 0;
  for (int step = 0; step < 300; ++step) {
    const double before = distance();
    RandomActions(s, arng, actions.data());
    env.Step(actions.data(), rng, b.out());
    const StepInfo& info = env.last_step();
    const double after = distance();
    // R_d: one point per 0.1 cm closer (from the global state, float precision)
    EXPECT_NEAR(b.reward_terms[1], (before - after) / 0.001, 2e-3);
    EXPECT_NEAR(b.reward_terms[1], (info.distance_before - info.distance_after) / 0.001, 1e-4);
    double reach = 0.0;
    for (int i = 0; i < 7; ++i) {
      EXPECT_TRUE(info.joint_reach[i] == 0.0 || info.joint_reach[i] == 1.0);
      reach += (i + 1) * info.joint_reach[i];
    }
    reached_terms += reach > 0.0;
    EXPECT_NEAR(b.reward_terms[0], reach, 1e-6);
    EXPECT_TRUE(b.reward_terms[2] == 0.0f || b.reward_terms[2] == 25.0f);
    EXPECT_EQ(b.reward_terms[3], -75.0f * info.collision_events);
    EXPECT_NEAR(b.reward, b.reward_terms[0] + b.reward_terms[1] + b.reward_terms[2] + b.reward_terms[3], 1e-4);
    if (b.terminated || b.truncated) env.Reset(rng, b.out());
  }
  EXPECT_GT(reached_terms, 10);  // random motion does earn joint rewards sometimes
}

/// runs `plain` and `changed` (a reward change only) for 100 steps from identical seeds with identical random
/// actions and calls check(step, d, distance-term difference, reward difference) after each, d the distance after it.
void CompareRewards(const TaskConfig& plain, const TaskConfig& changed,
                    const std::function<void(int, double, double, double)>& check) {
  auto plain_context = MakeTaskContext(plain);
  auto changed_context = MakeTaskContext(changed);
  ManipulatorEnv a(plain_context), b_env(changed_context);
  Buffers ba(a.spec()), bb(b_env.spec());
  std::mt19937_64 rng_a(9), rng_b(9), arng(10);
  a.Reset(rng_a, ba.out());
  b_env.Reset(rng_b, bb.out());
  std::vector<float> actions(a.spec().num_agents * a.spec().action.size());
  for (int step = 0; step < 100; ++step) {
    RandomActions(a.spec(), arng, actions.data());
    a.Step(actions.data(), rng_a, ba.out());
    b_env.Step(actions.data(), rng_b, bb.out());
    const double d = b_env.last_step().distance_after;
    ASSERT_NEAR(d, a.last_step().distance_after, 1e-12) << step;
    check(step, d, bb.reward_terms[1] - ba.reward_terms[1], bb.reward - ba.reward);
  }
}

// the dense precision term (reward.tracking_weight w): the distance term is R_d − w·d, d after the step; the same
// episode with w = 0 differs by exactly that, step by step (identical seeds, identical actions).
TEST(ManipulatorEnvTest, TrackingWeightSubtractsTheDistanceEveryStep) {
  TaskConfig plain = SmallConfig(TaskKind::kReachAvoid, "panda", 2);
  TaskConfig dense = plain;
  dense.reward.tracking_weight = 10.0;
  CompareRewards(plain, dense, [](int step, double d, double term, double reward) {
    EXPECT_NEAR(term, -10.0 * d, 1e-3) << step;
    EXPECT_NEAR(reward, -10.0 * d, 1e-3) << step;
    EXPECT_GT(d, 0.0);
  });
  TaskConfig bad = plain;
  bad.reward.tracking_weight = -1.0;
  EXPECT_THROW(ValidateTaskConfig(bad, "test"), rmpmarl::InputError);
}

// the bounded precision term (reward.precision_weight w, precision_length δ): the distance term is R_d + w·exp(−d/δ),
// d after the step; the same episode without it differs by exactly that (identical seeds and actions).
TEST(ManipulatorEnvTest, PrecisionWeightAddsABoundedKernelOfTheDistance) {
  TaskConfig plain = SmallConfig(TaskKind::kReachAvoid, "panda", 2);
  TaskConfig kernel = plain;
  kernel.reward.precision_weight = 2.0;
  kernel.reward.precision_length = 0.05;
  double smallest = 1e9, largest = 0.0;
  CompareRewards(plain, kernel, [&](int step, double d, double term, double reward) {
    const double k = 2.0 * std::exp(-d / 0.05);  // hand-derived: 2 at d = 0, 2/e at 5 cm
    EXPECT_NEAR(term, k, 1e-3) << step;
    EXPECT_NEAR(reward, k, 1e-3) << step;
    smallest = std::min(smallest, k);
    largest = std::max(largest, k);
  });
  EXPECT_GT(largest, smallest);  // the distance changed, and the term with it
  for (auto [weight, length] : {std::pair{-1.0, 0.02}, std::pair{1.0, 0.0}, std::pair{1.0, -0.1}}) {
    TaskConfig bad = plain;
    bad.reward.precision_weight = weight;
    bad.reward.precision_length = length;
    EXPECT_THROW(ValidateTaskConfig(bad, "test"), rmpmarl::InputError) << weight << " " << length;
  }
}

// reward.precision_pass_clearance c: the kernel is paid only on steps where every joint's look-ahead block predicts no
// pass within c of the arm. Twin envs (ungated and gated, identical seeds and actions): their distance terms differ by
// exactly the kernel on the steps where some joint's block (read from its observation) says clearance <= c, and by
// nothing on the others; both kinds of step occur.
TEST(ManipulatorEnvTest, PrecisionPassClearanceGatesTheKernelOnTheLookaheadBlock) {
  TaskConfig plain = SmallConfig(TaskKind::kLineCrossing, "panda", 1);
  plain.scenario.line_speeds = {1.2};
  plain.observation.lookahead = 1.0;
  plain.reward.precision_weight = 1.0;
  plain.reward.precision_length = 0.5;  // wide: the kernel is ≥ 0.1 wherever the arm is, so a withheld one shows
  TaskConfig gated = plain;
  gated.reward.precision_pass_clearance = 0.15;
  ManipulatorEnv a(MakeTaskContext(plain)), b(MakeTaskContext(gated));
  const EnvSpec& spec = b.spec();
  Buffers ba(a.spec()), bb(spec);
  std::mt19937_64 rng_a(5), rng_b(5), arng(6);
  a.Reset(rng_a, ba.out());
  b.Reset(rng_b, bb.out());
  std::vector<float> actions(spec.num_agents * spec.action.size());
  const int clearance_feature = LookaheadOffset(gated.interface) + LocalObs::kLookaheadClearance;
  int paid = 0, withheld = 0;
  for (int step = 0; step < 300 && !bb.terminated && !bb.truncated; ++step) {
    RandomActions(spec, arng, actions.data());
    a.Step(actions.data(), rng_a, ba.out());
    b.Step(actions.data(), rng_b, bb.out());
    const double d = b.last_step().distance_after;
    ASSERT_NEAR(d, a.last_step().distance_after, 1e-12) << step;
    double nearest = 1e9;  // the smallest predicted clearance over the joints, decoded from the block [m]
    for (int i = 0; i < spec.num_agents; ++i) {
      nearest = std::min(nearest, bb.obs(spec, i, clearance_feature) * gated.observation.length_scale);
    }
    const double kernel = std::exp(-d / 0.5), term = bb.reward_terms[1] - ba.reward_terms[1];
    ASSERT_GT(kernel, 0.1) << step;
    if (nearest <= 0.15 + 1e-6) {
      EXPECT_NEAR(term, -kernel, 1e-6) << step;
      ++withheld;
    } else {
      EXPECT_NEAR(term, 0.0, 1e-9) << step;
      ++paid;
    }
  }
  EXPECT_GT(paid, 10);
  EXPECT_GT(withheld, 10);
  // a gate needs the block: refused without the look-ahead, or with a NaN / +inf clearance
  TaskConfig blind = gated;
  blind.observation.lookahead = 0.0;
  EXPECT_THROW(ValidateTaskConfig(blind, "test"), rmpmarl::InputError);
  for (double c : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    TaskConfig bad = gated;
    bad.reward.precision_pass_clearance = c;
    EXPECT_THROW(ValidateTaskConfig(bad, "test"), rmpmarl::InputError) << c;
  }
}

// options.target_gate_*: a hand prior under the agent's target accel parameter, switched by the look-ahead block.
// Reference: an env without the prior, reading its parameters every step, fed the agent's held parameters (its last
// read, StepOutput::parameters_read) + the prior decided from its own observation's block (the clearance feature,
// decoded to metres). The actions are multiples of 2^-12, so the float sums of the reference are exact and the two
// trajectories are identical, bit for bit, step by step: with parameters read every step and held 25 steps (the
// prior is decided every step either way). Both branches occur, the sum is clipped, and the prior changes the
// trajectory (an env fed the raw actions drifts apart).
TEST(ManipulatorEnvTest, TargetGatePriorAddsTheGatedParameterToTheAgents) {
  TaskConfig plain = SmallConfig(TaskKind::kLineCrossing, "panda", 1);
  plain.scenario.line_speeds = {1.2};
  plain.observation.lookahead = 1.0;
  for (const int period : {1, 25}) {
    SCOPED_TRACE(period);
    TaskConfig prior = plain;
    prior.options.parameter_period = period;
    prior.options.target_gate_clearance = 0.15;
    prior.options.target_gate_clear = 1.0;
    prior.options.target_gate_threat = -0.5;
    TaskConfig unprimed = prior;  // the same parameter period, no prior
    unprimed.options.target_gate_clearance = -std::numeric_limits<double>::infinity();
    ManipulatorEnv a(MakeTaskContext(prior)), b(MakeTaskContext(plain)), raw(MakeTaskContext(unprimed));
    const EnvSpec& spec = a.spec();
    const ActionSpec& as = spec.action;
    Buffers ba(spec), bb(b.spec()), br(raw.spec());
    std::mt19937_64 rng_a(5), rng_b(5), rng_r(5), arng(6);
    a.Reset(rng_a, ba.out());
    b.Reset(rng_b, bb.out());
    raw.Reset(rng_r, br.out());
    std::vector<float> actions(spec.num_agents * as.size()), fed(actions.size()), kept(actions.size(), 0.0f);
    const int clearance_feature = LookaheadOffset(prior.interface) + LocalObs::kLookaheadClearance;
    int clear = 0, threat = 0, clipped = 0, holds = 0;
    double raw_gap = 0.0;
    for (int step = 0; step < 300 && !ba.terminated && !ba.truncated; ++step) {
      RandomActions(spec, arng, actions.data());
      for (float& u : actions) u = std::round(u * 4096.0f) / 4096.0f;  // option indices and flags stay integers
      std::vector<bool> fires(spec.num_agents);
      for (int i = 0; i < spec.num_agents; ++i) {
        const double nearest = bb.obs(spec, i, clearance_feature) * plain.observation.length_scale;
        ASSERT_FALSE(std::abs(nearest - 0.15) <= 1e-6) << step;  // no step on the threshold itself
        fires[i] = nearest < 0.15;
        (fires[i] ? threat : clear) += 1;
      }
      a.Step(actions.data(), rng_a, ba.out());
      raw.Step(actions.data(), rng_r, br.out());
      fed = actions;
      for (int i = 0; i < spec.num_agents; ++i) {
        const size_t row = i * as.size() + as.continuous_offset();
        if (ba.parameters_read[i] == 1.0f) {
          std::copy_n(actions.begin() + row, as.num_continuous, kept.begin() + row);
        } else {
          ++holds;
        }
        std::copy_n(kept.begin() + row, as.num_continuous, fed.begin() + row);
        float& u = fed[i * as.size() + RmpActionLayout::kTargetAccelScale];
        const float sum = u + (fires[i] ? -0.5f : 1.0f);
        if (std::abs(sum) > 1.0f) ++clipped;
        u = std::clamp(sum, -1.0f, 1.0f);
      }
      b.Step(fed.data(), rng_b, bb.out());
      ASSERT_EQ((a.world().q() - b.world().q()).cwiseAbs().maxCoeff(), 0.0) << "step " << step;
      raw_gap = std::max(raw_gap, (a.world().q() - raw.world().q()).cwiseAbs().maxCoeff());
    }
    // measured at period 1: 316 of 2100 agent-steps clear, 1784 threatened, 651 clipped
    EXPECT_GT(clear, 100);
    EXPECT_GT(threat, 100);
    EXPECT_GT(clipped, 100);
    if (period > 1) EXPECT_GT(holds, 1000);  // the agent's part was held on most steps
    EXPECT_GT(raw_gap, 0.05);  // [rad] the prior moves the arm
  }
  // the prior needs the block, the per-joint-rmp interface and parameters in [−1, 1]; each refusal names its key
  auto refused = [](const TaskConfig& c, const std::string& key) {
    try {
      ValidateTaskConfig(c, "test");
    } catch (const rmpmarl::InputError& e) {
      return std::string(e.what()).find(key) != std::string::npos;
    }
    return false;
  };
  TaskConfig prior = plain;
  prior.options.target_gate_clearance = 0.15;
  ValidateTaskConfig(prior, "test");
  TaskConfig blind = prior;
  blind.observation.lookahead = 0.0;
  EXPECT_TRUE(refused(blind, "options.target_gate_clearance"));
  TaskConfig direct = prior;
  direct.interface = InterfaceMode::kPerJointDirect;
  EXPECT_TRUE(refused(direct, "options.target_gate_clearance"));
  for (double c : {std::nan(""), std::numeric_limits<double>::infinity()}) {
    TaskConfig bad = prior;
    bad.options.target_gate_clearance = c;
    EXPECT_TRUE(refused(bad, "options.target_gate_clearance")) << c;
  }
  TaskConfig far = prior;
  far.options.target_gate_clear = 1.5;
  EXPECT_TRUE(refused(far, "options.target_gate_clear"));
  TaskConfig below = prior;
  below.options.target_gate_threat = -1.01;
  EXPECT_TRUE(refused(below, "options.target_gate_threat"));
}

// options.parameter_period: a joint reads its RMP parameters at the first step, at option starts, when W_i fills or
// empties, and every N steps, and holds them in between. Reference: an env reading every step, fed the held values
// (the action of each joint's last read) — the two trajectories are identical, step by step.
TEST(ManipulatorEnvTest, ParameterPeriodHoldsParametersBetweenReads) {
  TaskConfig held = SmallConfig(TaskKind::kReachAvoid, "panda", 1);
  held.options.parameter_period = 5;
  held.scenario.crossing.num_obstacles = 2;  // warnings come and go
  TaskConfig every = held;
  every.options.parameter_period = 1;
  auto held_context = MakeTaskContext(held);
  auto every_context = MakeTaskContext(every);
  ManipulatorEnv a(held_context), b(every_context);
  const EnvSpec& s = a.spec();
  const ActionSpec& as = s.action;
  Buffers ba(s), bb(b.spec());
  std::mt19937_64 rng_a(21), rng_b(21), arng(22);
  a.Reset(rng_a, ba.out());
  b.Reset(rng_b, bb.out());
  std::vector<float> actions(s.num_agents * as.size()), fed(actions.size()), last_read(actions.size(), 0.0f);
  std::vector<int> age(s.num_agents, 0);
  int reads = 0, holds = 0, early = 0;
  for (int step = 0; step < 300; ++step) {
    RandomActions(s, arng, actions.data());
    a.Step(actions.data(), rng_a, ba.out());
    fed = actions;
    for (int i = 0; i < s.num_agents; ++i) {
      float* row = fed.data() + i * as.size() + as.continuous_offset();
      const float* now = actions.data() + i * as.size() + as.continuous_offset();
      float* kept = last_read.data() + i * as.size() + as.continuous_offset();
      if (step == 0) {
        EXPECT_EQ(ba.parameters_read[i], 1.0f);
      }
      if (ba.parameters_read[i] == 1.0f) {
        std::copy(now, now + as.num_continuous, kept);
        early += age[i] > 0 && age[i] < 5;  // an option start or a W_i change
        age[i] = 0;
        ++reads;
      } else {
        EXPECT_EQ(ba.parameters_read[i], 0.0f);
        ++holds;
      }
      ++age[i];
      EXPECT_LE(age[i], 5) << "joint " << i << " step " << step;  // at least every 5 steps
      std::copy(kept, kept + as.num_continuous, row);
    }
    b.Step(fed.data(), rng_b, bb.out());
    ASSERT_EQ((a.world().q() - b.world().q()).cwiseAbs().maxCoeff(), 0.0) << "step " << step;
    EXPECT_EQ(bb.parameters_read, std::vector<float>(s.num_agents, 1.0f));  // period 1 reads every step
    if (ba.terminated || ba.truncated) break;
  }
  EXPECT_GT(2 * holds, reads);  // often held (the random actions also end options every ~5 steps)
  EXPECT_GT(early, 0);          // and read early where options start or warnings change
}

// options.target_gain_range 1: the target RMP's two scales are unit whatever the action, so two episodes whose
// actions differ only there are identical, step for step; with the default range the same difference changes the
// motion (the check can fail)
TEST(ManipulatorEnvTest, TargetGainRangeOneIgnoresTheTargetScales) {
  for (const double range : {1.0, 0.0}) {
    TaskConfig c = SmallConfig(TaskKind::kReachAvoid, "panda", 1);
    c.scenario.crossing.num_obstacles = 2;
    c.options.target_gain_range = range;
    auto context = MakeTaskContext(c);
    ManipulatorEnv a(context), b(context);
    const EnvSpec& s = a.spec();
    const ActionSpec& as = s.action;
    Buffers ba(s), bb(s);
    std::mt19937_64 rng_a(31), rng_b(31), arng(32);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f);
    a.Reset(rng_a, ba.out());
    b.Reset(rng_b, bb.out());
    std::vector<float> actions(s.num_agents * as.size()), other(actions.size());
    double max_difference = 0.0;
    for (int step = 0; step < 150; ++step) {
      RandomActions(s, arng, actions.data());
      other = actions;
      for (int i = 0; i < s.num_agents; ++i) {
        other[i * as.size() + RmpActionLayout::kTargetAccelScale] = u(arng);
        other[i * as.size() + RmpActionLayout::kTargetMetricScale] = u(arng);
      }
      a.Step(actions.data(), rng_a, ba.out());
      b.Step(other.data(), rng_b, bb.out());
      max_difference = std::max(max_difference, (a.world().q() - b.world().q()).cwiseAbs().maxCoeff());
      if (ba.terminated || ba.truncated || bb.terminated || bb.truncated) break;
    }
    if (range == 1.0) {
      EXPECT_EQ(max_difference, 0.0);
    } else {
      EXPECT_GT(max_difference, 1e-3);
    }
  }
}

// The look-ahead block (observation.lookahead T) against brute force: each moving cube's centre sampled along its
// straight path at 20001 instants of [0, T], the distance to every capsule axis joint i moves minus the capsule radius
// and the cube's bounding radius; the block holds the smallest such clearance, an instant at which it happens and that
// cube's speed.
TEST(ManipulatorEnvTest, LookaheadBlockMatchesSampledPaths) {
  TaskConfig c = SmallConfig(TaskKind::kLineCrossing, "panda", 1);
  c.observation.lookahead = 1.0;
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  const EnvSpec& s = env.spec();
  ASSERT_EQ(s.local_obs_dim, LocalObs::kRmpSize + LocalObs::kLookaheadSize);
  EXPECT_EQ(s.local_obs_names[LocalObs::kRmpSize + LocalObs::kLookaheadTime], "lookahead_time");
  const int base = LocalObs::kRmpSize;
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
          const int k_obs = static_cast<int>(std::lround(20000.0 * b.obs(s, i, base + LocalObs::kLookaheadTime)));
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
          EXPECT_NEAR(b.obs(s, i, base + LocalObs::kLookaheadClearance), std::clamp(best / l, -1.0, 2.0), 5e-4)
              << "episode " << episode << " step " << step << " joint " << i;
          EXPECT_NEAR(b.obs(s, i, base + LocalObs::kLookaheadSpeed), best_speed / c.observation.speed_scale, 1e-5);
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
    EXPECT_EQ(bs.obs(still.spec(), i, base + LocalObs::kLookaheadClearance), 2.0f);
    EXPECT_EQ(bs.obs(still.spec(), i, base + LocalObs::kLookaheadTime), 1.0f);
    EXPECT_EQ(bs.obs(still.spec(), i, base + LocalObs::kLookaheadSpeed), 0.0f);
  }
  // off by default: the paper's local observation size
  EXPECT_EQ(MakeTaskContext(SmallConfig(TaskKind::kLineCrossing, "panda", 1))->spec().local_obs_dim, LocalObs::kRmpSize);
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
  EXPECT_LT(env.metrics().min_clearance_m, 0.0);
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
std::vector<int> StartedPattern(OptionTermination termination, int horizon, const std::vector<int>& flags) {
  TaskConfig c = SmallConfig(TaskKind::kPretrain2Link, "", 1);
  c.options.termination = termination;
  c.options.horizon = horizon;
  ManipulatorEnv env(MakeTaskContext(c));
  const EnvSpec& s = env.spec();
  Buffers b(s);
  std::mt19937_64 rng(2);
  env.Reset(rng, b.out());
  std::vector<int> started;
  std::vector<float> actions(s.num_agents * s.action.size(), 0.0f);  // option 0 = target, scales 1
  for (size_t t = 0; t < flags.size(); ++t) {
    if (s.action.has_termination) actions[s.action.termination_offset()] = static_cast<float>(flags[t]);
    env.Step(actions.data(), rng, b.out());
    started.push_back(static_cast<int>(b.option_started[0]));
    // the observation shows the running option (zeros once it ended)
    const bool running = !env.option_machine(0).idle();
    EXPECT_EQ(b.obs(s, 0, LocalObs::kOption), running ? 1.0f : 0.0f);
    EXPECT_EQ(b.option_started[1], started.size() == 1 || (termination == OptionTermination::kFixed &&
                                                            (started.size() - 1) % horizon == 0)
                                       ? 1.0f
                                       : 0.0f);
  }
  return started;
}

TEST(ManipulatorEnvTest, OptionsPersistForAFixedHorizon) {
  EXPECT_EQ(StartedPattern(OptionTermination::kFixed, 4, std::vector<int>(10, 1)),
            (std::vector<int>{1, 0, 0, 0, 1, 0, 0, 0, 1, 0}));
}

TEST(ManipulatorEnvTest, OptionsPersistUntilTheLearnedTerminationFires) {
  EXPECT_EQ(StartedPattern(OptionTermination::kLearned, 4, {0, 0, 0, 0, 0, 0, 1, 0, 1, 1, 0}),
            (std::vector<int>{1, 0, 0, 0, 0, 0, 0, 1, 0, 1, 1}));
}

// ------------------------------------------------------------------------------- domain randomisation

TEST(ManipulatorEnvTest, LinkLengthVariantsRespectTheirRanges) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.randomization.variants = 8;
  auto planar = MakeTaskContext(c);
  std::set<double> lengths;
  for (int k = 0; k < planar->num_variants(); ++k) {
    const RobotVariant& v = planar->variant(k);
    for (double len : v.planar2_lengths) {
      EXPECT_GE(len, 0.3);
      EXPECT_LE(len, 0.7);
      lengths.insert(len);
    }
    // the compiled robot has those lengths: the end effector at q = 0 is at l1 + l2 along x
    const kinematics::Robot& robot = v.world_model->robot();
    kinematics::Data data(robot.model);
    kinematics::CalcForwardKinematics(robot.model, Eigen::Vector2d::Zero(), &data);
    const Eigen::Vector3d p = kinematics::CalcPointPosition(data, robot.end_effector.link,
                                                            robot.end_effector.X_LE.translation());
    EXPECT_NEAR(p.x(), v.planar2_lengths[0] + v.planar2_lengths[1], 1e-12);
  }
  EXPECT_NEAR(planar->variant(0).planar2_lengths[0], 0.5, 1e-12);  // the nominal variant
  EXPECT_GE(lengths.size(), 14u);

  TaskConfig u = SmallConfig(TaskKind::kReachAvoid, "ur5e", 5);
  u.randomization.link_scale = {0.8, 1.2};
  auto arm = MakeTaskContext(u);
  const kinematics::Robot nominal = kinematics::LoadShippedRobot("ur5e");
  for (int k = 0; k < arm->num_variants(); ++k) {
    const double s = arm->variant(k).link_scale;
    EXPECT_GE(s, 0.8);
    EXPECT_LE(s, 1.2);
    const kinematics::Robot& r = arm->variant(k).world_model->robot();
    for (int j = 0; j < nominal.model.num_links(); ++j) {
      EXPECT_LT((r.model.link(j).X_PJ.translation() - s * nominal.model.link(j).X_PJ.translation()).norm(), 1e-12);
    }
    for (size_t j = 0; j < nominal.capsules.size(); ++j) {
      EXPECT_NEAR(r.capsules[j].radius, s * nominal.capsules[j].radius, 1e-12);
      EXPECT_LT((r.capsules[j].p_LB - s * nominal.capsules[j].p_LB).norm(), 1e-12);
    }
    EXPECT_LT((r.end_effector.X_LE.translation() - s * nominal.end_effector.X_LE.translation()).norm(), 1e-12);
  }
  EXPECT_EQ(arm->variant(0).link_scale, 1.0);
}

TEST(ManipulatorEnvTest, ResetsReuseTheVariantPool) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.randomization.variants = 4;
  const long before_context = WorldModelsBuilt();
  auto context = MakeTaskContext(c);
  EXPECT_EQ(WorldModelsBuilt() - before_context, 4);  // K models, once
  const long before = WorldModelsBuilt();
  rl::VecEnv envs(MakeManipulatorEnvFactory(context), {.num_envs = 3, .seed = 11, .num_threads = 1});
  std::vector<std::unique_ptr<ManipulatorEnv>> direct;
  for (int k = 0; k < 2; ++k) direct.push_back(std::make_unique<ManipulatorEnv>(context));
  std::set<const sim::WorldModel*> used;
  std::mt19937_64 rng(4);
  Buffers b(context->spec());
  for (int r = 0; r < 40; ++r) {
    envs.Reset();
    for (auto& env : direct) {
      env->Reset(rng, b.out());
      used.insert(env->world().shared_model().get());
      EXPECT_EQ(env->world().shared_model(), context->variant(env->variant()).world_model);  // the pool's model
    }
  }
  EXPECT_EQ(WorldModelsBuilt(), before);  // envs and resets built none
  EXPECT_EQ(used.size(), 4u);             // every variant was drawn
  EXPECT_GE(context->variant(0).world_model.use_count(), 2);
}

TEST(ManipulatorEnvTest, PretrainResetsRandomiseWithinTheirRanges) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.scenario.pretrain.obstacle_path_offset = {0.0, 0.0};  // the paper's scene: the cube on the path
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  Buffers b(env.spec());
  std::mt19937_64 rng(9);
  std::set<double> q0s, speeds;
  for (int r = 0; r < 30; ++r) {
    env.Reset(rng, b.out());
    const Eigen::VectorXd& q = env.world().q();
    const Eigen::VectorXd& qd = env.world().qd();
    for (int i = 0; i < 2; ++i) {
      EXPECT_LE(std::abs(q[i]), 1.5 + 1e-12);  // ready posture 0 ± initial_q_spread
      EXPECT_LE(std::abs(qd[i]), 0.2 * 3.0 + 1e-12);
    }
    q0s.insert(q[0]);
    const sim::TargetState& t = env.scenario().target();
    const double v = t.v_WT.norm();
    EXPECT_GE(v, 0.05 - 1e-12);
    EXPECT_LE(v, 0.25 + 1e-12);
    EXPECT_NEAR(t.v_WT.z(), 0.0, 1e-12);  // in the arm's plane
    speeds.insert(v);
    EXPECT_TRUE(t.bounds.contains(t.p_WT));
    // the cube sits on the target's reflected path, 1–3 s ahead
    const Eigen::Vector3d cube = env.scenario().obstacles()[0].p_WO();
    double nearest = 1e9;
    for (double time = 1.0; time <= 3.0; time += 1e-3) {
      nearest = std::min(nearest, (ReflectedPosition(t.p_WT, t.v_WT, time, t.bounds) - cube).norm());
    }
    EXPECT_LT(nearest, 1e-3);
  }
  EXPECT_EQ(q0s.size(), 30u);
  EXPECT_EQ(speeds.size(), 30u);
}

TEST(ManipulatorEnvTest, PretrainPathOffsetPutsTheCubeBesideTheWholePath) {
  TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  c.scenario.pretrain.obstacle_path_offset = {0.05, 0.10};
  auto context = MakeTaskContext(c);
  ManipulatorEnv env(context);
  Buffers b(env.spec());
  std::mt19937_64 rng(21);
  const double h = 0.5 * c.scenario.pretrain.obstacle_side;
  int left = 0, right = 0;
  for (int r = 0; r < 30; ++r) {
    env.Reset(rng, b.out());
    const sim::TargetState& t = env.scenario().target();
    const Eigen::Vector3d cube = env.scenario().obstacles()[0].p_WO();
    // brute force, 1 ms steps, the distance from the library's capsule–box query (a point: a zero-radius capsule):
    // the whole path (the scenario's duration) keeps the range's minimum from the cube ...
    math::Box box;
    box.X_WB.translation() = cube;
    box.half_size.setConstant(h);
    double nearest_all = 1e9, nearest_lead = 1e9, time_lead = 0.0;
    for (double time = 0.0; time <= env.scenario().default_duration(); time += 1e-3) {
      const Eigen::Vector3d x = ReflectedPosition(t.p_WT, t.v_WT, time, t.bounds);
      const double d = math::CapsuleBoxDistance(math::Capsule{x, x, 0.0}, box).distance;
      nearest_all = std::min(nearest_all, d);
      if (time >= 1.0 && time <= 3.0 && d < nearest_lead) {
        nearest_lead = d;
        time_lead = time;
      }
    }
    EXPECT_GE(nearest_all, 0.05 - 1e-3);
    // ... and passes it within the range's maximum (plus a corner's excess over a face, h (sqrt 2 - 1)) 1–3 s ahead
    EXPECT_LE(nearest_lead, 0.10 + h * (std::sqrt(2.0) - 1.0) + 1e-3);
    const Eigen::Vector3d p = ReflectedPosition(t.p_WT, t.v_WT, time_lead, t.bounds);
    const Eigen::Vector3d d = ReflectedDirection(t.p_WT, t.v_WT, time_lead, t.bounds);
    (d.cross(cube - p).z() > 0.0 ? left : right)++;
  }
  EXPECT_GE(left, 5);  // both sides of the path
  EXPECT_GE(right, 5);
}

// the shipped scene's rejections (the cube must stay clear of the whole path) must not bias the target's speed: the
// accepted episodes keep U(0.05, 0.25) m/s — mean 0.15, both quartiles near 0.10 and 0.20
TEST(ManipulatorEnvTest, PretrainPathOffsetKeepsTheTargetSpeedDistribution) {
  const TaskConfig c = DefaultTaskConfig(TaskKind::kPretrain2Link);
  ASSERT_GT(c.scenario.pretrain.obstacle_path_offset[1], 0.0);
  ManipulatorEnv env(MakeTaskContext(c));
  Buffers b(env.spec());
  std::mt19937_64 rng(31);
  std::vector<double> speeds;
  for (int r = 0; r < 400; ++r) {
    env.Reset(rng, b.out());
    speeds.push_back(env.scenario().target().v_WT.norm());
  }
  std::sort(speeds.begin(), speeds.end());
  double mean = 0.0;
  for (double v : speeds) mean += v / speeds.size();
  std::printf("accepted target speeds: mean %.4f, quartiles %.4f %.4f %.4f\n", mean, speeds[100], speeds[200],
              speeds[300]);
  EXPECT_NEAR(mean, 0.15, 0.01);  // the standard error of 400 uniform draws is 0.0029
  EXPECT_NEAR(speeds[100], 0.10, 0.015);
  EXPECT_NEAR(speeds[300], 0.20, 0.015);
}

TEST(ManipulatorEnvTest, ReflectedDirectionIsTheDerivativeOfTheReflectedPath) {
  const Eigen::AlignedBox3d box(Eigen::Vector3d(0.2, -0.5, 0.0), Eigen::Vector3d(0.8, 0.5, 0.0));
  const Eigen::Vector3d p(0.3, 0.1, 0.0), v(0.21, -0.13, 0.0);
  int checked = 0;
  for (double t = 0.0; t < 20.0; t += 0.137) {
    const double e = 1e-6;
    const Eigen::Vector3d fd =
        (ReflectedPosition(p, v, t + e, box) - ReflectedPosition(p, v, t - e, box)) / (2.0 * e);
    if (std::abs(fd.norm() - v.norm()) > 1e-6) continue;  // a reflection inside the difference stencil
    EXPECT_LT((ReflectedDirection(p, v, t, box) - fd.normalized()).norm(), 1e-6) << "t " << t;
    ++checked;
  }
  EXPECT_GT(checked, 130);  // of 146 times, all but those within 1 µs of a reflection
  EXPECT_EQ(ReflectedDirection(p, Eigen::Vector3d::Zero(), 1.0, box), Eigen::Vector3d::Zero());
}

TEST(ManipulatorEnvTest, LineCrossingDrawsItsSpeedPerEpisode) {
  auto context = MakeTaskContext(SmallConfig(TaskKind::kLineCrossing, "panda", 1));
  EXPECT_EQ(context->num_scenario_settings(), 5);
  ManipulatorEnv env(context);
  Buffers b(env.spec());
  std::mt19937_64 rng(2);
  std::set<double> speeds;
  for (int r = 0; r < 25; ++r) {
    env.Reset(rng, b.out());
    const double v = env.scenario().obstacles()[0].speed;
    EXPECT_EQ(v, context->config().scenario.line_speeds[env.scenario_setting()]);
    speeds.insert(v);
  }
  EXPECT_EQ(speeds, (std::set<double>{0.2, 0.6, 1.2, 1.8, 2.8}));
}

// --------------------------------------------------------------------------------------------- determinism

TEST(ManipulatorEnvTest, SameSeedSameTrajectory) {
  for (TaskKind task : {TaskKind::kPretrain2Link, TaskKind::kReachAvoid}) {
    TaskConfig c = SmallConfig(task, "", 3);
    c.episode.max_steps = 60;
    auto context = MakeTaskContext(c);
    ManipulatorEnv a(context), b(context);
    const EnvSpec& s = a.spec();
    Buffers ba(s), bb(s);
    std::mt19937_64 ra(42), rb(42), actions_rng(7);
    a.Reset(ra, ba.out());
    b.Reset(rb, bb.out());
    std::vector<float> actions(s.num_agents * s.action.size());
    for (int step = 0; step < 200; ++step) {
      RandomActions(s, actions_rng, actions.data());
      a.Step(actions.data(), ra, ba.out());
      b.Step(actions.data(), rb, bb.out());
      ASSERT_EQ(ba.local_obs, bb.local_obs) << step;
      ASSERT_EQ(ba.global_state, bb.global_state) << step;
      ASSERT_EQ(ba.reward_terms, bb.reward_terms) << step;
      ASSERT_EQ(ba.terminated, bb.terminated);
      ASSERT_EQ(ba.truncated, bb.truncated);
      if (ba.terminated || ba.truncated) {
        a.Reset(ra, ba.out());
        b.Reset(rb, bb.out());
        ASSERT_EQ(ba.local_obs, bb.local_obs);
      }
    }
  }
}

TEST(ManipulatorEnvTest, VecEnvResultsDoNotDependOnTheThreadCount) {
  TaskConfig c = SmallConfig(TaskKind::kReachAvoid, "ur5e", 3);
  c.episode.max_steps = 40;
  auto context = MakeTaskContext(c);
  rl::VecEnv one(MakeManipulatorEnvFactory(context), {.num_envs = 4, .seed = 3, .num_threads = 1});
  rl::VecEnv two(MakeManipulatorEnvFactory(context), {.num_envs = 4, .seed = 3, .num_threads = 2});
  one.Reset();
  two.Reset();
  const EnvSpec& s = one.spec();
  std::vector<float> actions(4 * s.num_agents * s.action.size());
  std::mt19937_64 rng(8);
  for (int step = 0; step < 100; ++step) {
    for (int k = 0; k < 4; ++k) RandomActions(s, rng, actions.data() + k * s.num_agents * s.action.size());
    one.Step(actions.data());
    two.Step(actions.data());
    ASSERT_TRUE(one.batch().local_obs == two.batch().local_obs) << step;
    ASSERT_TRUE(one.batch().reward == two.batch().reward) << step;
  }
}

// --------------------------------------------------------------------------------------------- bad input

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
