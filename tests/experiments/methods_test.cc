// The methods as data (configs/methods, configs/ablations, configs/layers, configs/experiments): every file loads,
// the lists name existing methods, layers apply onto a task as the task loader merges them, bad files are refused.
#include "rmpmarl/experiments/methods.h"

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/experiments.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::experiments {
namespace {
namespace fs = std::filesystem;

TEST(MethodsTest, EveryMethodFileLoadsAndEveryLayerIsUsed) {
  std::set<std::string> layers_used;
  const std::vector<std::string> keys = MethodKeys();
  ASSERT_GE(keys.size(), 10u);
  for (const std::string& key : keys) {
    SCOPED_TRACE(key);
    const MethodSpec& m = FindMethod(key);
    EXPECT_EQ(m.key, key);
    EXPECT_FALSE(m.label.empty());
    if (!m.layer.empty()) layers_used.insert(m.layer);
    // the overrides are single-line flow mappings, whatever style their files use (they are merged as text)
    EXPECT_EQ(m.layer_yaml.find('\n'), std::string::npos) << m.layer_yaml;
    if (m.training) {
      for (const std::string& o : {m.training->overrides, m.training->reward, m.training->mix_overrides}) {
        EXPECT_EQ(o.find('\n'), std::string::npos) << o;
      }
    }
    if (m.kind == MethodSpec::Kind::kLearned) {
      ASSERT_TRUE(m.training.has_value());
      EXPECT_TRUE(fs::exists(ConfigsDirectory() / "train" / (m.training->config + ".yaml")));
      if (!m.training->init.empty()) EXPECT_EQ(FindMethod(m.training->init).kind, MethodSpec::Kind::kLearned);
    } else {
      EXPECT_FALSE(m.training.has_value());
    }
  }
  for (const auto& e : fs::directory_iterator(ConfigsDirectory() / "layers")) {
    EXPECT_TRUE(layers_used.count(e.path().stem().string())) << e.path() << " is used by no method";
  }
  // the methods a user sees are a short list (the paper's, the baselines, the hand gate and two shipped controllers)
  EXPECT_LE(ProductMethodKeys().size(), 13u);
}

TEST(MethodsTest, EachExperimentListsExistingMethodsThePaperSevenInTable4) {
  for (const std::string& name : ExperimentNames()) {
    SCOPED_TRACE(name);
    const std::vector<std::string> keys = ExperimentMethods(name);
    EXPECT_FALSE(keys.empty());
    for (const std::string& k : keys) EXPECT_NO_THROW(FindMethod(k)) << k;
  }
  const std::vector<std::string> table4 = ExperimentMethods("table4");
  for (const char* paper : {"hrl-rmp", "marl-rmp", "ppo", "mappo", "marl-ppo", "rmpflow", "rrt"}) {
    EXPECT_NE(std::find(table4.begin(), table4.end(), paper), table4.end()) << paper;
  }
  EXPECT_THROW(ExperimentMethods("table9"), InputError);
}

// what a task's fields look like after a layer (the fields the layers set, and a few they leave)
std::string Fields(const tasks::TaskConfig& c) {
  const rmp::TargetRmpParams& t = c.basic_layer.params.target;
  const rmp::CollisionRmpParams& k = c.basic_layer.params.collision;
  return fmt::format(
      "{} {} {} {} | {} {} {} {} {} {} {} {} {} {} {} {} {} | {} {} {} {} | {} {} {} {} {} {} {} {} | {} {}",
      c.controller.max_substep, c.observation.warning_distance, c.observation.lookahead, c.observation.max_obstacles,
      static_cast<int>(c.options.termination), c.options.horizon, c.options.gain_range, c.options.target_gain_range,
      c.options.collision_target_weight, c.options.collision_length_exponent, c.options.fixed_option,
      c.options.parameter_period, c.options.target_gate_clearance, c.options.target_gate_clear,
      c.options.target_gate_threat, static_cast<int>(c.options.warnings), c.episode.max_steps,
      static_cast<int>(c.basic_layer.resolve), static_cast<int>(c.basic_layer.params.target_scale),
      static_cast<int>(t.damping), t.accel_p_gain, t.accel_d_gain, k.metric_modulation_radius, k.metric_scalar,
      k.repulsion_gain, k.damping_gain, k.repulsion_std_dev, k.damping_std_dev, c.reward.collision_penalty,
      c.scenario.crossing.num_obstacles, c.robot);
}

// a layer read onto a built task (the experiments' evaluation) equals the same layer merged by the task loader
// (training: the run's task overrides)
TEST(MethodsTest, LayersApplyOntoATaskAsTheLoaderMergesThem) {
  for (const auto& e : fs::directory_iterator(ConfigsDirectory() / "layers")) {
    const std::string layer = e.path().stem().string();
    const std::string yaml = LayerOverrides(layer);
    ASSERT_FALSE(yaml.empty()) << layer;
    for (const char* task : {"reach-avoid", "line-crossing", "pretrain-2link"}) {
      SCOPED_TRACE(fmt::format("{} on {}", layer, task));
      tasks::TaskConfig applied = tasks::LoadShippedTaskConfig(task);
      tasks::ApplyTaskOverrides(applied, yaml, "test");
      const tasks::TaskConfig merged = tasks::LoadTaskConfig(tasks::TaskConfigPath(task), yaml);
      EXPECT_EQ(Fields(applied), Fields(merged));
      EXPECT_NE(Fields(applied), Fields(tasks::LoadShippedTaskConfig(task)));  // the layer changes something
    }
  }
}

TEST(MethodsTest, ApplyTaskOverridesRefusesBadKeysAndKeepsTheConfig) {
  tasks::TaskConfig c = tasks::LoadShippedTaskConfig("reach-avoid");
  const std::string before = Fields(c);
  EXPECT_THROW(tasks::ApplyTaskOverrides(c, "{options: {horizon: -3}}", "test"), InputError);
  EXPECT_THROW(tasks::ApplyTaskOverrides(c, "{optionz: {horizon: 3}}", "test"), InputError);
  EXPECT_THROW(tasks::ApplyTaskOverrides(c, "{task: cluttered}", "test"), InputError);
  EXPECT_THROW(tasks::ApplyTaskOverrides(c, "[1, 2]", "test"), InputError);
  EXPECT_EQ(Fields(c), before);
  tasks::ApplyTaskOverrides(c, "{task: reach-avoid, options: {horizon: 7}}", "test");
  EXPECT_EQ(c.options.horizon, 7);
}

TEST(MethodsTest, RmpflowTunedChangesTheFourCollisionGainsOnly) {
  const MethodSpec& m = FindMethod("rmpflow-tuned");
  rmp::RmpflowOptions base = rmp::LoadRmpflowOptions(rmp::RmpflowConfigPath("panda"));
  rmp::RmpflowOptions tuned = base;
  rmp::ApplyRmpflowOverrides(tuned, m.rmpflow, "test");
  EXPECT_EQ(tuned.collision.repulsion_gain, 3200.0);
  EXPECT_EQ(tuned.collision.damping_gain, 200.0);
  EXPECT_EQ(tuned.collision.repulsion_std_dev, 0.0283);
  EXPECT_EQ(tuned.collision.damping_std_dev, 0.1131);
  EXPECT_EQ(tuned.collision.metric_scalar, base.collision.metric_scalar);
  EXPECT_EQ(tuned.target.accel_p_gain, base.target.accel_p_gain);
  EXPECT_EQ(tuned.self_collision.repulsion_gain, base.self_collision.repulsion_gain);
  EXPECT_THROW(rmp::ApplyRmpflowOverrides(tuned, "{rmp_params: {collision_rmp: {repulsion_gian: 1}}}", "t"),
               InputError);
}

// a user's method file with a mistake is refused naming the file and the key
TEST(MethodsTest, MalformedMethodFilesAreRefusedNamingTheKey) {
  const fs::path dir = fs::temp_directory_path() / ("rmpmarl_methods_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto refused = [&](const std::string& text, const std::string& expected) {
    const fs::path f = dir / "m.yaml";
    std::ofstream(f) << text;
    try {
      LoadMethodFile("m", f);
      ADD_FAILURE() << "accepted:\n" << text;
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find(f.string()), std::string::npos) << what;
      EXPECT_NE(what.find(expected), std::string::npos) << "expected '" << expected << "' in: " << what;
    }
  };
  refused("kind: rmpflow\n", "'label'");
  refused("label: x\nkind: magic\n", "'kind'");
  refused("label: x\nkind: rmpflow\noption: target\n", "'option'");
  refused("label: x\nkind: basic-layer\n", "'option'");
  refused("label: x\nkind: basic-layer\noption: sideways\n", "'option'");
  refused("label: x\nkind: basic-layer\noption: target\nparameters: {target_accel: 2}\n", "parameters.target_accel");
  refused("label: x\nkind: basic-layer\noption: target\ngate: {clearance: -1}\n", "gate.clearance");
  refused("label: x\nkind: basic-layer\noption: target\nlayer: no-such-layer\n", "no-such-layer");
  refused("label: x\nkind: learned\n", "'train'");
  refused("label: x\nkind: learned\ntrain: {config: no-such-config}\n", "no-such-config");
  refused("label: x\nkind: learned\ntrain: {config: ppo-reach-avoid, updates: 0}\n", "train.updates");
  refused("label: x\nkind: learned\ntrain: {config: ppo-reach-avoid, mix: {overrides: {}}}\n", "train.mix.task");
  refused("label: x\nkind: rmpflow\nrmpflow: {rmp_params: {collision_rmp: {repulsion_gain: -5}}}\n", "repulsion_gain");
  refused("label: x\nkind: rrt\nsurprise: 1\n", "'surprise'");
  // a good one
  std::ofstream(dir / "ok.yaml") << "label: mine\nkind: basic-layer\noption: target-then-collision\n"
                                    "parameters: {target_accel: 0.5}\nlayer: v2c\n";
  const MethodSpec ok = LoadMethodFile("ok", dir / "ok.yaml");
  EXPECT_EQ(ok.option, 2);
  EXPECT_FLOAT_EQ(ok.parameters[0], 0.5f);
  EXPECT_EQ(ok.layer, "v2c");
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rmpmarl::experiments
