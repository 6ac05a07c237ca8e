// One evaluation path for every method (docs/experiments.md): identical episodes by construction.
#include "rmpmarl/experiments/evaluation.h"

#include <fmt/format.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <exception>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <random>
#include <thread>

#include "rmpmarl/common/error.h"
#include "rmpmarl/common/random.h"
#include "rmpmarl/experiments/statistics.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/tasks/task_episode.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/control/controller.h"

namespace rmpmarl::experiments {
namespace {

/// the acting part of a method: fills the actions of one env step from its observations.
class Actor {
 public:
  virtual ~Actor() = default;
  virtual void Act(const tasks::StepBuffers& step, float* actions) = 0;
};

class PolicyActor final : public Actor {
 public:
  PolicyActor(const control::PolicyWeights& weights, int num_agents) : runtime_(weights, num_agents), agents_(num_agents) {}
  /// only the agents whose action the env will read (held parameters): the others keep their last, valid action
  void Act(const tasks::StepBuffers& step, float* actions) override {
    runtime_.ActWhere(step.local_obs.data(), agents_, step.next_action_read.data(), actions);
  }

 private:
  control::PolicyRuntime runtime_;
  int agents_;
};

/// a constant action: the fixed option, unit scales (u = 0 ↦ scale 1), never terminating.
class ConstantActor final : public Actor {
 public:
  explicit ConstantActor(std::vector<float> actions) : actions_(std::move(actions)) {}
  void Act(const tasks::StepBuffers& /*step*/, float* actions) override {
    std::copy(actions_.begin(), actions_.end(), actions);
  }

 private:
  std::vector<float> actions_;
};

/// the fixed option with Method::ThreatGate: per agent, the threat parameters while the look-ahead block predicts a
/// pass within the gate's clearance, the fixed ones otherwise.
class ThreatGateActor final : public Actor {
 public:
  ThreatGateActor(std::vector<float> clear, std::vector<float> threat, int obs_dim, int clearance_index,
                  float clearance_threshold)
      : clear_(std::move(clear)), threat_(std::move(threat)), obs_dim_(obs_dim), index_(clearance_index),
        threshold_(clearance_threshold) {}
  void Act(const tasks::StepBuffers& step, float* actions) override {
    const int agents = static_cast<int>(step.option_started.size());
    const size_t as = clear_.size() / static_cast<size_t>(agents);
    for (int a = 0; a < agents; ++a) {
      const bool threat = step.local_obs[static_cast<size_t>(a) * obs_dim_ + index_] < threshold_;
      const std::vector<float>& src = threat ? threat_ : clear_;
      std::copy_n(src.begin() + a * as, as, actions + a * as);
    }
  }

