#include "rmpmarl/experiments/probe.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "rmpmarl/common/error.h"
#include "rmpmarl/experiments/evaluation.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/control/policy_runtime.h"

namespace rmpmarl::experiments {

LookaheadProbe ProbeLookahead(const std::string& policy_path, const tasks::TaskConfig& task, const ProbeOptions& o) {
  if (!(task.observation.lookahead > 0.0)) {
    throw InputError(fmt::format("look-ahead probe: expected a task with observation.lookahead > 0 s, got {}",
                                 task.observation.lookahead));
  }
  if (task.interface != tasks::InterfaceMode::kPerJointRmp) {
    throw InputError(fmt::format("look-ahead probe: expected the per-joint-rmp interface (RMP parameters), got {}",
                                 tasks::InterfaceModeName(task.interface)));
  }
  if (o.episodes < 1) throw InputError(fmt::format("look-ahead probe: episodes: expected >= 1, got {}", o.episodes));
  if (!(o.threat_time >= 0.0 && o.threat_time <= task.observation.lookahead)) {
    throw InputError(fmt::format("look-ahead probe: --time: expected [0, {}] s (observation.lookahead), got {}",
                                 task.observation.lookahead, o.threat_time));
  }
  if (!std::isfinite(o.threat_clearance)) {
    throw InputError(fmt::format("look-ahead probe: --clearance: expected a finite distance [m], got {}",
                                 o.threat_clearance));
  }
  if (!(std::isfinite(o.threat_speed) && o.threat_speed >= 0.0)) {
    throw InputError(fmt::format("look-ahead probe: --speed: expected a speed >= 0 m/s, got {}", o.threat_speed));
  }
  if (!std::isfinite(o.threat_threshold)) {
    throw InputError(fmt::format("look-ahead probe: threat threshold: expected a finite distance [m], got {}",
                                 o.threat_threshold));
  }
  const auto context = tasks::MakeTaskContext(task);
  const tasks::EnvSpec& spec = context->spec();
  const control::PolicyWeights weights = control::LoadPolicyFile(policy_path).weights;
  if (weights.obs_dim != spec.local_obs_dim || weights.action_size() != spec.action.size()) {
    throw InputError(fmt::format("look-ahead probe: policy {} takes obs {} and gives {} action floats; the task has "
                                 "obs {} and actions of {}", policy_path, weights.obs_dim, weights.action_size(),
                                 spec.local_obs_dim, spec.action.size()));
  }
  // the action is [option | continuous… | termination] and the head [option logits… | Gaussian means… | termination]
  const int k = o.parameter - control::RmpActionLayout::kTargetAccelScale;  // index among the Gaussian means
  if (k < 0 || k >= weights.num_continuous) {
    throw InputError(fmt::format("look-ahead probe: parameter: expected an RMP parameter index in [{}, {}], got {}",
                                 control::RmpActionLayout::kTargetAccelScale,
                                 control::RmpActionLayout::kTargetAccelScale + weights.num_continuous - 1, o.parameter));
  }
  const int A = spec.num_agents, D = spec.local_obs_dim, H = weights.head_size();
  const int mean_at = weights.num_options + k;
  const int c = control::LookaheadOffset(task.interface);
  float none[control::LocalObs::kLookaheadSize], threat[control::LocalObs::kLookaheadSize];
  control::WriteLookaheadBlock(std::numeric_limits<double>::infinity(), 0.0, 0.0, task.observation, none);
  control::WriteLookaheadBlock(o.threat_clearance, o.threat_time, o.threat_speed, task.observation, threat);
  const float threshold = static_cast<float>(o.threat_threshold / task.observation.length_scale);

  control::PolicyRuntime runtime(weights, A);
  tasks::ManipulatorEnv env(context);
  tasks::StepBuffers step(spec);
  std::vector<float> actions(static_cast<size_t>(A) * spec.action.size());
  std::vector<float> head(static_cast<size_t>(A) * H), edited(static_cast<size_t>(A) * D);
  LookaheadProbe p;
  p.u_none.assign(A, 0.0);
  p.u_threat.assign(A, 0.0);
  double sum_threatened = 0.0, sum_clear = 0.0;
  long steps = 0;
  auto head_with = [&](const float* block) {
    const float* obs = step.local_obs.data();
    std::copy(obs, obs + static_cast<size_t>(A) * D, edited.begin());
    for (int a = 0; a < A; ++a) {
      std::copy_n(block, control::LocalObs::kLookaheadSize, edited.begin() + static_cast<size_t>(a) * D + c);
    }
    runtime.EvaluateHead(edited.data(), A, head.data());
  };
  for (int e = 0; e < o.episodes; ++e) {
    std::mt19937_64 rng(EpisodeSeed(o.eval_seed, e));
    env.Reset(rng, step.out());
    while (true) {
      const float* obs = step.local_obs.data();
      runtime.EvaluateHead(obs, A, head.data());
      for (int a = 0; a < A; ++a) {
        const double u = head[static_cast<size_t>(a) * H + mean_at];
        if (obs[static_cast<size_t>(a) * D + c + control::LocalObs::kLookaheadClearance] < threshold) {
          sum_threatened += u;
          ++p.threatened_steps;
        } else {
          sum_clear += u;
          ++p.clear_steps;
        }
      }
      head_with(none);
      for (int a = 0; a < A; ++a) p.u_none[a] += head[static_cast<size_t>(a) * H + mean_at];
      head_with(threat);
      for (int a = 0; a < A; ++a) p.u_threat[a] += head[static_cast<size_t>(a) * H + mean_at];
      ++steps;
      runtime.Act(obs, A, actions.data());
      env.Step(actions.data(), rng, step.out());
      if (step.terminated || step.truncated) break;
    }
    ++p.episodes;
    p.failures += step.metrics.success ? 0 : 1;
  }
  for (int a = 0; a < A; ++a) {
    p.u_none[a] /= static_cast<double>(steps);
    p.u_threat[a] /= static_cast<double>(steps);
  }
  p.u_observed_threatened = p.threatened_steps > 0 ? sum_threatened / p.threatened_steps : 0.0;
  p.u_observed_clear = p.clear_steps > 0 ? sum_clear / p.clear_steps : 0.0;
  return p;
}

}  // namespace rmpmarl::experiments
