#include "rmpmarl/experiments/methods.h"

#include <fmt/core.h>
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <set>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

/// a non-empty string
std::string String(const internal::YamlReader& r, const YAML::Node& node, const std::string& key) {
  const std::string v = r.String(node, key);
  if (v.empty()) r.Fail(node, key, "expected a non-empty string");
  return v;
}

void SetFlowStyle(YAML::Node node) {
  node.SetStyle(YAML::EmitterStyle::Flow);
  if (node.IsMap()) {
    for (auto kv : node) SetFlowStyle(kv.second);
  } else if (node.IsSequence()) {
    for (auto v : node) SetFlowStyle(v);
  }
}

/// a mapping of overrides as one single-line YAML flow mapping ("" for none), whatever style the file wrote it in
std::string FlowMap(const internal::YamlReader& r, const YAML::Node& node, const std::string& key) {
  if (!node || node.IsNull()) return "";
  if (!node.IsMap()) r.Fail(node, key, "expected a mapping of config keys");
  const YAML::Node copy = YAML::Clone(node);
  SetFlowStyle(copy);
  YAML::Emitter out;
  out << YAML::Flow << copy;
  return out.c_str();
}

/// the four continuous parameters u by name (control::RmpActionLayout order), each in [−1, 1]
std::array<float, control::RmpActionLayout::kNumContinuous> Parameters(const internal::YamlReader& r,
                                                                   const YAML::Node& node, const std::string& key) {
  static const std::vector<std::string> names = {"target_accel", "target_metric", "collision_accel",
                                                 "collision_metric"};
  std::array<float, control::RmpActionLayout::kNumContinuous> u{};
  if (!node) return u;
  r.CheckKeys(node, key, {names.begin(), names.end()});
  for (size_t i = 0; i < names.size(); ++i) {
    if (const YAML::Node v = node[names[i]]) {
      const double x = r.Number(v, key + "." + names[i]);
      if (!(x >= -1.0 && x <= 1.0)) r.Fail(v, key + "." + names[i], fmt::format("expected u in [-1, 1], got {}", x));
      u[i] = static_cast<float>(x);
    }
  }
  return u;
}

fs::path MethodFile(const std::string& key) {
  for (const char* dir : {"methods", "ablations"}) {
    const fs::path f = ConfigsDirectory() / dir / (key + ".yaml");
    if (fs::exists(f)) return f;
  }
  return {};
}

std::vector<std::string> KeysIn(const char* dir) {
  std::vector<std::string> keys;
  const fs::path d = ConfigsDirectory() / dir;
  if (!fs::is_directory(d)) return keys;
  for (const auto& e : fs::directory_iterator(d)) {
    if (e.path().extension() == ".yaml") keys.push_back(e.path().stem().string());
  }
  std::sort(keys.begin(), keys.end());
  return keys;
}

}  // namespace

