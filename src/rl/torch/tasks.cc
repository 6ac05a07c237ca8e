// Task registry for training and evaluation, and the built-in toy-reach task (torch-free translation unit).
#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/tasks/task_config.h"
#include "rmpmarl/rl/torch/toy_reach.h"
#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::rl {

ToyReachEnv::ToyReachEnv(const ToyReachOptions& options) : options_(options) {
  if (options.agents < 1) throw InputError(fmt::format("toy-reach: agents: expected >= 1, got {}", options.agents));
  if (options.horizon < 1) throw InputError(fmt::format("toy-reach: horizon: expected >= 1, got {}", options.horizon));
  const int A = options.agents;
  spec_.task = "toy-reach";
  spec_.num_agents = A;
  spec_.local_obs_names = {"x", "target_minus_x"};
  if (options.options) {
    spec_.action.num_options = 3;
    spec_.action.option_names = {"toward", "hold", "away"};
    spec_.action.num_continuous = 1;
    spec_.action.continuous_names = {"speed"};
    spec_.action.low = {0.0f};
    spec_.action.high = {1.0f};
    spec_.action.has_termination = true;
    for (const char* name : {"running_toward", "running_hold", "running_away"}) spec_.local_obs_names.push_back(name);
  } else {
    spec_.action.num_continuous = 1;
    spec_.action.continuous_names = {"velocity"};
    spec_.action.low = {-1.0f};
    spec_.action.high = {1.0f};
  }
  spec_.local_obs_dim = static_cast<int>(spec_.local_obs_names.size());
  for (int a = 0; a < A; ++a) spec_.global_state_names.push_back(fmt::format("x{}", a));
  for (int a = 0; a < A; ++a) spec_.global_state_names.push_back(fmt::format("target{}", a));
  spec_.global_state_dim = 2 * A;
  spec_.reward_terms = {"distance", "out_of_bounds"};
  spec_.discount = 0.99;
  spec_.max_episode_steps = options.horizon;
  spec_.control_dt = 0.1;
  x_.assign(A, 0.0);
  g_.assign(A, 0.0);
  option_.assign(A, -1);
}

void ToyReachEnv::Write(const tasks::StepOutput& out) const {
  const int A = options_.agents, d = spec_.local_obs_dim;
  for (int a = 0; a < A; ++a) {
    float* o = out.local_obs + a * d;
    o[0] = static_cast<float>(x_[a]);
    o[1] = static_cast<float>(g_[a] - x_[a]);
    if (options_.options) {
      for (int k = 0; k < 3; ++k) o[2 + k] = option_[a] == k ? 1.0f : 0.0f;
    }
    out.global_state[a] = static_cast<float>(x_[a]);
    out.global_state[A + a] = static_cast<float>(g_[a]);
  }
}

void ToyReachEnv::Reset(std::mt19937_64& rng, const tasks::StepOutput& out) {
  std::uniform_real_distribution<double> start(-1.0, 1.0), target(-0.8, 0.8);
  for (int a = 0; a < options_.agents; ++a) {
    x_[a] = start(rng);
    g_[a] = target(rng);
    option_[a] = -1;
    out.option_started[a] = 0.0f;
  }
  steps_ = 0;
  error_sum_ = return_ = 0.0;
  Write(out);
  out.reward[0] = out.reward_terms[0] = out.reward_terms[1] = 0.0f;
  out.terminated[0] = out.truncated[0] = 0;
}

void ToyReachEnv::Step(const float* actions, std::mt19937_64& /*rng*/, const tasks::StepOutput& out) {
  const int A = options_.agents, as = spec_.action.size();
  bool invalid = false;
  for (int i = 0; i < A * as; ++i) invalid |= !std::isfinite(actions[i]);
  double distance = 0.0;
  bool out_of_bounds = false;
  for (int a = 0; a < A && !invalid; ++a) {
    const float* act = actions + a * as;
    out.option_started[a] = 0.0f;
    double dx;
    if (options_.options) {
      const int chosen = static_cast<int>(act[0]);
      if (chosen < 0 || chosen > 2 || act[0] != static_cast<float>(chosen)) {
        invalid = true;
        break;
      }
      if (option_[a] < 0) {  // idle: the action's option starts
        option_[a] = chosen;
        out.option_started[a] = 1.0f;
      }
      const double speed = options_.step * std::clamp<double>(act[1], 0.0, 1.0);
      const double to_goal = g_[a] - x_[a];
      const double dir = to_goal >= 0.0 ? 1.0 : -1.0;
      dx = option_[a] == 0 ? std::clamp(to_goal, -speed, speed) : option_[a] == 1 ? 0.0 : -dir * speed;
      if (act[2] >= 0.5f) option_[a] = -1;  // the flag ends the option after this step
    } else {
      dx = options_.step * std::clamp<double>(act[0], -1.0, 1.0);
    }
    x_[a] += dx;
    distance += std::abs(g_[a] - x_[a]);
    out_of_bounds |= std::abs(x_[a]) > 1.5;
  }
  ++steps_;
  Write(out);
  if (invalid) {
    out.reward[0] = out.reward_terms[0] = out.reward_terms[1] = 0.0f;
    out.terminated[0] = 1;
    out.truncated[0] = 0;
    *out.metrics = tasks::EpisodeMetrics{};
    out.metrics->invalid = true;
    out.metrics->length = steps_;
    return;
  }
  out.reward_terms[0] = static_cast<float>(-distance / A);
  out.reward_terms[1] = out_of_bounds ? -1.0f : 0.0f;
  out.reward[0] = out.reward_terms[0] + out.reward_terms[1];
  error_sum_ += distance / A;
  return_ += out.reward[0];
  out.terminated[0] = out_of_bounds;
  out.truncated[0] = !out_of_bounds && steps_ >= options_.horizon;
  if (out.terminated[0] || out.truncated[0]) {
    bool success = !out_of_bounds;
    for (int a = 0; a < A; ++a) success &= std::abs(g_[a] - x_[a]) < options_.tolerance;
    tasks::EpisodeMetrics& m = *out.metrics;
    m = tasks::EpisodeMetrics{};
    m.success = success;
    m.length = steps_;
    m.mean_tracking_error = error_sum_ / steps_;
    m.final_tracking_error = distance / A;
    m.min_clearance = std::numeric_limits<double>::infinity();
    m.episode_return = return_;
  }
}

