// Reward terms of eq (14) and the option state machine against hand-computed values.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/tasks/reward.h"

namespace rmpmarl::tasks {
namespace {

TEST(RewardTest, DistanceRewardIsOnePointPerMillimetre) {
  EXPECT_NEAR(DistanceReward(0.100, 0.095, 0.001), 5.0, 1e-9);    // 0.5 cm closer: +5
  EXPECT_NEAR(DistanceReward(0.095, 0.100, 0.001), -5.0, 1e-9);   // 0.5 cm farther: −5 (signed)
  EXPECT_NEAR(DistanceReward(0.3, 0.3, 0.001), 0.0, 1e-12);
  EXPECT_NEAR(DistanceReward(0.0123, 0.0120, 0.001), 0.3, 1e-9);  // partial points count
}

TEST(RewardTest, JointReachRewardsUseSequentialSubTargets) {
  // e = (0.1, 0, 0); joint 0 moves the end effector by (0, 0.05, 0): sideways, |t0 − s0| = 0.1118 > 0.1 → R0 = 0.
  // t1 = e − s0 = (0.1, −0.05, 0); joint 1 moves it by (0.04, 0, 0): |t1 − s1| = 0.0781 < |t1| = 0.1118 → R1 = 1.
  // t2 = (0.06, −0.05, 0); joint 2 moves it by (0.2, 0, 0): overshoots, |t2 − s2| = 0.1487 > 0.0781 → R2 = 0.
  Eigen::Matrix3Xd J(3, 3);
  J.col(0) << 0.0, 0.5, 0.0;
  J.col(1) << 0.2, 0.0, 0.0;
  J.col(2) << 1.0, 0.0, 0.0;
  const Eigen::Vector3d dq(0.1, 0.2, 0.2);
  Eigen::VectorXd R(3);
  JointReachRewards(Eigen::Vector3d(0.1, 0.0, 0.0), J, dq, 1e-4, R);
  EXPECT_EQ(R[0], 0.0);
  EXPECT_EQ(R[1], 1.0);
  EXPECT_EQ(R[2], 0.0);
  // without the sideways joint-0 motion, joint 1's step is judged against the whole error: 0.06 < 0.1 → 1
  JointReachRewards(Eigen::Vector3d(0.1, 0.0, 0.0), J, Eigen::Vector3d(0.0, 0.2, 0.0), 1e-4, R);
  EXPECT_EQ(R[0], 0.0);  // no motion is no progress
  EXPECT_EQ(R[1], 1.0);
  EXPECT_EQ(R[2], 0.0);
  // the tolerance η: a 0.05 mm improvement does not count with η = 0.1 mm
  JointReachRewards(Eigen::Vector3d(0.1, 0.0, 0.0), J, Eigen::Vector3d(0.0, 0.00025, 0.0), 1e-4, R);
  EXPECT_EQ(R[1], 0.0);
}

TEST(RewardTest, TimeRewardWhenAReachCycleIsShorterThanThePreviousOne) {
  ReachCycleTracker t(0.02, 0.04, 25.0);
  t.Reset();
  // cycle 1: reached at step 3 → compared with +inf → 25
  EXPECT_EQ(t.Update(0.10), 0.0);
  EXPECT_EQ(t.Update(0.05), 0.0);
  EXPECT_EQ(t.Update(0.015), 25.0);
  EXPECT_EQ(t.previous_cycle_steps(), 3.0);
  // stays near the target: no new cycle (hysteresis between 0.02 and 0.04)
  EXPECT_EQ(t.Update(0.03), 0.0);
  EXPECT_EQ(t.Update(0.01), 0.0);
  // the target gets away (d > 0.04): cycle 2 starts with this step and takes 2 steps → 2 < 3 → 25
  EXPECT_EQ(t.Update(0.05), 0.0);
  EXPECT_EQ(t.Update(0.019), 25.0);
  // cycle 3 takes 4 steps: not shorter → 0
  EXPECT_EQ(t.Update(0.06), 0.0);
  EXPECT_EQ(t.Update(0.06), 0.0);
  EXPECT_EQ(t.Update(0.06), 0.0);
  EXPECT_EQ(t.Update(0.0), 0.0);
  EXPECT_EQ(t.cycles_completed(), 3);
  EXPECT_EQ(t.previous_cycle_steps(), 4.0);
}

TEST(RewardTest, TermsSum) {
  const RewardTerms r{.joint_reach = 1.5, .distance = -3.0, .time = 25.0, .collision = -75.0};
  EXPECT_DOUBLE_EQ(r.total(), -51.5);
}

TEST(ActionTest, GainScaleMapsTheUnitIntervalToOneQuarterToFour) {
  EXPECT_NEAR(control::GainScale(0.0, 4.0), 1.0, 1e-12);
  EXPECT_NEAR(control::GainScale(1.0, 4.0), 4.0, 1e-12);
  EXPECT_NEAR(control::GainScale(-1.0, 4.0), 0.25, 1e-12);
  EXPECT_NEAR(control::GainScale(0.5, 4.0), 2.0, 1e-12);
  EXPECT_NEAR(control::GainScale(7.0, 4.0), 4.0, 1e-12);  // clipped
  EXPECT_NEAR(control::GainScale(-3.0, 4.0), 0.25, 1e-12);
}

TEST(ActionTest, OptionIndicesMustBeIntegersInRange) {
  EXPECT_EQ(control::DecodeOptionIndex(0.0f, 3), 0);
  EXPECT_EQ(control::DecodeOptionIndex(2.0f, 3), 2);
  EXPECT_EQ(control::DecodeOptionIndex(1.0004f, 3), 1);
  EXPECT_EQ(control::DecodeOptionIndex(1.5f, 3), -1);
  EXPECT_EQ(control::DecodeOptionIndex(3.0f, 3), -1);
  EXPECT_EQ(control::DecodeOptionIndex(-1.0f, 3), -1);
  EXPECT_EQ(control::DecodeOptionIndex(std::numeric_limits<float>::quiet_NaN(), 3), -1);
  EXPECT_EQ(control::DecodeOptionIndex(std::numeric_limits<float>::infinity(), 3), -1);
}

constexpr int kTarget = static_cast<int>(control::RmpOption::kTarget);
constexpr int kCollision = static_cast<int>(control::RmpOption::kCollision);
constexpr int kComposite = static_cast<int>(control::RmpOption::kTargetThenCollision);

TEST(OptionMachineTest, FixedHorizonRunsExactlyHorizonSteps) {
  control::OptionMachine m(OptionTermination::kFixed, 3);
  m.Reset();
  std::vector<int> started;
  for (int step = 0; step < 9; ++step) {
    // the chosen index changes every step: only the first step of each option reads it
    const control::OptionSelection s = m.Begin(step % 2 == 0 ? kTarget : kComposite, false);
    started.push_back(s.started);
    EXPECT_TRUE(s.use_target);
    EXPECT_FALSE(s.use_collision);
    m.End(/*terminate_flag=*/true, false);  // ignored in fixed mode
  }
  EXPECT_EQ(started, (std::vector<int>{1, 0, 0, 1, 0, 0, 1, 0, 0}));
}

TEST(OptionMachineTest, LearnedTerminationEndsAfterTheFlaggedStep) {
  control::OptionMachine m(OptionTermination::kLearned, 10);
  m.Reset();
  const bool flags[] = {false, false, true, false, true, true, false};
  std::vector<int> started;
  for (bool flag : flags) {
    started.push_back(m.Begin(kTarget, false).started);
    m.End(flag, false);
  }
  EXPECT_EQ(started, (std::vector<int>{1, 0, 0, 1, 0, 1, 1}));
  EXPECT_EQ(m.age(), 1);  // the horizon does not cap a learned option
}

TEST(OptionMachineTest, CollisionOptionNeedsAWarningAndEndsWithIt) {
  control::OptionMachine m(OptionTermination::kLearned, 10);
  m.Reset();
  // outside its initiation set: not applicable, the target RMP runs this step and the option ends after it
  control::OptionSelection s = m.Begin(kCollision, /*warning=*/false);
  EXPECT_TRUE(s.started);
  EXPECT_TRUE(s.use_target);
  EXPECT_FALSE(s.use_collision);
  EXPECT_TRUE(m.End(false, /*warning_next=*/true));
  EXPECT_TRUE(m.idle());
  // inside: runs while the warning lasts
  s = m.Begin(kCollision, true);
  EXPECT_TRUE(s.started && s.use_collision && !s.use_target);
  EXPECT_FALSE(m.End(false, true));
  s = m.Begin(kTarget, true);  // ignored: the option runs on
  EXPECT_TRUE(!s.started && s.use_collision);
  EXPECT_TRUE(m.End(false, /*warning_next=*/false));  // the obstacle left the warning distance
  EXPECT_TRUE(m.idle());
}

TEST(OptionMachineTest, CompositeRunsTargetThenCollision) {
  control::OptionMachine m(OptionTermination::kLearned, 10);
  m.Reset();
  control::OptionSelection s = m.Begin(kComposite, false);
  EXPECT_TRUE(s.started && s.use_target && !s.use_collision);
  EXPECT_FALSE(m.End(false, false));
  s = m.Begin(kTarget, false);
  EXPECT_TRUE(!s.started && s.use_target);
  EXPECT_FALSE(m.End(false, /*warning_next=*/true));  // a terminates: obstacle within the warning distance
  EXPECT_TRUE(m.phase_b());
  s = m.Begin(kTarget, true);
  EXPECT_TRUE(!s.started && s.use_collision && !s.use_target);
  EXPECT_FALSE(m.End(false, true));
  s = m.Begin(kTarget, true);
  EXPECT_TRUE(s.use_collision);
  EXPECT_TRUE(m.End(false, false));  // b terminates: the warning set emptied
  EXPECT_TRUE(m.idle());
  // starting inside the warning set: phase a ends at once
  s = m.Begin(kComposite, true);
  EXPECT_TRUE(s.started && s.use_collision && m.phase_b());
  // the learned flag ends the composite in either phase
  EXPECT_TRUE(m.End(true, true));
}

}  // namespace
}  // namespace rmpmarl::tasks
