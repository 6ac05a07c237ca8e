#pragma once
/// What a learned per-joint agent does with the moving-obstacle look-ahead block (observation.lookahead, docs/
/// environments.md): the policy acts deterministically on the evaluation episodes (the same EpisodeSeed as
/// EvaluateMethod), and at every agent-step its Gaussian mean of one RMP parameter is also evaluated with the block
/// replaced by "no pass predicted" and by "a pass at `threat_clearance` in `threat_time`", all other features as
/// observed. The difference is the agent's response to the block alone — for the hand gate it is the full switch
/// (u = +1 against 0 on the stiffness layer).
///
///   const LookaheadProbe p = ProbeLookahead(policy_path, task, {.episodes = 10});
#include <cstdint>
#include <string>
#include <vector>

#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::experiments {

struct ProbeOptions {
  int episodes = 10;
  std::uint64_t eval_seed = 7;    ///< episodes as EvaluateMethod's under this seed (7: the selection seed)
  int parameter = control::RmpActionLayout::kTargetAccelScale;  ///< which RMP parameter (RmpActionLayout index 1..4)
  double threat_clearance = 0.0;  ///< [m] the substituted pass: predicted clearance ...
  double threat_time = 0.3;       ///< [s] ... time of closest approach (≤ observation.lookahead) ...
  double threat_speed = 2.8;      ///< [m/s] ... and the obstacle's speed
  double threat_threshold = 0.15; ///< [m] an observed step counts as threatened below this predicted clearance
};

/// Means of the chosen parameter's action mean u (before the env clips it to [−1, 1]), per agent and pooled, over every
/// agent-step — also the steps where a joint holds its parameters (options.parameter_period > 1) and ignores u: the
/// probe describes the policy as a function of its observation, not only the values the env applied.
struct LookaheadProbe {
  std::vector<double> u_none;    ///< per agent: block set to "none" (clearance 2ℓ, time 1, speed 0)
  std::vector<double> u_threat;  ///< per agent: block set to the substituted pass
  double u_observed_threatened = 0.0;  ///< over agent-steps whose observed block predicts a pass below the threshold
  double u_observed_clear = 0.0;       ///< over the others
  long threatened_steps = 0, clear_steps = 0;
  int episodes = 0, failures = 0;      ///< failures: episodes that are not a success (EpisodeMetrics::success)
};

/// \throws InputError when the task has no look-ahead block (observation.lookahead 0) or is not per-joint-rmp, the
/// options are out of range, or the policy does not fit the task's observation and action sizes.
LookaheadProbe ProbeLookahead(const std::string& policy_path, const tasks::TaskConfig& task, const ProbeOptions& options);

}  // namespace rmpmarl::experiments
