// The training config: YAML ⇄ TrainConfig with one table of keys (torch-free translation unit).
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::rl {

std::string ToString(Activation activation) { return activation == Activation::kTanh ? "tanh" : "relu"; }
std::string ToString(LrSchedule schedule) { return schedule == LrSchedule::kLinear ? "linear" : "constant"; }

Activation ParseActivation(const std::string& name) {
  if (name == "relu") return Activation::kRelu;
  if (name == "tanh") return Activation::kTanh;
  throw InputError(fmt::format("activation: expected \"relu\" or \"tanh\", got \"{}\"", name));
}

LrSchedule ParseLrSchedule(const std::string& name) {
  if (name == "constant") return LrSchedule::kConstant;
  if (name == "linear") return LrSchedule::kLinear;
  throw InputError(fmt::format("lr_schedule: expected \"constant\" or \"linear\", got \"{}\"", name));
}

namespace {

// one config key: how to read it from YAML and how to print it.
struct Key {
  std::string name;
  std::function<void(TrainConfig&, const YAML::Node&)> read;
  std::function<std::string(const TrainConfig&)> write;
};

std::string Quote(const std::string& s) {
  YAML::Emitter e;
  e << YAML::DoubleQuoted << s;
  return e.c_str();
}

std::string Real(double v) { return fmt::format("{}", v); }

std::string IntList(const std::vector<int>& v) {
  std::string s = "[";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + std::to_string(v[i]);
  return s + "]";
}

// option accessors: Ptr gives the fluent options' getter/setter pair as a key.
template <typename Options, typename T>
Key OptionKey(const std::string& name, Options TrainConfig::*group, const T& (Options::*get)() const,
              Options& (Options::*set)(const T&), std::function<std::string(const T&)> print) {
  return Key{name,
             [=](TrainConfig& c, const YAML::Node& n) { ((c.*group).*set)(n.as<T>()); },
             [=](const TrainConfig& c) { return print(((c.*group).*get)()); }};
}

template <typename T>
Key FieldKey(const std::string& name, T TrainConfig::*field, std::function<std::string(const T&)> print) {
  return Key{name, [=](TrainConfig& c, const YAML::Node& n) { c.*field = n.as<T>(); },
             [=](const TrainConfig& c) { return print(c.*field); }};
}

// a task-overrides key: a YAML map kept as one flow-style string ("" for none or an empty map).
Key OverridesKey(const std::string& name, std::string TaskSelection::*field) {
  return Key{name,
             [field](TrainConfig& c, const YAML::Node& n) {
               if (n.IsNull()) {
                 (c.task.*field).clear();
                 return;
               }
               if (!n.IsMap()) throw YAML::Exception(YAML::Mark(), "expected a map");
               YAML::Emitter e;
               e << YAML::Flow << n;
               c.task.*field = n.size() == 0 ? "" : e.c_str();
             },
             [field](const TrainConfig& c) { return (c.task.*field).empty() ? std::string("{}") : c.task.*field; }};
}

const std::vector<Key>& Keys() {
  static const std::vector<Key> keys = [] {
    const std::function<std::string(const std::string&)> str = Quote;
    const std::function<std::string(const int&)> integer = [](const int& v) { return std::to_string(v); };
    const std::function<std::string(const double&)> real = [](const double& v) { return Real(v); };
    const std::function<std::string(const bool&)> boolean = [](const bool& v) { return v ? "true" : "false"; };
    const std::function<std::string(const std::uint64_t&)> u64 = [](const std::uint64_t& v) {
      return std::to_string(v);
    };
    const std::function<std::string(const std::vector<int>&)> ints = IntList;
    using N = NetworkOptions;
    using P = PpoOptions;
    std::vector<Key> k;
    k.push_back(FieldKey("name", &TrainConfig::name, str));
    k.push_back(Key{"task.name", [](TrainConfig& c, const YAML::Node& n) { c.task.name = n.as<std::string>(); },
                    [](const TrainConfig& c) { return Quote(c.task.name); }});
    k.push_back(Key{"task.config", [](TrainConfig& c, const YAML::Node& n) { c.task.config = n.as<std::string>(); },
                    [](const TrainConfig& c) { return Quote(c.task.config); }});
    k.push_back(Key{"task.interface",
                    [](TrainConfig& c, const YAML::Node& n) { c.task.interface = n.as<std::string>(); },
                    [](const TrainConfig& c) { return Quote(c.task.interface); }});
    k.push_back(OverridesKey("task.overrides", &TaskSelection::overrides_yaml));
    k.push_back(Key{"task.mix.name", [](TrainConfig& c, const YAML::Node& n) { c.task.mix_name = n.as<std::string>(); },
                    [](const TrainConfig& c) { return Quote(c.task.mix_name); }});
    k.push_back(OverridesKey("task.mix.overrides", &TaskSelection::mix_overrides_yaml));
    k.push_back(Key{"task.mix.fraction",
                    [](TrainConfig& c, const YAML::Node& n) { c.task.mix_fraction = n.as<double>(); },
                    [](const TrainConfig& c) { return Real(c.task.mix_fraction); }});
    k.push_back(FieldKey("algorithm", &TrainConfig::algorithm, str));
    k.push_back(FieldKey("seed", &TrainConfig::seed, u64));
    k.push_back(FieldKey("num_envs", &TrainConfig::num_envs, integer));
    k.push_back(FieldKey("env_threads", &TrainConfig::env_threads, integer));
    k.push_back(FieldKey("torch_threads", &TrainConfig::torch_threads, integer));
    k.push_back(FieldKey("total_updates", &TrainConfig::total_updates, integer));
    k.push_back(FieldKey("checkpoint_every", &TrainConfig::checkpoint_every, integer));
    k.push_back(FieldKey("output_dir", &TrainConfig::output_dir, str));
    k.push_back(FieldKey("init_actor_from", &TrainConfig::init_actor_from, str));
    k.push_back(FieldKey("snapshot_updates", &TrainConfig::snapshot_updates, ints));
    k.push_back(FieldKey("logging.csv", &TrainConfig::write_csv, boolean));
    k.push_back(FieldKey("logging.tensorboard", &TrainConfig::write_tensorboard, boolean));
    k.push_back(FieldKey("logging.progress", &TrainConfig::progress, boolean));
    k.push_back(FieldKey("logging.window", &TrainConfig::stats_window, integer));
    k.push_back(OptionKey<N, std::vector<int>>("network.actor_hidden", &TrainConfig::network, &N::actor_hidden,
                                               &N::actor_hidden, ints));
    k.push_back(OptionKey<N, std::vector<int>>("network.critic_hidden", &TrainConfig::network, &N::critic_hidden,
                                               &N::critic_hidden, ints));
    k.push_back(Key{"network.activation",
                    [](TrainConfig& c, const YAML::Node& n) { c.network.activation(ParseActivation(n.as<std::string>())); },
                    [](const TrainConfig& c) { return ToString(c.network.activation()); }});
    k.push_back(OptionKey<N, double>("network.init_log_std", &TrainConfig::network, &N::init_log_std,
                                     &N::init_log_std, real));
    k.push_back(OptionKey<N, double>("network.actor_output_gain", &TrainConfig::network, &N::actor_output_gain,
                                     &N::actor_output_gain, real));
    auto pi = [&](const char* name, const int& (P::*get)() const, P& (P::*set)(const int&)) {
      k.push_back(OptionKey<P, int>(std::string("ppo.") + name, &TrainConfig::ppo, get, set, integer));
    };
    auto pd = [&](const char* name, const double& (P::*get)() const, P& (P::*set)(const double&)) {
      k.push_back(OptionKey<P, double>(std::string("ppo.") + name, &TrainConfig::ppo, get, set, real));
    };
    auto pb = [&](const char* name, const bool& (P::*get)() const, P& (P::*set)(const bool&)) {
      k.push_back(OptionKey<P, bool>(std::string("ppo.") + name, &TrainConfig::ppo, get, set, boolean));
    };
    pi("rollout_steps", &P::rollout_steps, &P::rollout_steps);
    pd("gamma", &P::gamma, &P::gamma);
    pd("gae_lambda", &P::gae_lambda, &P::gae_lambda);
    pi("epochs", &P::epochs, &P::epochs);
    pi("minibatches", &P::minibatches, &P::minibatches);
    pd("clip", &P::clip, &P::clip);
    pd("value_clip", &P::value_clip, &P::value_clip);
    pd("value_coef", &P::value_coef, &P::value_coef);
    pd("entropy_option", &P::entropy_option, &P::entropy_option);
    pd("entropy_continuous", &P::entropy_continuous, &P::entropy_continuous);
    pd("entropy_termination", &P::entropy_termination, &P::entropy_termination);
    pd("max_grad_norm", &P::max_grad_norm, &P::max_grad_norm);
    pd("target_kl", &P::target_kl, &P::target_kl);
    pd("lr", &P::lr, &P::lr);
    pd("critic_lr", &P::critic_lr, &P::critic_lr);
    k.push_back(Key{"ppo.lr_schedule",
                    [](TrainConfig& c, const YAML::Node& n) { c.ppo.lr_schedule(ParseLrSchedule(n.as<std::string>())); },
                    [](const TrainConfig& c) { return ToString(c.ppo.lr_schedule()); }});
    pd("lr_final_fraction", &P::lr_final_fraction, &P::lr_final_fraction);
    pd("adam_eps", &P::adam_eps, &P::adam_eps);
    pb("normalize_advantage", &P::normalize_advantage, &P::normalize_advantage);
    pd("advantage_eps", &P::advantage_eps, &P::advantage_eps);
    pb("normalize_observations", &P::normalize_observations, &P::normalize_observations);
    pd("obs_clip", &P::obs_clip, &P::obs_clip);
    pb("normalize_value", &P::normalize_value, &P::normalize_value);
    pb("bf16_autocast", &P::bf16_autocast, &P::bf16_autocast);
    return k;
  }();
  return keys;
}

// flattens nested maps into dotted keys (task.overrides stays one node).
void Flatten(const YAML::Node& node, const std::string& prefix, std::map<std::string, YAML::Node>* out,
             std::vector<std::string>* order, const std::string& where) {
  for (const auto& kv : node) {
    if (!kv.first.IsScalar()) {  // e.g. {[a]: 1} (found by fuzzing)
      throw InputError(fmt::format("{}: under '{}': expected a plain key name, got a sequence or mapping as a key",
                                   where, prefix.empty() ? std::string("(top level)") : prefix));
    }
    const std::string key = prefix + kv.first.Scalar();
    if (kv.second.IsMap() && key != "task.overrides" && key != "task.mix.overrides") {
      Flatten(kv.second, key + ".", out, order, where);
    } else {
      (*out)[key] = kv.second;
      order->push_back(key);
    }
  }
}

void Validate(const TrainConfig& c, const std::string& where) {
  auto fail = [&](const std::string& key, const std::string& message) {
    throw InputError(fmt::format("{}: {}: {}", where, key, message));
  };
  if (c.task.name.empty()) fail("task.name", "expected a task name, got none");
  if (c.algorithm != "mappo" && c.algorithm != "ppo") {
    fail("algorithm", fmt::format("expected \"mappo\" or \"ppo\", got \"{}\"", c.algorithm));
  }
  if (c.num_envs < 1) fail("num_envs", fmt::format("expected >= 1, got {}", c.num_envs));
  if (!c.task.mix_name.empty() && !(c.task.mix_fraction > 0.0 && c.task.mix_fraction < 1.0)) {
    fail("task.mix.fraction", fmt::format("expected a share of the envs in (0, 1), got {}", c.task.mix_fraction));
  }
  if (c.task.mix_name.empty() && !c.task.mix_overrides_yaml.empty()) {
    fail("task.mix.overrides", "given without task.mix.name");
  }
  if (c.env_threads < 1) fail("env_threads", fmt::format("expected >= 1, got {}", c.env_threads));
  if (c.torch_threads < 1) fail("torch_threads", fmt::format("expected >= 1, got {}", c.torch_threads));
  if (c.total_updates < 1) fail("total_updates", fmt::format("expected >= 1, got {}", c.total_updates));
  if (c.stats_window < 1) fail("logging.window", fmt::format("expected >= 1, got {}", c.stats_window));
  if (c.checkpoint_every < 1) fail("checkpoint_every", fmt::format("expected >= 1, got {}", c.checkpoint_every));
  for (int u : c.snapshot_updates) {
    if (u < 1 || u > c.total_updates) {
      fail("snapshot_updates", fmt::format("expected updates in 1..{} (total_updates), got {}", c.total_updates, u));
    }
  }
  const PpoOptions& p = c.ppo;
  if (p.rollout_steps() < 1) fail("ppo.rollout_steps", fmt::format("expected >= 1, got {}", p.rollout_steps()));
  if (p.epochs() < 1) fail("ppo.epochs", fmt::format("expected >= 1, got {}", p.epochs()));
  if (p.minibatches() < 1 || p.minibatches() > p.rollout_steps() * c.num_envs) {
    fail("ppo.minibatches", fmt::format("expected 1..{} (rollout_steps × num_envs), got {}",
                                        p.rollout_steps() * c.num_envs, p.minibatches()));
  }
  if (!(p.gamma() > 0.0 && p.gamma() <= 1.0)) fail("ppo.gamma", fmt::format("expected in (0, 1], got {}", p.gamma()));
  if (!(p.gae_lambda() >= 0.0 && p.gae_lambda() <= 1.0)) {
    fail("ppo.gae_lambda", fmt::format("expected in [0, 1], got {}", p.gae_lambda()));
  }
  if (!(p.clip() > 0.0)) fail("ppo.clip", fmt::format("expected > 0, got {}", p.clip()));
  if (!(p.lr() > 0.0)) fail("ppo.lr", fmt::format("expected > 0, got {}", p.lr()));
  for (const auto& [key, hidden] : {std::pair{"network.actor_hidden", c.network.actor_hidden()},
                                    std::pair{"network.critic_hidden", c.network.critic_hidden()}}) {
    for (int h : hidden) {
      if (h < 1) fail(key, fmt::format("expected positive layer sizes, got {}", h));
    }
  }
}

}  // namespace

TrainConfig ParseTrainConfig(const std::string& yaml_text, const std::string& where) {
  YAML::Node root;
  try {
    root = YAML::Load(yaml_text);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}: not valid YAML: {}", where, e.what()));
  }
  if (!root.IsMap()) throw InputError(fmt::format("{}: expected a YAML map of training settings", where));
  std::map<std::string, YAML::Node> flat;
  std::vector<std::string> order;
  Flatten(root, "", &flat, &order, where);
  TrainConfig config;
  std::map<std::string, const Key*> by_name;
  for (const Key& key : Keys()) by_name[key.name] = &key;
  for (const std::string& name : order) {
    auto it = by_name.find(name);
    if (it == by_name.end()) {
      std::string known;
      for (const Key& key : Keys()) known += (known.empty() ? "" : ", ") + key.name;
      throw InputError(fmt::format("{}: unknown key \"{}\" (known keys: {})", where, name, known));
    }
    try {
      it->second->read(config, flat[name]);
    } catch (const YAML::Exception&) {
      throw InputError(fmt::format("{}: {}: cannot read the value \"{}\" (expected the type of the default: {})",
                                   where, name, YAML::Dump(flat[name]), it->second->write(TrainConfig{})));
    } catch (const InputError& e) {
      throw InputError(fmt::format("{}: {}: {}", where, name, e.what()));
    }
  }
  Validate(config, where);
  return config;
}

TrainConfig LoadTrainConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(fmt::format("training config {}: cannot open it", path));
  std::stringstream text;
  text << in.rdbuf();
  return ParseTrainConfig(text.str(), path);
}

std::vector<std::pair<std::string, std::string>> FlattenTrainConfig(const TrainConfig& config) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const Key& key : Keys()) {
    // the mixture keys only when a mix task is set: configs without one print (and compare) as before they existed
    if (config.task.mix_name.empty() && key.name.rfind("task.mix.", 0) == 0) continue;
    out.emplace_back(key.name, key.write(config));
  }
  return out;
}

std::string ToYaml(const TrainConfig& config) {
  // nested output from the dotted keys (keys of a group are contiguous in the table).
  std::string out, group;
  for (const auto& [name, value] : FlattenTrainConfig(config)) {
    const auto dot = name.find('.');
    const std::string g = dot == std::string::npos ? "" : name.substr(0, dot);
    const std::string leaf = dot == std::string::npos ? name : name.substr(dot + 1);
    if (g != group && !g.empty()) out += g + ":\n";
    group = g;
    out += (g.empty() ? "" : "  ") + leaf + ": " + value + "\n";
  }
  return out;
}

}  // namespace rmpmarl::rl
