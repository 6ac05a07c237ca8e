#include "rmpmarl/experiments/methods.h"

#include <fmt/core.h>
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <set>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

YAML::Node LoadYaml(const fs::path& path, const char* what) {
  try {
    return YAML::LoadFile(path.string());
  } catch (const YAML::BadFile&) {
    throw InputError(fmt::format("{}: cannot open {} (missing or unreadable)", path.string(), what));
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", path.string(), e.mark.line + 1, e.msg));
  }
}

[[noreturn]] void Fail(const fs::path& file, const std::string& key, const std::string& what) {
  throw InputError(fmt::format("{}: key '{}': {}", file.string(), key, what));
}

void CheckKeys(const YAML::Node& node, const fs::path& file, const std::string& where,
               const std::set<std::string>& allowed) {
  if (!node.IsMap()) Fail(file, where.empty() ? "(top level)" : where, "expected a mapping");
  for (const auto& kv : node) {
    const std::string k = kv.first.as<std::string>();
    if (!allowed.count(k)) {
      Fail(file, where.empty() ? k : where + "." + k,
           fmt::format("unknown key (expected one of: {})", fmt::join(allowed, ", ")));
    }
  }
}

std::string String(const YAML::Node& node, const fs::path& file, const std::string& key) {
  if (!node.IsScalar() || node.Scalar().empty()) Fail(file, key, "expected a non-empty string");
  return node.Scalar();
}

