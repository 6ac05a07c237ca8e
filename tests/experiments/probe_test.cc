// experiments::ProbeLookahead against policies whose response to the look-ahead block is known by hand: linear actors
// whose target-stiffness mean is u = w · (look-ahead block) + b and which ignore every other feature.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/probe.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/control/policy_runtime.h"

namespace rmpmarl::experiments {
namespace {
namespace fs = std::filesystem;

tasks::TaskConfig LookaheadTask() {
  tasks::TaskConfig c = tasks::DefaultTaskConfig(tasks::TaskKind::kLineCrossing);
  c.randomization.variants = 2;
  c.episode.max_steps = 120;
  c.scenario.line_speeds = {1.8};
  c.observation.lookahead = 1.0;
  return c;
}

/// the look-ahead block's three weights in the linear actor below
struct BlockWeights {
  float clearance = 0.0f, time = 0.0f, speed = 0.0f;
};

/// a per-joint-rmp actor with no hidden layer: every head output is 0 but the target-stiffness mean, which is
/// u = w · (look-ahead block) + b. `extra_obs` > 0 makes it expect a longer observation than the task's.
std::string LinearPolicy(const tasks::TaskConfig& task, BlockWeights w_block, float b, const std::string& name,
                         int extra_obs = 0) {
  const auto context = tasks::MakeTaskContext(task);
  const int D = context->spec().local_obs_dim + extra_obs;
  control::PolicyWeights w;
  w.obs_dim = D;
  w.num_options = control::kNumRmpOptions;
  w.num_continuous = control::RmpActionLayout::kNumContinuous;
  w.has_termination = true;
  w.head.weight = Eigen::MatrixXf::Zero(w.head_size(), D);
  w.head.bias = Eigen::VectorXf::Zero(w.head_size());
  const int row = w.num_options + (control::RmpActionLayout::kTargetAccelScale - 1);
  const int c = control::LookaheadOffset(tasks::InterfaceMode::kPerJointRmp);
  w.head.weight(row, c + control::LocalObs::kLookaheadClearance) = w_block.clearance;
  w.head.weight(row, c + control::LocalObs::kLookaheadTime) = w_block.time;
  w.head.weight(row, c + control::LocalObs::kLookaheadSpeed) = w_block.speed;
  w.head.bias(row) = b;
  w.obs_mean = Eigen::VectorXf::Zero(D);
  w.obs_inv_std = Eigen::VectorXf::Ones(D);
  w.log_std = Eigen::VectorXf::Constant(w.num_continuous, -1.5f);
  w.low = Eigen::VectorXf::Constant(w.num_continuous, -1.0f);
  w.high = Eigen::VectorXf::Constant(w.num_continuous, 1.0f);
  // one file per process and test (ctest runs the tests of this file as separate processes, possibly at once)
  const fs::path path =
      fs::temp_directory_path() / ("rmpmarl_probe_test_" + name + "_" + std::to_string(::getpid()) + ".rmpp");
  control::SavePolicyFile({.weights = w}, path.string());
  return path.string();
}

TEST(ProbeLookaheadTest, RecoversAHandMadeResponseToTheBlock) {
  const tasks::TaskConfig task = LookaheadTask();
  const ProbeOptions options{.episodes = 3, .eval_seed = 5, .threat_clearance = 0.05, .threat_time = 0.3,
                             .threat_speed = 1.8, .threat_threshold = 0.15};
  const float ell = static_cast<float>(task.observation.length_scale);
  // every block feature weighted differently: the substituted values of all three (encoding in docs/environments.md:
  // clearance / ℓ, time / T, speed / v_s; "none" = 2, 1, 0)
  const BlockWeights all{0.4f, -0.3f, 0.05f};
  const std::string full = LinearPolicy(task, all, -0.1f, "full");
  const LookaheadProbe p = ProbeLookahead(full, task, options);
  ASSERT_EQ(p.u_none.size(), 7u);  // the Panda's joints
  for (size_t j = 0; j < p.u_none.size(); ++j) {
    EXPECT_NEAR(p.u_none[j], 0.4 * 2.0 - 0.3 * 1.0 + 0.05 * 0.0 - 0.1, 1e-6);
    EXPECT_NEAR(p.u_threat[j], 0.4 * (0.05 / ell) - 0.3 * (0.3 / 1.0) + 0.05 * (1.8 / 1.0) - 0.1, 1e-6);
  }
  EXPECT_EQ(p.episodes, 3);
  EXPECT_EQ(p.threatened_steps + p.clear_steps, 3L * 120 * 7);  // every agent-step is one or the other
  // on the clearance alone, u splits at the threshold: the line at 1.8 m/s passes the arm, so both kinds occur
  const float a = 0.4f, b = -0.1f;
  const std::string clearance_only = LinearPolicy(task, {a, 0.0f, 0.0f}, b, "clearance");
  const LookaheadProbe q = ProbeLookahead(clearance_only, task, options);
  ASSERT_GT(q.threatened_steps, 0);
  ASSERT_GT(q.clear_steps, 0);
  const double u_at_threshold = a * (0.15 / ell) + b;
  EXPECT_LT(q.u_observed_threatened, u_at_threshold);
  EXPECT_GE(q.u_observed_clear, u_at_threshold);
  fs::remove(full);
  fs::remove(clearance_only);
}

TEST(ProbeLookaheadTest, RefusesWhatItCannotProbe) {
  tasks::TaskConfig task = LookaheadTask();
  const std::string policy = LinearPolicy(task, {1.0f, 0.0f, 0.0f}, 0.0f, "refuse");
  tasks::TaskConfig no_block = task;
  no_block.observation.lookahead = 0.0;
  EXPECT_THROW(ProbeLookahead(policy, no_block, {}), InputError);  // no block to substitute
  tasks::TaskConfig direct = task;
  direct.interface = tasks::InterfaceMode::kPerJointDirect;
  EXPECT_THROW(ProbeLookahead(policy, direct, {.episodes = 1}), InputError);  // no RMP parameters
  const std::string longer = LinearPolicy(task, {1.0f, 0.0f, 0.0f}, 0.0f, "longer", 1);
  EXPECT_THROW(ProbeLookahead(longer, task, {.episodes = 1}), InputError);  // expects another observation size
  tasks::TaskConfig other_robot = task;
  other_robot.robot = "ur5e";  // 6 joints, the same local observation: fits
  EXPECT_NO_THROW(ProbeLookahead(policy, other_robot, {.episodes = 1}));
  EXPECT_THROW(ProbeLookahead(policy, task, {.episodes = 1, .threat_time = 2.0}), InputError);  // > lookahead
  EXPECT_THROW(ProbeLookahead(policy, task, {.episodes = 1, .parameter = 0}), InputError);  // the option index
  EXPECT_THROW(ProbeLookahead(policy, task, {.episodes = 1, .parameter = 5}), InputError);  // the termination flag
  EXPECT_THROW(ProbeLookahead(policy, task, {.episodes = 1, .threat_clearance = std::nan("")}), InputError);
  EXPECT_THROW(ProbeLookahead(policy, task, {.episodes = 1, .threat_speed = -1.0}), InputError);
  fs::remove(policy);
  fs::remove(longer);
}

}  // namespace
}  // namespace rmpmarl::experiments
