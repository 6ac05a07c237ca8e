#pragma once
/// Environments as specs (EnvPool's design): an environment declares its observation, global-state and action
/// layout and its reward terms in an EnvSpec; the generic batched engine (vec_env.h) runs any Env on a thread pool
/// with preallocated batch buffers. Multi-agent aware: each env has `num_agents` agents with same-sized local
/// observations and actions (one per joint for the per-joint agents; 1 for single-agent baselines) and one global
/// state for a centralised critic.
#include <functional>
#include <memory>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "rmpmarl/control/action_spec.h"
#include "rmpmarl/sim/episode_metrics.h"

namespace rmpmarl::tasks {

using control::ActionSpec;

/// Everything a learner needs to know about an environment, fixed for its lifetime.
struct EnvSpec {
  std::string task;                              ///< e.g. "reach-avoid"
  int num_agents = 1;
  int local_obs_dim = 0;
  std::vector<std::string> local_obs_names;      ///< size local_obs_dim
  int global_state_dim = 0;
  std::vector<std::string> global_state_names;   ///< size global_state_dim
  ActionSpec action;                             ///< per agent
  std::vector<std::string> reward_terms;         ///< the logged reward terms; the reward is their sum
  double discount = 0.99;                        ///< γ
  int max_episode_steps = 0;                     ///< truncation horizon
  double control_dt = 0.0;                       ///< seconds of simulated time per env step
};

/// Per-episode metrics, reported when an episode ends: the episode loop's (sim/episode_metrics.h).
using EpisodeMetrics = sim::EpisodeMetrics;

/// the start of the settled phase of a task episode (EpisodeMetrics::settled_tracking_error, LoopOptions) [s].
inline constexpr double kSettleTime = 1.0;

/// Where one env writes one step's results: views into the engine's batch buffers (row-major).
struct StepOutput {
  float* local_obs = nullptr;     ///< num_agents × local_obs_dim
  float* global_state = nullptr;  ///< global_state_dim
  float* reward_terms = nullptr;  ///< reward_terms.size()
  float* reward = nullptr;        ///< 1: the sum of the terms
  std::uint8_t* terminated = nullptr;  ///< 1: the episode ended (collision-free end, failure, invalid)
  std::uint8_t* truncated = nullptr;   ///< 1: the episode hit max_episode_steps
  float* option_started = nullptr;     ///< num_agents: 1 where the agent's action started a new option this step
  EpisodeMetrics* metrics = nullptr;   ///< written when terminated or truncated
  /// num_agents, optional (nullptr: not asked): 1 where the env read the action's continuous part this step, 0 where
  /// it held earlier values (per-joint-rmp with options.parameter_period > 1); envs that always read it may leave it
  float* parameters_read = nullptr;
  /// num_agents, optional (nullptr: not asked): 1 where the next Step reads some part of the agent's action, 0 where
  /// it will ignore it (per-joint-rmp with a running option, no learned termination and parameters held by
  /// options.parameter_period > 1; every agent while a baseline drives the robot). A deterministic actor may skip
  /// the agents marked 0, but the env still checks every action (finite, a valid option index): keep their last
  /// actions there. Envs that always read leave it.
  float* next_action_read = nullptr;
};

/// Owned buffers for one env's step results (what a VecEnv row holds), sized from a spec, and the StepOutput view
/// over them — for driving an Env directly (demos, benchmarks, tests). Not copyable: views point into it.
struct StepBuffers {
  /// sized for `spec`, every float set to `fill`.
  explicit StepBuffers(const EnvSpec& spec, float fill = 0.0f)
      : local_obs(static_cast<size_t>(spec.num_agents) * spec.local_obs_dim, fill),
        global_state(spec.global_state_dim, fill),
        reward_terms(spec.reward_terms.size(), fill),
        option_started(spec.num_agents, fill),
        reward(fill) {}
  StepBuffers(const StepBuffers&) = delete;
  StepBuffers& operator=(const StepBuffers&) = delete;

  StepOutput out() {
    return {local_obs.data(), global_state.data(), reward_terms.data(), &reward, &terminated, &truncated,
            option_started.data(), &metrics, parameters_read.data(), next_action_read.data()};
  }

  std::vector<float> local_obs, global_state, reward_terms, option_started;
  std::vector<float> parameters_read = std::vector<float>(option_started.size(), 1.0f);
  std::vector<float> next_action_read = std::vector<float>(option_started.size(), 1.0f);
  float reward = 0.0f;
  std::uint8_t terminated = 0, truncated = 0;
  EpisodeMetrics metrics;
};

/// One environment instance. Implementations own their simulation state (e.g. a sim::World over a shared
/// WorldModel), allocate nothing in Step, and draw every random number from the engine-provided RNG.
class Env {
 public:
  virtual ~Env() = default;
  virtual const EnvSpec& spec() const = 0;
  /// starts a new episode (domain randomisation happens here) and writes its first observation; reward terms,
  /// reward and flags are written as zero.
  virtual void Reset(std::mt19937_64& rng, const StepOutput& out) = 0;
  /// applies `actions` (num_agents × spec().action.size() floats, row-major) and advances one control step.
  /// Non-finite or out-of-layout actions end the episode flagged invalid (never NaN in the outputs).
  virtual void Step(const float* actions, std::mt19937_64& rng, const StepOutput& out) = 0;
};

/// makes env number `env_id` (called once per env at construction, on the constructing thread).
using EnvFactory = std::function<std::unique_ptr<Env>(int env_id)>;

}  // namespace rmpmarl::tasks