double Number(const YAML::Node& node, const fs::path& file, const std::string& key) {
  try {
    if (node.IsScalar()) return node.as<double>();
  } catch (const YAML::Exception&) {
  }
  Fail(file, key, fmt::format("expected a number, got '{}'", node.IsScalar() ? node.Scalar() : YAML::Dump(node)));
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
std::string FlowMap(const YAML::Node& node, const fs::path& file, const std::string& key) {
  if (!node || node.IsNull()) return "";
  if (!node.IsMap()) Fail(file, key, "expected a mapping of config keys");
  const YAML::Node copy = YAML::Clone(node);
  SetFlowStyle(copy);
  YAML::Emitter out;
  out << YAML::Flow << copy;
  return out.c_str();
}

/// the four continuous parameters u by name (tasks::RmpActionLayout order), each in [−1, 1]
std::array<float, tasks::RmpActionLayout::kNumContinuous> Parameters(const YAML::Node& node, const fs::path& file,
                                                                   const std::string& key) {
  static const std::vector<std::string> names = {"target_accel", "target_metric", "collision_accel",
                                                 "collision_metric"};
  std::array<float, tasks::RmpActionLayout::kNumContinuous> u{};
  if (!node) return u;
  CheckKeys(node, file, key, {names.begin(), names.end()});
  for (size_t i = 0; i < names.size(); ++i) {
    if (const YAML::Node v = node[names[i]]) {
      const double x = Number(v, file, key + "." + names[i]);
      if (!(x >= -1.0 && x <= 1.0)) Fail(file, key + "." + names[i], fmt::format("expected u in [-1, 1], got {}", x));
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
  const YAML::Node root = LoadYaml(file, "method file");
  CheckKeys(root, file, "",
            {"label", "kind", "train", "shipped", "layer", "option", "parameters", "gate", "evaluate", "rmpflow"});
  MethodSpec m;
  m.key = key;
  m.file = file;
  if (!root["label"]) Fail(file, "label", "missing (the method's row and legend label)");
  m.label = String(root["label"], file, "label");
  if (!root["kind"]) Fail(file, "kind", "missing (expected learned, basic-layer, rmpflow or rrt)");
  const std::string kind = String(root["kind"], file, "kind");
  const std::map<std::string, MethodSpec::Kind> kinds = {{"learned", MethodSpec::Kind::kLearned},
                                                         {"basic-layer", MethodSpec::Kind::kBasicLayer},
                                                         {"rmpflow", MethodSpec::Kind::kRmpflow},
                                                         {"rrt", MethodSpec::Kind::kRrt}};
  if (!kinds.count(kind)) Fail(file, "kind", fmt::format("expected learned, basic-layer, rmpflow or rrt, got '{}'", kind));
  m.kind = kinds.at(kind);
  auto only_for = [&](const char* k, MethodSpec::Kind allowed, const char* kind_name) {
    if (root[k] && m.kind != allowed) Fail(file, k, fmt::format("only a {} method has it", kind_name));
  };
  only_for("train", MethodSpec::Kind::kLearned, "learned");
  only_for("shipped", MethodSpec::Kind::kLearned, "learned");
  only_for("option", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("parameters", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("gate", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("evaluate", MethodSpec::Kind::kBasicLayer, "basic-layer");
  only_for("rmpflow", MethodSpec::Kind::kRmpflow, "rmpflow");
  if (root["layer"] && m.kind != MethodSpec::Kind::kLearned && m.kind != MethodSpec::Kind::kBasicLayer) {
    Fail(file, "layer", "only a learned or basic-layer method runs on a basic layer");
  }
  if (const YAML::Node n = root["layer"]) {
    m.layer = String(n, file, "layer");
    try {
      m.layer_yaml = LayerOverrides(m.layer);
    } catch (const InputError& e) {
      Fail(file, "layer", e.what());
    }
    tasks::TaskConfig check = tasks::LoadShippedTaskConfig("reach-avoid");  // a bad layer key is refused now
    tasks::ApplyTaskOverrides(check, m.layer_yaml, fmt::format("{}: layer {}", file.string(), m.layer));
  }
  if (m.kind == MethodSpec::Kind::kLearned) {
    const YAML::Node t = root["train"];
    if (!t) Fail(file, "train", "missing (a learned method states how it is trained)");
    CheckKeys(t, file, "train", {"config", "init", "updates", "overrides", "reward", "mix", "seconds_per_update"});
    TrainingRecipe r;
    if (!t["config"]) Fail(file, "train.config", "missing (a training config in configs/train/)");
    r.config = String(t["config"], file, "train.config");
    const fs::path train_file = ConfigsDirectory() / "train" / (r.config + ".yaml");
    if (!fs::exists(train_file)) {
      Fail(file, "train.config", fmt::format("no training config {}", train_file.string()));
    }
    const YAML::Node train = LoadYaml(train_file, "training config");
    const YAML::Node task = train["task"];
    if (!task || !task.IsMap() || !task["name"] || !task["interface"]) {
      throw InputError(fmt::format("{}: expected task.name and task.interface", train_file.string()));
    }
    r.two_link = task["name"].as<std::string>() == "pretrain-2link";
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
    if (const YAML::Node n = t["init"]) r.init = String(n, file, "train.init");
    if (const YAML::Node n = t["updates"]) {
      const double u = Number(n, file, "train.updates");
      if (!(u >= 1 && u == static_cast<int>(u))) Fail(file, "train.updates", fmt::format("expected an integer >= 1, got {}", u));
      r.updates = static_cast<int>(u);
    }
    if (const YAML::Node n = t["seconds_per_update"]) {
      r.seconds_per_update = Number(n, file, "train.seconds_per_update");
      if (!(r.seconds_per_update > 0.0)) {
        Fail(file, "train.seconds_per_update", fmt::format("expected > 0, got {}", r.seconds_per_update));
      }
    }
    r.overrides = FlowMap(t["overrides"], file, "train.overrides");
    if (const YAML::Node n = t["reward"]) {
      if (!n.IsMap()) Fail(file, "train.reward", "expected a mapping of reward keys");
      YAML::Node wrapped(YAML::NodeType::Map);
      wrapped["reward"] = n;
      r.reward = FlowMap(wrapped, file, "train.reward");
    }
    if (const YAML::Node n = t["mix"]) {
      CheckKeys(n, file, "train.mix", {"task", "overrides"});
      if (!n["task"]) Fail(file, "train.mix.task", "missing (the second training task)");
      r.mix_task = String(n["task"], file, "train.mix.task");
      tasks::ParseTaskKind(r.mix_task);
      r.mix_overrides = FlowMap(n["overrides"], file, "train.mix.overrides");
    }
    m.training = r;
    if (const YAML::Node n = root["shipped"]) m.shipped = String(n, file, "shipped");
  }
  if (m.kind == MethodSpec::Kind::kBasicLayer) {
    if (const YAML::Node n = root["option"]) {
      const std::string o = String(n, file, "option");
      const std::vector<std::string> options = {"target", "collision", "target-then-collision"};
      const auto it = std::find(options.begin(), options.end(), o);
      if (it == options.end()) Fail(file, "option", fmt::format("expected target, collision or target-then-collision, got '{}'", o));
      m.option = static_cast<int>(it - options.begin());
    } else {
      Fail(file, "option", "missing (target, collision or target-then-collision at every joint)");
    }
    m.parameters = Parameters(root["parameters"], file, "parameters");
    if (const YAML::Node g = root["gate"]) {
      CheckKeys(g, file, "gate", {"clearance", "parameters"});
      if (!g["clearance"]) Fail(file, "gate.clearance", "missing (predicted pass clearance [m] that fires the rule)");
      Method::ThreatGate gate;
      gate.clearance = Number(g["clearance"], file, "gate.clearance");
      if (!(gate.clearance >= 0.0)) Fail(file, "gate.clearance", fmt::format("expected >= 0, got {}", gate.clearance));
      gate.parameters = Parameters(g["parameters"], file, "gate.parameters");
      m.gate = gate;
    }
    m.evaluate = FlowMap(root["evaluate"], file, "evaluate");
  }
  if (m.kind == MethodSpec::Kind::kRmpflow) {
    m.rmpflow = FlowMap(root["rmpflow"], file, "rmpflow");
    rmp::RmpflowOptions check;
    rmp::ApplyRmpflowOverrides(check, m.rmpflow, file.string() + ": rmpflow");  // refused now, not mid-experiment
  }
  return m;
}

fs::path ConfigsDirectory() { return tasks::TaskConfigDirectory().parent_path(); }

std::string LayerOverrides(const std::string& layer) {
  const fs::path file = ConfigsDirectory() / "layers" / (layer + ".yaml");
  if (!fs::exists(file)) {
    std::vector<std::string> known = KeysIn("layers");
    throw InputError(fmt::format("layer '{}': no {} (known: {})", layer, file.string(), fmt::join(known, ", ")));
  }
  const YAML::Node root = LoadYaml(file, "layer file");
  if (root.IsNull()) return "";
  return FlowMap(root, file, "(top level)");
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
  const YAML::Node root = LoadYaml(file, "experiment file");
  CheckKeys(root, file, "", {"methods"});
  const YAML::Node list = root["methods"];
  if (!list || !list.IsSequence() || list.size() == 0) Fail(file, "methods", "expected a non-empty list of method keys");
  std::vector<std::string> keys;
  for (size_t i = 0; i < list.size(); ++i) keys.push_back(String(list[i], file, fmt::format("methods[{}]", i)));
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
