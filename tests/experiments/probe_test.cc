// experiments::ProbeLookahead against a policy whose response to the look-ahead block is known by hand: a linear
// actor whose target-stiffness mean is u = a · (clearance feature) + b and which ignores every other feature.
#include <gtest/gtest.h>

#include <filesystem>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/probe.h"
#include "rmpmarl/rl/agent_interface.h"
#include "rmpmarl/rl/manipulator_env.h"
#include "rmpmarl/rl/policy_runtime.h"

namespace rmpmarl::experiments {
namespace {
namespace fs = std::filesystem;

rl::TaskConfig LookaheadTask() {
  rl::TaskConfig c = rl::DefaultTaskConfig(rl::TaskKind::kLineCrossing);
  c.randomization.variants = 2;
  c.episode.max_steps = 120;
  c.scenario.line_speeds = {1.8};
  c.observation.lookahead = 1.0;
  return c;
}

/// a per-joint-rmp actor with no hidden layer: every head output is 0 but the target-stiffness mean
std::string LinearPolicy(const rl::TaskConfig& task, float a, float b) {
  const auto context = rl::MakeTaskContext(task);
  const int D = context->spec().local_obs_dim;
  rl::PolicyWeights w;
  w.obs_dim = D;
  w.num_options = rl::kNumRmpOptions;
  w.num_continuous = rl::RmpActionLayout::kNumContinuous;
  w.has_termination = true;
  w.head.weight = Eigen::MatrixXf::Zero(w.head_size(), D);
  w.head.bias = Eigen::VectorXf::Zero(w.head_size());
  const int row = w.num_options + (rl::RmpActionLayout::kTargetAccelScale - 1);
  w.head.weight(row, rl::LookaheadOffset(rl::InterfaceMode::kPerJointRmp) + rl::LocalObs::kLookaheadClearance) = a;
  w.head.bias(row) = b;
  w.obs_mean = Eigen::VectorXf::Zero(D);
  w.obs_inv_std = Eigen::VectorXf::Ones(D);
  w.log_std = Eigen::VectorXf::Constant(w.num_continuous, -1.5f);
  w.low = Eigen::VectorXf::Constant(w.num_continuous, -1.0f);
  w.high = Eigen::VectorXf::Constant(w.num_continuous, 1.0f);
  const fs::path path = fs::temp_directory_path() / "rmpmarl_probe_test_linear.rmpp";
  rl::SavePolicyFile(w, path.string());
  return path.string();
}

TEST(ProbeLookaheadTest, RecoversAHandMadeResponseToTheBlock) {
  const rl::TaskConfig task = LookaheadTask();
  const float a = 0.4f, b = -0.1f;
  const ProbeOptions options{.episodes = 3, .eval_seed = 5, .threat_clearance = 0.05, .threat_time = 0.3,
                             .threat_speed = 1.8, .threat_threshold = 0.15};
  const LookaheadProbe p = ProbeLookahead(LinearPolicy(task, a, b), task, options);
  ASSERT_EQ(p.u_none.size(), 7u);  // the Panda's joints
  const float ell = static_cast<float>(task.observation.length_scale);
  for (size_t j = 0; j < p.u_none.size(); ++j) {
    EXPECT_NEAR(p.u_none[j], a * 2.0f + b, 1e-6);               // "none": clearance feature 2
    EXPECT_NEAR(p.u_threat[j], a * (0.05f / ell) + b, 1e-6);   // the substituted pass
  }
  EXPECT_EQ(p.episodes, 3);
  EXPECT_EQ(p.threatened_steps + p.clear_steps, 3L * 120 * 7);  // every agent-step is one or the other
  // the line at 1.8 m/s passes the arm: some steps are threatened, some not, and u splits at the threshold
  ASSERT_GT(p.threatened_steps, 0);
  ASSERT_GT(p.clear_steps, 0);
  const double u_at_threshold = a * (0.15 / ell) + b;
  EXPECT_LT(p.u_observed_threatened, u_at_threshold);
  EXPECT_GE(p.u_observed_clear, u_at_threshold);
}

TEST(ProbeLookaheadTest, RefusesATaskWithoutTheBlockAndAMisfitPolicy) {
  rl::TaskConfig task = LookaheadTask();
  const std::string policy = LinearPolicy(task, 1.0f, 0.0f);
  rl::TaskConfig no_block = task;
  no_block.observation.lookahead = 0.0;
  EXPECT_THROW(ProbeLookahead(policy, no_block, {}), InputError);
  rl::TaskConfig other_robot = task;
  other_robot.robot = "ur5e";  // 6 joints, the same local observation: fits; a 2-link arm's does too
  EXPECT_NO_THROW(ProbeLookahead(policy, other_robot, {.episodes = 1}));
  EXPECT_THROW(ProbeLookahead(policy, task, {.episodes = 1, .threat_time = 2.0}), InputError);  // > lookahead
  EXPECT_THROW(ProbeLookahead(policy, task, {.episodes = 1, .parameter = 0}), InputError);  // the option index
}

}  // namespace
}  // namespace rmpmarl::experiments