namespace {

ToyReachOptions ToyOptions(const TaskSelection& task) {
  ToyReachOptions o;
  if (!task.interface.empty() && task.interface != "options" && task.interface != "direct") {
    throw InputError(fmt::format("task toy-reach: interface: expected \"options\" or \"direct\", got \"{}\"",
                                 task.interface));
  }
  o.options = task.interface != "direct";
  if (task.overrides_yaml.empty()) return o;
  const YAML::Node node = YAML::Load(task.overrides_yaml);
  if (!node.IsMap() && !node.IsNull()) throw InputError("task toy-reach: overrides: expected a map");
  for (const auto& kv : node) {
    const std::string key = kv.first.as<std::string>();
    try {
      if (key == "agents") {
        o.agents = kv.second.as<int>();
      } else if (key == "horizon") {
        o.horizon = kv.second.as<int>();
      } else if (key == "step") {
        o.step = kv.second.as<double>();
      } else if (key == "tolerance") {
        o.tolerance = kv.second.as<double>();
      } else {
        throw InputError(fmt::format("task toy-reach: unknown override \"{}\" (known: agents, horizon, step, "
                                     "tolerance)", key));
      }
    } catch (const YAML::Exception&) {
      throw InputError(fmt::format("task toy-reach: override {}: expected a number", key));
    }
  }
  return o;
}

// the manipulator task config: the task file (shipped or task.config), the overrides merged in, the interface.
tasks::TaskConfig ManipulatorTaskConfig(const TaskSelection& task) {
  const std::filesystem::path path = task.config.empty() ? tasks::TaskConfigPath(task.name) : std::filesystem::path(task.config);
  tasks::TaskConfig config;
  if (task.overrides_yaml.empty()) {
    config = tasks::LoadTaskConfig(path);
  } else {
    // the task loader merges the overrides itself (mappings key by key, non-scalar keys refused)
    try {
      config = tasks::LoadTaskConfig(path, task.overrides_yaml);
    } catch (const InputError& e) {
      throw InputError(fmt::format("task {} ({} with the training config's task.overrides): {}", task.name,
                                   path.string(), e.what()));
    }
  }
  if (tasks::TaskKindName(config.task) != task.name) {
    throw InputError(fmt::format("task config {} is for task {}, not {}", path.string(), tasks::TaskKindName(config.task),
                                 task.name));
  }
  if (!task.interface.empty()) {
    try {
      config.interface = tasks::ParseInterfaceMode(task.interface);
    } catch (const InputError& e) {
      throw InputError(fmt::format("task {}: {}", task.name, e.what()));
    }
  }
  return config;
}

}  // namespace

std::vector<std::string> KnownTasks() {
  std::vector<std::string> names = tasks::TaskNames();
  names.push_back("toy-reach");
  return names;
}

tasks::EnvFactory MakeTaskFactory(const TaskSelection& task) {
  const std::vector<std::string> manipulator = tasks::TaskNames();
  auto is_manipulator = [&](const std::string& name) {
    return std::find(manipulator.begin(), manipulator.end(), name) != manipulator.end();
  };
  if (!task.mix_name.empty()) {
    if (!is_manipulator(task.name) || !is_manipulator(task.mix_name)) {
      throw InputError(fmt::format("task.mix: a mixture needs two manipulator tasks, got {} and {}", task.name,
                                   task.mix_name));
    }
    if (!(task.mix_fraction > 0.0 && task.mix_fraction < 1.0)) {
      throw InputError(fmt::format("task.mix.fraction: expected a share in (0, 1), got {}", task.mix_fraction));
    }
    TaskSelection mix;
    mix.name = task.mix_name;
    mix.interface = task.interface;
    mix.overrides_yaml = task.mix_overrides_yaml;
    const tasks::EnvFactory first = tasks::MakeManipulatorEnvFactory(tasks::MakeTaskContext(ManipulatorTaskConfig(task)));
    const tasks::EnvFactory second = tasks::MakeManipulatorEnvFactory(tasks::MakeTaskContext(ManipulatorTaskConfig(mix)));
    const double f = task.mix_fraction;
    // env k runs the mix task when the running share floor(k f) steps up at k: spread evenly over the envs
    return [first, second, f](int k) {
      return std::floor((k + 1) * f) > std::floor(k * f) ? second(k) : first(k);
    };
  }
  if (task.name == "toy-reach") {
    const ToyReachOptions options = ToyOptions(task);
    ToyReachEnv probe(options);  // validates the options now, not in a worker thread
    return [options](int) { return std::make_unique<ToyReachEnv>(options); };
  }
  if (is_manipulator(task.name)) {
    // the context (robot variants, one WorldModel each) is built once and shared by every env of every segment
    return tasks::MakeManipulatorEnvFactory(tasks::MakeTaskContext(ManipulatorTaskConfig(task)));
  }
  std::string known;
  for (const std::string& name : KnownTasks()) known += (known.empty() ? "" : ", ") + name;
  throw InputError(fmt::format("unknown task \"{}\" (known: {})", task.name, known));
}

}  // namespace rmpmarl::rl