 private:
  std::vector<float> clear_, threat_;
  int obs_dim_, index_;
  float threshold_;
};

tasks::InterfaceMode EnvInterface(const Method& m) {
  return m.kind == MethodKind::kPolicy ? m.interface : tasks::InterfaceMode::kPerJointRmp;
}

}  // namespace

Method Method::Policy(std::string name, std::string path, tasks::InterfaceMode interface) {
  Method m;
  m.name = std::move(name);
  m.kind = MethodKind::kPolicy;
  m.policy_path = std::move(path);
  m.interface = interface;
  return m;
}

Method Method::FixedOption(std::string name, int option) {
  if (option < 0 || option >= control::kNumRmpOptions) {
    throw InputError(fmt::format("fixed option: expected 0..{}, got {}", control::kNumRmpOptions - 1, option));
  }
  Method m;
  m.name = std::move(name);
  m.kind = MethodKind::kFixedOption;
  m.fixed_option = option;
  return m;
}

Method Method::Rmpflow(std::string name) {
  Method m;
  m.name = std::move(name);
  m.kind = MethodKind::kRmpflow;
  return m;
}

Method Method::Rrt(std::string name, planning::RrtOptions options) {
  Method m;
  m.name = std::move(name);
  m.kind = MethodKind::kRrt;
  m.rrt = options;
  return m;
}

std::uint64_t EpisodeSeed(std::uint64_t eval_seed, int index) {
  std::uint64_t s = SplitMix64(SplitMix64(eval_seed) ^ static_cast<std::uint64_t>(index));
  while (s < (std::uint64_t{1} << 32)) s = SplitMix64(s);
  return s;
}

std::vector<EpisodeRecord> EvaluateMethod(const Method& method, const tasks::TaskConfig& task,
                                          const EvalProtocol& protocol) {
  if (protocol.episodes < 1) throw InputError(fmt::format("episodes: expected >= 1, got {}", protocol.episodes));
  if (protocol.jobs < 1) throw InputError(fmt::format("jobs: expected >= 1, got {}", protocol.jobs));
  tasks::TaskConfig config = task;
  if (method.adjust_task) method.adjust_task(config);
  config.interface = EnvInterface(method);
  const auto context = tasks::MakeTaskContext(config);
  const tasks::EnvSpec& spec = context->spec();
  const int A = spec.num_agents, as = spec.action.size();

  control::PolicyWeights weights;
  if (method.kind == MethodKind::kPolicy) {
    weights = control::LoadPolicyFile(method.policy_path).weights;
    if (weights.obs_dim != spec.local_obs_dim || weights.action_size() != as) {
      throw InputError(fmt::format("{}: policy {} does not fit task {} ({}): it takes obs {} and gives {} action "
                                   "floats, the env has obs {} and actions of {}", method.name, method.policy_path,
                                   spec.task, tasks::InterfaceModeName(config.interface), weights.obs_dim,
                                   weights.action_size(), spec.local_obs_dim, as));
    }
  }
  auto constant_actions = [&](const std::array<float, control::RmpActionLayout::kNumContinuous>& parameters) {
    std::vector<float> actions(static_cast<size_t>(A) * as, 0.0f);
    for (int a = 0; a < A; ++a) {
      float* u = actions.data() + static_cast<size_t>(a) * as;
      u[control::RmpActionLayout::kOption] = static_cast<float>(method.fixed_option);
      for (int k = 0; k < control::RmpActionLayout::kNumContinuous; ++k) {
        u[control::RmpActionLayout::kTargetAccelScale + k] = parameters[k];
      }
    }
    return actions;
  };
  std::vector<float> fixed, threat;
  if (method.threat_gate && method.kind != MethodKind::kFixedOption) {
    throw InputError(fmt::format("{}: a threat gate switches fixed-option parameters: expected a fixed-option method",
                                 method.name));
  }
  if (method.kind == MethodKind::kFixedOption) {
    fixed = constant_actions(method.fixed_parameters);
    if (method.threat_gate) {
      if (!(config.observation.lookahead > 0.0)) {
        throw InputError(fmt::format("{}: the threat gate reads the look-ahead block: expected observation.lookahead "
                                     "> 0 s, got {}", method.name, config.observation.lookahead));
      }
      threat = constant_actions(method.threat_gate->parameters);
    }
  }

  const bool sensed = static_cast<bool>(protocol.make_sensor);
  if (sensed && method.kind == MethodKind::kFixedOption) {
    throw InputError(fmt::format("{}: a fixed-option method reads MuJoCo's contacts, not a sensor: with a sensor "
                                 "(--perception depth) run RMPflow, RRT or learned methods", method.name));
  }
  // methods that are controllers run the task's episodes through tasks::ControllerEpisodes; the others act in the
  // env. Both draw every episode from the same rng, so every method sees identical episodes.
  const int sensor_slots =
      sensed ? std::max(context->num_obstacles(), protocol.sensor_obstacle_slots) : context->num_obstacles();
  std::optional<tasks::ControllerMaker> controller;
  if ((sensed || protocol.learned_as_controller) && method.kind == MethodKind::kPolicy) {
    // the agents as a user's loop runs them: control::LearnedController on what the sensor perceives
    controller = tasks::LearnedControllerMaker(config, weights, method.name, sensor_slots);
  } else if (method.kind == MethodKind::kRmpflow) {
    controller.emplace();
    controller->options = control::ControllerOptions{};  // the demo's: 2 ms substeps, commanded-state input
    controller->make_policy = [sensor_slots, adjust = method.adjust_rmpflow](const kinematics::Robot& robot) {
      rmp::RmpflowOptions options = rmp::LoadRmpflowOptions(rmp::RmpflowConfigPath(robot.name));
      if (adjust) {
        adjust(options);
        rmp::ValidateRmpflowOptions(options, "RMPflow options adjusted by the experiment");
      }
      return std::make_unique<control::RmpflowAccelerationPolicy>(robot, options, sensor_slots);
    };
  } else if (method.kind == MethodKind::kRrt) {
    controller.emplace();
    controller->options = control::ControllerOptions{};
    planning::RrtOptions rrt = method.rrt;
    const double period = spec.control_dt;
    rrt.evaluation_period = period / control::ControlSubsteps(period, controller->options);
    controller->make_policy = [rrt](const kinematics::Robot& robot) {
      return std::make_unique<planning::RrtPolicy>(robot, rrt);
    };
  }
  if (controller) controller->make_sensor = protocol.make_sensor;
  auto make_actor = [&]() -> std::unique_ptr<Actor> {
    if (method.kind == MethodKind::kPolicy) return std::make_unique<PolicyActor>(weights, A);
    if (method.threat_gate) {
      return std::make_unique<ThreatGateActor>(
          fixed, threat, spec.local_obs_dim, control::LookaheadOffset(config.interface) + control::LocalObs::kLookaheadClearance,
          static_cast<float>(method.threat_gate->clearance / config.observation.length_scale));
    }
    return std::make_unique<ConstantActor>(fixed);
  };

  std::vector<EpisodeRecord> records(protocol.episodes);
  std::atomic<int> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  // one episode of the method: its metrics, the time its actor took per step (0 for controllers) and the steps
  auto worker = [&] {
    try {
      std::unique_ptr<tasks::ManipulatorEnv> env;
      std::unique_ptr<Actor> actor;
      std::unique_ptr<tasks::ControllerEpisodes> runner;
      if (controller) {
        runner = std::make_unique<tasks::ControllerEpisodes>(context, *controller);
      } else {
        env = std::make_unique<tasks::ManipulatorEnv>(context);
        actor = make_actor();
      }
      tasks::StepBuffers step(spec);
      std::vector<float> actions(static_cast<size_t>(A) * as, 0.0f);
      for (int i = next.fetch_add(1); i < protocol.episodes; i = next.fetch_add(1)) {
        EpisodeRecord& r = records[i];
        r.index = i;
        r.episode_seed = EpisodeSeed(protocol.eval_seed, i);
        std::mt19937_64 rng(r.episode_seed);
        if (runner) {
          r.metrics = runner->Run(rng);
          r.variant = runner->episode().variant();
          r.setting = runner->episode().setting();
          r.control_step_us = r.metrics.mean_control_us;
          if (const auto* rrt = dynamic_cast<const planning::RrtPolicy*>(&runner->controller()->policy());
              rrt != nullptr) {
            const planning::RrtStats& st = rrt->stats();
            r.plans = st.plans_attempted;
            r.plans_succeeded = st.plans_succeeded;
            for (double t : st.planning_times_s) {
              r.planning_ms_mean += 1000.0 * t / st.planning_times_s.size();
              r.planning_ms_max = std::max(r.planning_ms_max, 1000.0 * t);
            }
          }
          if (const sim::ObstacleSensor* sensor = runner->sensor(); sensor != nullptr) r.sensor = sensor->Summary();
          continue;
        }
        env->Reset(rng, step.out());
        r.variant = env->variant();
        r.setting = env->scenario_setting();
        double act_us = 0.0;
        int steps = 0;
        while (true) {
          const auto t0 = std::chrono::steady_clock::now();
          actor->Act(step, actions.data());
          act_us += std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - t0).count();
          env->Step(actions.data(), rng, step.out());
          ++steps;
          if (step.terminated || step.truncated) break;
        }
        r.metrics = step.metrics;
        r.control_step_us = act_us / steps + step.metrics.mean_control_us;
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
      next.store(protocol.episodes);
    }
  };
  const int threads = std::min(protocol.jobs, protocol.episodes);
  std::vector<std::thread> pool;
  for (int t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (std::thread& t : pool) t.join();
  if (error) std::rethrow_exception(error);
  return records;
}

EpisodeSplit SplitByReference(const std::vector<EpisodeRecord>& episodes, const std::vector<EpisodeRecord>& reference) {
  std::map<int, bool> blocked;  // reference episode index -> had a collision
  for (const EpisodeRecord& r : reference) {
    if (!blocked.emplace(r.index, r.metrics.collisions > 0).second) {
      throw InputError(fmt::format("SplitByReference: the reference has episode {} twice", r.index));
    }
  }
  std::vector<double> settled[2];
  int successes[2] = {0, 0}, counts[2] = {0, 0};
  for (const EpisodeRecord& e : episodes) {
    const auto it = blocked.find(e.index);
    if (it == blocked.end()) {
      throw InputError(fmt::format("SplitByReference: episode {} is not among the reference's {} episodes", e.index,
                                   reference.size()));
    }
    const int k = it->second ? 1 : 0;
    ++counts[k];
    successes[k] += e.metrics.success ? 1 : 0;
    settled[k].push_back(1000.0 * e.metrics.settled_tracking_error);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EpisodeSplit s;
  s.free_count = counts[0];
  s.blocked_count = counts[1];
  s.free_success = counts[0] > 0 ? static_cast<double>(successes[0]) / counts[0] : nan;
  s.blocked_success = counts[1] > 0 ? static_cast<double>(successes[1]) / counts[1] : nan;
  s.free_settled_mm = FiniteMean(settled[0]);
  s.blocked_settled_mm = FiniteMean(settled[1]);
  return s;
}

}  // namespace rmpmarl::experiments
