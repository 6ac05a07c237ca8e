// The policies shipped in models/policies/ load in the torch-free runtime and act sensibly on held-out episodes of
// the task they were trained for (the YAML beside each holds the full evaluation).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/evaluation.h"
#include "rmpmarl/experiments/experiments.h"
#include "rmpmarl/rl/agent_interface.h"
#include "rmpmarl/rl/policy_runtime.h"

namespace rmpmarl::experiments {
namespace {
namespace fs = std::filesystem;

fs::path Shipped(const std::string& name) {
  return rl::TaskConfigDirectory().parent_path().parent_path() / "models" / "policies" / name;
}

TEST(ShippedPoliciesTest, EachLoadsAndRunsItsTask) {
  struct Case {
    const char* file;
    const char* task;
  };
  for (const Case& c : {Case{"hrl-rmp-2link.rmpp", "pretrain-2link"}, Case{"marl-rmp.rmpp", "reach-avoid"},
                        Case{"marl-rmp-v2.rmpp", "reach-avoid"}, Case{"marl-rmp-v2-params-hold.rmpp", "reach-avoid"},
                        Case{"marl-rmp-v2c.rmpp", "reach-avoid"}, Case{"marl-rmp-v2c-gate.rmpp", "reach-avoid"}}) {
    SCOPED_TRACE(c.file);
    const fs::path path = Shipped(c.file);
    ASSERT_TRUE(fs::exists(path)) << path << " (scripts/ship-policies writes it)";
    EXPECT_TRUE(fs::exists(fs::path(path).replace_extension(".yaml")));
    const rl::PolicyWeights weights = rl::LoadPolicyFile(path.string());
    EXPECT_EQ(weights.num_options, rl::kNumRmpOptions);
    // a policy trained on a basic-layer variant runs on it: the overrides beside it are the recipe's
    const std::string layer = rl::LoadPolicyTaskOverrides(path.string());
    if (std::string(c.file) == "marl-rmp-v2.rmpp") {
      EXPECT_EQ(layer, RecipeLayerOverrides("marl-rmp-v2"));
    } else if (std::string(c.file) == "marl-rmp-v2-params-hold.rmpp") {
      EXPECT_EQ(layer, RecipeLayerOverrides("marl-rmp-v2-params-hold"));
    } else if (std::string(c.file) == "marl-rmp-v2c.rmpp") {
      EXPECT_EQ(layer, RecipeLayerOverrides("marl-rmp-v2c-params-hold-phi20k"));
    } else if (std::string(c.file) == "marl-rmp-v2c-gate.rmpp") {
      EXPECT_EQ(layer, RecipeLayerOverrides("marl-rmp-v2c-gate-residual-kernel-gated"));
    } else {
      EXPECT_EQ(layer, "");
    }
    rl::TaskConfig task = rl::LoadTaskConfig(rl::TaskConfigPath(c.task), layer);
    task.randomization.variants = 2;
    task.episode.max_steps = 200;
    if (task.task != rl::TaskKind::kPretrain2Link) task.observation.max_obstacles = 6;
    const auto records = EvaluateMethod(Method::Policy("shipped", path.string(), rl::InterfaceMode::kPerJointRmp),
                                        task, {.episodes = 6, .eval_seed = 5, .jobs = 2});
    int successes = 0;
    for (const EpisodeRecord& r : records) {
      EXPECT_FALSE(r.metrics.invalid);
      EXPECT_TRUE(std::isfinite(r.metrics.settled_tracking_error_mm));
      successes += r.metrics.success ? 1 : 0;
    }
    // measured (results/, training seed 1): 99 % on pretrain-2link (session 9's scene), 90 % on reach-avoid; 6 short
    // episodes here
    EXPECT_GE(successes, 4);
  }
}

TEST(ShippedPoliciesTest, TaskOverridesBesideAPolicyAreReadOrRejectedWithTheFile) {
  const fs::path dir = fs::temp_directory_path() / "rmpmarl_policy_overrides_test";
  fs::create_directories(dir);
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / fs::path(name).replace_extension(".rmpp")).string();
  };
  EXPECT_EQ(rl::LoadPolicyTaskOverrides((dir / "none.rmpp").string()), "");  // no YAML beside it
  EXPECT_EQ(rl::LoadPolicyTaskOverrides(write("plain.yaml", "seed: 1\n")), "");
  EXPECT_EQ(rl::LoadPolicyTaskOverrides(write("layer.yaml", "task_overrides: \"{options: {fixed_option: 2}}\"\n")),
            "{options: {fixed_option: 2}}");
  for (const char* bad : {"task_overrides: [1, 2]\n", "- a list\n", "task_overrides: {a: [\n"}) {
    SCOPED_TRACE(bad);
    try {
      rl::LoadPolicyTaskOverrides(write("bad.yaml", bad));
      ADD_FAILURE() << "expected an InputError";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
    }
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rmpmarl::experiments
