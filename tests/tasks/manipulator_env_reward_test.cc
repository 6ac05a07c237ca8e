// ManipulatorEnv rewards and the agents' option and parameter machinery: each reward term against its definition,
// the precision terms, the hand-gate prior, parameter holding and the target gain range.
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/common/error.h"

#include <fmt/format.h>
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
  const int clearance_feature = control::LookaheadOffset(gated.interface) + control::LocalObs::kLookaheadClearance;
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

// options.target_gate_* and collision_gate_*: hand priors under the agent's target and collision accel parameters,
// switched by the look-ahead block.
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
  for (const auto& [period, threat_only] : {std::pair{1, false}, std::pair{25, false}, std::pair{25, true}}) {
    SCOPED_TRACE(fmt::format("period {}, agents under threat only {}", period, threat_only));
    TaskConfig base = plain;  // the agents only under threat need a fixed option (the composite one here)
    if (threat_only) base.options.fixed_option = 2;
    TaskConfig prior = base;
    prior.options.parameter_period = period;
    prior.options.agents_under_threat_only = threat_only;
    // with the agents' part only under threat the arm tracks calmly and the line passes wider: a wider gate
    const double gate = threat_only ? 0.2 : 0.15;
    prior.options.target_gate_clearance = gate;
    prior.options.target_gate_clear = 1.0;
    prior.options.target_gate_threat = -0.5;
    prior.options.collision_gate_clear = -0.75;
    prior.options.collision_gate_threat = 0.25;
    TaskConfig unprimed = prior;  // the same parameter period, no prior
    unprimed.options.target_gate_clearance = -std::numeric_limits<double>::infinity();
    unprimed.options.collision_gate_clear = 0.0;
    unprimed.options.collision_gate_threat = 0.0;
    unprimed.options.agents_under_threat_only = false;
    ManipulatorEnv a(MakeTaskContext(prior)), b(MakeTaskContext(base)), raw(MakeTaskContext(unprimed));
    const EnvSpec& spec = a.spec();
    const ActionSpec& as = spec.action;
    Buffers ba(spec), bb(b.spec()), br(raw.spec());
    std::mt19937_64 rng_a(5), rng_b(5), rng_r(5), arng(6);
    a.Reset(rng_a, ba.out());
    b.Reset(rng_b, bb.out());
    raw.Reset(rng_r, br.out());
    std::vector<float> actions(spec.num_agents * as.size()), fed(actions.size()), kept(actions.size(), 0.0f);
    const int clearance_feature = control::LookaheadOffset(prior.interface) + control::LocalObs::kLookaheadClearance;
    int clear = 0, threat = 0, clipped = 0, collision_clipped = 0, holds = 0;
    double raw_gap = 0.0;
    for (int step = 0; step < 300 && !ba.terminated && !ba.truncated; ++step) {
      RandomActions(spec, arng, actions.data());
      for (float& u : actions) u = std::round(u * 4096.0f) / 4096.0f;  // option indices and flags stay integers
      std::vector<bool> fires(spec.num_agents);
      for (int i = 0; i < spec.num_agents; ++i) {
        const double nearest = bb.obs(spec, i, clearance_feature) * plain.observation.length_scale;
        ASSERT_FALSE(std::abs(nearest - gate) <= 1e-6) << step;  // no step on the threshold itself
        fires[i] = nearest < gate;
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
        // agents_under_threat_only: no pass predicted, the priors alone
        if (threat_only && !fires[i]) std::fill_n(fed.begin() + row, as.num_continuous, 0.0f);
        float& u = fed[i * as.size() + control::RmpActionLayout::kTargetAccelScale];
        const float sum = u + (fires[i] ? -0.5f : 1.0f);
        if (std::abs(sum) > 1.0f) ++clipped;
        u = std::clamp(sum, -1.0f, 1.0f);
        float& uc = fed[i * as.size() + control::RmpActionLayout::kCollisionAccelScale];
        const float csum = uc + (fires[i] ? 0.25f : -0.75f);
        if (std::abs(csum) > 1.0f) ++collision_clipped;
        uc = std::clamp(csum, -1.0f, 1.0f);
      }
      b.Step(fed.data(), rng_b, bb.out());
      ASSERT_EQ((a.world().q() - b.world().q()).cwiseAbs().maxCoeff(), 0.0) << "step " << step;
      raw_gap = std::max(raw_gap, (a.world().q() - raw.world().q()).cwiseAbs().maxCoeff());
    }
    // measured at period 1: 316 of 2100 agent-steps clear, 1784 threatened, 651 clipped
    EXPECT_GT(clear, threat_only ? 20 : 100);  // with the agents only under threat: 25 of 2100 clear at 20 cm
    EXPECT_GT(threat, 100);
    EXPECT_GT(clipped, 100);
    EXPECT_GT(collision_clipped, 20);
    if (period > 1) {
      EXPECT_GT(holds, 1000);  // the agent's part was held on most steps
    }
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
  TaskConfig collision_far = prior;
  collision_far.options.collision_gate_clear = -1.5;
  EXPECT_TRUE(refused(collision_far, "options.collision_gate_clear"));
  TaskConfig collision_nan = prior;
  collision_nan.options.collision_gate_threat = std::nan("");
  EXPECT_TRUE(refused(collision_nan, "options.collision_gate_threat"));
  TaskConfig ungated = plain;  // a collision prior needs the gate's clearance
  ungated.options.collision_gate_clear = -1.0;
  EXPECT_TRUE(refused(ungated, "options.collision_gate_clear"));
  TaskConfig ungated_agents = plain;
  ungated_agents.options.agents_under_threat_only = true;
  ungated_agents.options.fixed_option = 2;
  EXPECT_TRUE(refused(ungated_agents, "options.agents_under_threat_only"));
  TaskConfig learned_options = prior;  // gated, but the agents choose their options
  learned_options.options.agents_under_threat_only = true;
  learned_options.options.fixed_option = -1;
  EXPECT_TRUE(refused(learned_options, "options.agents_under_threat_only"));
  learned_options.options.fixed_option = 2;
  ValidateTaskConfig(learned_options, "test");
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

// StepOutput::next_action_read: an agent marked 0 has its action ignored by the next step. Two envs on the same
// episodes, one fed random actions, the other the same where marked 1 and other random values where marked 0, stay
// identical step by step; the marks are both 0 and 1 (held parameters, also read early where a warning set changes),
// agree with what the step then read, and are all 1 where every step reads the action: a learned termination flag,
// parameter_period 1, the direct interface.
TEST(ManipulatorEnvTest, NextActionReadMarksTheActionsTheNextStepIgnores) {
  struct Case {
    int fixed_option;
    OptionTermination termination;
    int period;
    InterfaceMode interface;
  };
  constexpr int kPeriod = 6;
  for (const Case& k : {Case{2, OptionTermination::kFixed, kPeriod, InterfaceMode::kPerJointRmp},
                        Case{-1, OptionTermination::kFixed, kPeriod, InterfaceMode::kPerJointRmp},
                        Case{-1, OptionTermination::kLearned, kPeriod, InterfaceMode::kPerJointRmp},
                        Case{2, OptionTermination::kFixed, 1, InterfaceMode::kPerJointRmp},
                        Case{-1, OptionTermination::kLearned, 1, InterfaceMode::kDirect}}) {
    SCOPED_TRACE(::testing::Message() << "fixed option " << k.fixed_option << ", period " << k.period
                                      << ", interface " << InterfaceModeName(k.interface));
    TaskConfig c = SmallConfig(TaskKind::kReachAvoid, "panda", 1);
    c.interface = k.interface;
    c.options.parameter_period = k.period;
    c.options.fixed_option = k.fixed_option;
    c.options.termination = k.termination;
    c.options.horizon = 20;
    c.scenario.crossing.num_obstacles = 4;
    c.observation.warning_distance = 0.2;
    c.options.warnings = OptionWarnings::kAll;  // W_i of any warning: it fills and empties often
    auto context = MakeTaskContext(c);
    ManipulatorEnv a(context), b(context);
    const EnvSpec& s = a.spec();
    const ActionSpec& as = s.action;
    Buffers ba(s), bb(s);
    std::mt19937_64 rng_a(41), rng_b(41), arng(42), brng(43);
    std::vector<float> actions(s.num_agents * as.size()), other(actions.size());
    int ignored = 0, read = 0, warning_reads = 0;
    for (int episode = 0; episode < 2; ++episode) {
      a.Reset(rng_a, ba.out());
      b.Reset(rng_b, bb.out());
      EXPECT_EQ(ba.next_action_read, std::vector<float>(s.num_agents, 1.0f));  // the first step reads every action
      std::vector<int> age(s.num_agents, 0);
      for (int step = 0; step < 150; ++step) {
        RandomActions(s, arng, actions.data());
        RandomActions(s, brng, other.data());
        const std::vector<float> predicted = ba.next_action_read;
        for (int i = 0; i < s.num_agents; ++i) {
          ASSERT_TRUE(predicted[i] == 0.0f || predicted[i] == 1.0f);
          if (predicted[i] == 0.0f) {
            ++ignored;
          } else {
            ++read;
            std::copy_n(actions.begin() + i * as.size(), as.size(), other.begin() + i * as.size());
          }
        }
        a.Step(actions.data(), rng_a, ba.out());
        b.Step(other.data(), rng_b, bb.out());
        ASSERT_EQ((a.world().q() - b.world().q()).cwiseAbs().maxCoeff(), 0.0) << "step " << step;
        ASSERT_EQ(ba.local_obs, bb.local_obs) << "step " << step;
        ASSERT_EQ(ba.next_action_read, bb.next_action_read) << "step " << step;
        for (int i = 0; i < s.num_agents; ++i) {
          // what the step read was marked; with the option fixed, only what it read
          EXPECT_TRUE(predicted[i] == 1.0f || (ba.parameters_read[i] == 0.0f && ba.option_started[i] == 0.0f));
          if (k.fixed_option >= 0) {
            EXPECT_EQ(predicted[i], ba.parameters_read[i]) << "step " << step;
          }
          ++age[i];
          if (ba.parameters_read[i] == 1.0f) {
            // read before the period ran out with no option starting: the warning set emptied or filled
            warning_reads += step > 0 && age[i] < kPeriod && ba.option_started[i] == 0.0f;
            age[i] = 0;
          }
        }
        if (ba.terminated || ba.truncated) break;
      }
    }
    if (k.termination == OptionTermination::kLearned || k.period == 1) {
      EXPECT_EQ(ignored, 0);  // every step reads every action
    } else {
      EXPECT_GT(ignored, 2 * read);  // most steps hold every parameter
      EXPECT_GT(read, 0);
      EXPECT_GT(warning_reads, 0);
    }
  }
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
        other[i * as.size() + control::RmpActionLayout::kTargetAccelScale] = u(arng);
        other[i * as.size() + control::RmpActionLayout::kTargetMetricScale] = u(arng);
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

}  // namespace
}  // namespace rmpmarl::tasks
