// Random-action rollouts (random_rollout.h).
#include "rmpmarl/rl/random_rollout.h"

#include <chrono>
#include <cmath>
#include <vector>

#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/rl/vec_env.h"

namespace rmpmarl::rl {

void RandomActions(const tasks::EnvSpec& spec, std::mt19937_64& rng, float* actions) {
  const tasks::ActionSpec& a = spec.action;
  std::uniform_real_distribution<float> u(-1.2f, 1.2f), flag(0.0f, 1.0f);
  for (int agent = 0; agent < spec.num_agents; ++agent) {
    float* row = actions + static_cast<size_t>(agent) * a.size();
    if (a.num_options > 0) row[0] = static_cast<float>(std::uniform_int_distribution<int>(0, a.num_options - 1)(rng));
    for (int k = 0; k < a.num_continuous; ++k) row[a.continuous_offset() + k] = u(rng);
    if (a.has_termination) row[a.termination_offset()] = flag(rng) < 0.2f ? 1.0f : 0.0f;
  }
}

RandomRolloutStats RandomRollout(const tasks::TaskConfig& config, const RandomRolloutOptions& options) {
  const int N = options.num_envs;
  VecEnv envs(tasks::MakeManipulatorEnvFactory(tasks::MakeTaskContext(config)),
              {.num_envs = N, .seed = options.seed, .num_threads = options.threads});
  const tasks::EnvSpec& spec = envs.spec();
  const size_t stride = static_cast<size_t>(spec.num_agents) * spec.action.size();
  std::vector<float> actions(N * stride);
  std::mt19937_64 rng(options.seed ^ 0x9e3779b97f4a7c15ull);
  RandomRolloutStats s;
  const auto count = [&s](const float* p, size_t n) {
    for (size_t k = 0; k < n; ++k) s.nonfinite += std::isfinite(p[k]) ? 0 : 1;
  };
  const auto start = std::chrono::steady_clock::now();
  envs.Reset();
  while (s.steps < options.steps) {
    for (int k = 0; k < N; ++k) RandomActions(spec, rng, actions.data() + k * stride);
    envs.Step(actions.data());
    const Batch& b = envs.batch();
    count(b.local_obs.data(), b.local_obs.size());
    count(b.global_state.data(), b.global_state.size());
    count(b.reward_terms.data(), b.reward_terms.size());
    count(b.reward.data(), b.reward.size());
    count(b.final_local_obs.data(), b.final_local_obs.size());
    count(b.final_global_state.data(), b.final_global_state.size());
    for (int k = 0; k < N; ++k) {
      if (!b.terminated[k] && !b.truncated[k]) continue;
      ++s.episodes;
      s.invalid_episodes += b.metrics[k].invalid ? 1 : 0;
      s.collisions += b.metrics[k].collisions;
    }
    s.steps += N;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

}  // namespace rmpmarl::rl