MethodSpec LoadMethodFile(const std::string& key, const fs::path& file) {
  const YAML::Node root = internal::LoadYamlFile(file.string(), "method file");
  const internal::YamlReader r(file.string());
  r.CheckKeys(root, "",
            {"label", "kind", "train", "shipped", "layer", "option", "parameters", "gate", "evaluate", "rmpflow"});
  MethodSpec m;
  m.key = key;
  m.file = file;
  if (!root["label"]) r.Fail(root, "label", "missing (the method's row and legend label)");
  m.label = String(r, root["label"], "label");
  if (!root["kind"]) r.Fail(root, "kind", "missing (expected learned, basic-layer, rmpflow or rrt)");
  const std::string kind = String(r, root["kind"], "kind");
  const std::map<std::string, MethodSpec::Kind> kinds = {{"learned", MethodSpec::Kind::kLearned},
                                                         {"basic-layer", MethodSpec::Kind::kBasicLayer},
                                                         {"rmpflow", MethodSpec::Kind::kRmpflow},
                                                         {"rrt", MethodSpec::Kind::kRrt}};
  if (!kinds.count(kind)) r.Fail(root, "kind", fmt::format("expected learned, basic-layer, rmpflow or rrt, got '{}'", kind));
  m.kind = kinds.at(kind);
  auto only_for = [&](const char* k, MethodSpec::Kind allowed, const char* kind_name) {
    if (root[k] && m.kind != allowed) r.Fail(root, k, fmt::format("only a {} method has it", kind_name));
  };
  only_for("train", MethodSpec::Kind::kLearned, "learned");
  only_for("shipped", MethodSpec::Kind::kLearned, "learned");
  only_for("option", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("parameters", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("gate", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("evaluate", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("rmpflow", MethodSpec::Kind::kRmpflow, "rmpflow");
  if (root["layer"] && m.kind != MethodSpec::Kind::kLearned && m.kind != MethodSpec::Kind::kBasicLayer) {
    r.Fail(root, "layer", "only a learned or basic-layer method runs on a basic layer");
  }
  if (const YAML::Node n = root["layer"]) {
    m.layer = String(r, n, "layer");
    try {
      m.layer_yaml = LayerOverrides(m.layer);
    } catch (const InputError& e) {
      r.Fail(root, "layer", e.what());
    }
    // a bad layer key is refused now, not mid-experiment
    static const tasks::TaskConfig reach_avoid = tasks::LoadShippedTaskConfig("reach-avoid");
    tasks::TaskConfig check = reach_avoid;
    tasks::ApplyTaskOverrides(check, m.layer_yaml, fmt::format("{}: layer {}", file.string(), m.layer));
  }
  if (m.kind == MethodSpec::Kind::kLearned) {
    const YAML::Node t = root["train"];
    if (!t) r.Fail(root, "train", "missing (a learned method states how it is trained)");
    r.CheckKeys(t, "train", {"config", "init", "updates", "overrides", "reward", "mix", "seconds_per_update"});
    TrainingRecipe recipe;
    if (!t["config"]) r.Fail(root, "train.config", "missing (a training config in configs/train/)");
    recipe.config = String(r, t["config"], "train.config");
    const fs::path train_file = TrainConfigPath(recipe.config);
    if (!fs::exists(train_file)) {
      r.Fail(root, "train.config", fmt::format("no training config {}", train_file.string()));
    }
    const YAML::Node train = internal::LoadYamlFile(train_file.string(), "training config");
    const YAML::Node task = train["task"];
    if (!task || !task.IsMap() || !task["name"] || !task["interface"]) {
      throw InputError(fmt::format("{}: expected task.name and task.interface", train_file.string()));
    }
    recipe.two_link = task["name"].as<std::string>() == "pretrain-2link";
    const std::string interface = task["interface"].as<std::string>();
    if (interface == "per-joint-rmp") {
      m.interface = tasks::InterfaceMode::kPerJointRmp;
    } else if (interface == "direct") {
      m.interface = tasks::InterfaceMode::kDirect;
    } else if (interface == "per-joint-direct") {
      m.interface = tasks::InterfaceMode::kPerJointDirect;
    } else {
      throw InputError(fmt::format("{}: task.interface: unknown '{}'", train_file.string(), interface));
    }
    if (const YAML::Node n = t["init"]) recipe.init = String(r, n, "train.init");
    if (const YAML::Node n = t["updates"]) {
      const double u = r.Number(n, "train.updates");
      if (!(u >= 1 && u == static_cast<int>(u))) r.Fail(root, "train.updates", fmt::format("expected an integer >= 1, got {}", u));
      recipe.updates = static_cast<int>(u);
    }
    if (const YAML::Node n = t["seconds_per_update"]) {
      recipe.seconds_per_update = r.Number(n, "train.seconds_per_update");
      if (!(recipe.seconds_per_update > 0.0)) {
        r.Fail(root, "train.seconds_per_update", fmt::format("expected > 0, got {}", recipe.seconds_per_update));
      }
    }
    recipe.overrides = FlowMap(r, t["overrides"], "train.overrides");
    if (const YAML::Node n = t["reward"]) {
      if (!n.IsMap()) r.Fail(root, "train.reward", "expected a mapping of reward keys");
      YAML::Node wrapped(YAML::NodeType::Map);
      wrapped["reward"] = n;
      recipe.reward = FlowMap(r, wrapped, "train.reward");
    }
    if (const YAML::Node n = t["mix"]) {
      r.CheckKeys(n, "train.mix", {"task", "overrides"});
      if (!n["task"]) r.Fail(root, "train.mix.task", "missing (the second training task)");
      recipe.mix_task = String(r, n["task"], "train.mix.task");
      tasks::ParseTaskKind(recipe.mix_task);
      recipe.mix_overrides = FlowMap(r, n["overrides"], "train.mix.overrides");
    }
    m.training = recipe;
    if (const YAML::Node n = root["shipped"]) m.shipped = String(r, n, "shipped");
  }
  if (m.kind == MethodSpec::Kind::kBasicLayer) {
    if (const YAML::Node n = root["option"]) {
      const std::string o = String(r, n, "option");
      const std::vector<std::string> options = {"target", "collision", "target-then-collision"};
      const auto it = std::find(options.begin(), options.end(), o);
      if (it == options.end()) r.Fail(root, "option", fmt::format("expected target, collision or target-then-collision, got '{}'", o));
      m.option = static_cast<int>(it - options.begin());
    } else {
      r.Fail(root, "option", "missing (target, collision or target-then-collision at every joint)");
    }
    m.parameters = Parameters(r, root["parameters"], "parameters");
    if (const YAML::Node g = root["gate"]) {
      r.CheckKeys(g, "gate", {"clearance", "parameters"});
      if (!g["clearance"]) r.Fail(root, "gate.clearance", "missing (predicted pass clearance [m] that fires the rule)");
      Method::ThreatGate gate;
      gate.clearance = r.Number(g["clearance"], "gate.clearance");
      if (!(gate.clearance >= 0.0)) r.Fail(root, "gate.clearance", fmt::format("expected >= 0, got {}", gate.clearance));
      gate.parameters = Parameters(r, g["parameters"], "gate.parameters");
      m.gate = gate;
    }
    m.evaluate = FlowMap(r, root["evaluate"], "evaluate");
  }
  if (m.kind == MethodSpec::Kind::kRmpflow) {
    m.rmpflow = FlowMap(r, root["rmpflow"], "rmpflow");
    rmp::RmpflowOptions check;
    rmp::ApplyRmpflowOverrides(check, m.rmpflow, file.string() + ": rmpflow");  // refused now, not mid-experiment
  }
  return m;
}

fs::path ConfigsDirectory() { return tasks::TaskConfigDirectory().parent_path(); }

fs::path TrainConfigPath(const std::string& name) { return ConfigsDirectory() / "train" / (name + ".yaml"); }

std::string LayerOverrides(const std::string& layer) {
  const fs::path file = ConfigsDirectory() / "layers" / (layer + ".yaml");
  if (!fs::exists(file)) {
    std::vector<std::string> known = KeysIn("layers");
    throw InputError(fmt::format("layer '{}': no {} (known: {})", layer, file.string(), fmt::join(known, ", ")));
  }
  const YAML::Node root = internal::LoadYamlFile(file.string(), "layer file");
  if (root.IsNull()) return "";
  return FlowMap(internal::YamlReader(file.string()), root, "<root>");
}

const MethodSpec& FindMethod(const std::string& key) {
  static std::mutex mutex;
  static std::map<std::string, MethodSpec> cache;
  const std::lock_guard<std::mutex> lock(mutex);
  if (const auto it = cache.find(key); it != cache.end()) return it->second;
  const fs::path file = MethodFile(key);
  if (file.empty()) {
    throw InputError(fmt::format("no method '{}' in {}/methods or ablations (methods: {})", key,
                                 ConfigsDirectory().string(), fmt::join(ProductMethodKeys(), ", ")));
  }
  return cache.emplace(key, LoadMethodFile(key, file)).first->second;
}

std::vector<std::string> ProductMethodKeys() { return KeysIn("methods"); }

std::vector<std::string> MethodKeys() {
  std::vector<std::string> keys = KeysIn("methods");
  for (const std::string& k : KeysIn("ablations")) keys.push_back(k);
  return keys;
}

std::vector<std::string> DefaultMethods(const std::string& experiment) {
  const fs::path file = ConfigsDirectory() / "experiments" / (experiment + ".yaml");
  const YAML::Node root = internal::LoadYamlFile(file.string(), "experiment file");
  const internal::YamlReader r(file.string());
  r.CheckKeys(root, "", {"methods"});
  const YAML::Node list = root["methods"];
  if (!list || !list.IsSequence() || list.size() == 0) r.Fail(root, "methods", "expected a non-empty list of method keys");
  std::vector<std::string> keys;
  for (size_t i = 0; i < list.size(); ++i) keys.push_back(String(r, list[i], fmt::format("methods[{}]", i)));
  return keys;
}

Method MakeMethod(const MethodSpec& spec, const std::string& policy_path) {
  Method m;
  switch (spec.kind) {
    case MethodSpec::Kind::kLearned:
      m = Method::Policy(spec.label, policy_path, spec.interface);
      break;
    case MethodSpec::Kind::kBasicLayer:
      m = Method::FixedOption(spec.label, spec.option);
      m.fixed_parameters = spec.parameters;
      m.threat_gate = spec.gate;
      break;
    case MethodSpec::Kind::kRmpflow:
      m = Method::Rmpflow(spec.label);
      if (!spec.rmpflow.empty()) {
        m.adjust_rmpflow = [yaml = spec.rmpflow, source = spec.file.string() + ": rmpflow"](rmp::RmpflowOptions& o) {
          rmp::ApplyRmpflowOverrides(o, yaml, source);
        };
      }
      break;
    case MethodSpec::Kind::kRrt:
      m = Method::Rrt(spec.label);
      break;
  }
  if (!spec.layer_yaml.empty() || !spec.evaluate.empty()) {
    m.adjust_task = [layer = spec.layer_yaml, evaluate = spec.evaluate, file = spec.file.string(),
                     name = spec.layer](tasks::TaskConfig& task) {
      if (!layer.empty()) tasks::ApplyTaskOverrides(task, layer, fmt::format("{}: layer {}", file, name));
      if (!evaluate.empty()) tasks::ApplyTaskOverrides(task, evaluate, file + ": evaluate");
    };
  }
  return m;
}

}  // namespace rmpmarl::experiments
