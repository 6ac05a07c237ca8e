// `rmpmarl_soak [--steps N] [--envs N] [--threads N] [--seed S]`: random-action env steps over every task × interface
// mode through the VecEnv engine (outside ctest; `make soak`), counting non-finite values in every observation,
// global state and reward. Prints one row per task/mode and the wall time; exits 1 when any value was non-finite.
#include <fmt/core.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <string>
#include <vector>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/manipulator_env.h"
#include "rmpmarl/rl/task_config.h"
#include "rmpmarl/rl/vec_env.h"

namespace rmpmarl::rl {
namespace {

struct SoakStats {
  long steps = 0, nonfinite = 0, episodes = 0, invalid_episodes = 0, collisions = 0;
  double seconds = 0.0;
};

// uniformly random actions: option indices, continuous values a bit beyond [low, high] (the env clips), termination
// flags (as tests/rl/rl_test_util.h).
void RandomActions(const EnvSpec& spec, std::mt19937_64& rng, float* actions) {
  const ActionSpec& a = spec.action;
  std::uniform_real_distribution<float> u(-1.2f, 1.2f), flag(0.0f, 1.0f);
  for (int agent = 0; agent < spec.num_agents; ++agent) {
    float* row = actions + static_cast<size_t>(agent) * a.size();
    if (a.num_options > 0) row[0] = static_cast<float>(std::uniform_int_distribution<int>(0, a.num_options - 1)(rng));
    for (int k = 0; k < a.num_continuous; ++k) row[a.continuous_offset() + k] = u(rng);
    if (a.has_termination) row[a.termination_offset()] = flag(rng) < 0.2f ? 1.0f : 0.0f;
  }
}

SoakStats Soak(const TaskConfig& config, int num_envs, int threads, long steps, std::uint64_t seed) {
  VecEnv envs(MakeManipulatorEnvFactory(MakeTaskContext(config)),
              {.num_envs = num_envs, .seed = seed, .num_threads = threads});
  const EnvSpec& spec = envs.spec();
  std::vector<float> actions(static_cast<size_t>(num_envs) * spec.num_agents * spec.action.size());
  std::mt19937_64 rng(seed ^ 0x9e3779b97f4a7c15ull);
  SoakStats s;
  const auto count = [&s](const float* p, size_t n) {
    for (size_t k = 0; k < n; ++k) s.nonfinite += std::isfinite(p[k]) ? 0 : 1;
  };
  const auto start = std::chrono::steady_clock::now();
  envs.Reset();
  while (s.steps < steps) {
    for (int k = 0; k < num_envs; ++k) {
      RandomActions(spec, rng, actions.data() + static_cast<size_t>(k) * spec.num_agents * spec.action.size());
    }
    envs.Step(actions.data());
    const Batch& b = envs.batch();
    count(b.local_obs.data(), b.local_obs.size());
    count(b.global_state.data(), b.global_state.size());
    count(b.reward_terms.data(), b.reward_terms.size());
    count(b.reward.data(), b.reward.size());
    for (int k = 0; k < num_envs; ++k) {
      if (!b.terminated[k] && !b.truncated[k]) continue;
      count(b.final_global_state.row(k).data(), b.final_global_state.cols());
      count(b.final_local_obs.data() + static_cast<size_t>(k) * spec.num_agents * b.final_local_obs.cols(),
            static_cast<size_t>(spec.num_agents) * b.final_local_obs.cols());
      ++s.episodes;
      s.invalid_episodes += b.metrics[k].invalid ? 1 : 0;
      s.collisions += b.metrics[k].collisions;
    }
    s.steps += num_envs;
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

long ArgValue(int argc, char** argv, const std::string& name, long fallback, long lo, long hi) {
  for (int k = 1; k + 1 < argc; ++k) {
    if (argv[k] != name) continue;
    char* end = nullptr;
    const long v = std::strtol(argv[k + 1], &end, 10);
    if (end == argv[k + 1] || *end != '\0' || v < lo || v > hi) {
      throw InputError(fmt::format("{}: expected an integer in [{}, {}], got \"{}\"", name, lo, hi, argv[k + 1]));
    }
    return v;
  }
  return fallback;
}

int Main(int argc, char** argv) {
  const long total = ArgValue(argc, argv, "--steps", 10'000'000, 1, 10'000'000'000L);
  const int envs = static_cast<int>(ArgValue(argc, argv, "--envs", 16, 1, 4096));
  const int threads = static_cast<int>(ArgValue(argc, argv, "--threads", 2, 1, 256));
  const auto seed = static_cast<std::uint64_t>(ArgValue(argc, argv, "--seed", 4242, 0, 1L << 62));
  const TaskKind tasks[] = {TaskKind::kPretrain2Link, TaskKind::kReachAvoid, TaskKind::kLineCrossing,
                            TaskKind::kCluttered};
  const InterfaceMode modes[] = {InterfaceMode::kPerJointRmp, InterfaceMode::kDirect, InterfaceMode::kPerJointDirect};
  const long per_run = (total + 11) / 12;
  fmt::print("soak: {} random-action steps per task x interface mode (12 runs), {} envs, {} threads, seed {}\n",
             per_run, envs, threads, seed);
  long steps = 0, nonfinite = 0, episodes = 0;
  const auto start = std::chrono::steady_clock::now();
  for (const TaskKind task : tasks) {
    for (const InterfaceMode mode : modes) {
      TaskConfig c = LoadShippedTaskConfig(TaskKindName(task));
      c.interface = mode;
      c.episode.max_steps = 200;  // more resets per step budget
      const SoakStats s = Soak(c, envs, threads, per_run, seed + static_cast<std::uint64_t>(steps));
      fmt::print("  {:<15} {:<16} {:>9} steps {:>6} episodes ({} invalid, {} collisions) {:7.1f} s {:8.0f} steps/s  "
                 "non-finite {}\n", TaskKindName(task), InterfaceModeName(mode), s.steps, s.episodes,
                 s.invalid_episodes, s.collisions, s.seconds, s.steps / s.seconds, s.nonfinite);
      std::fflush(stdout);
      steps += s.steps;
      nonfinite += s.nonfinite;
      episodes += s.episodes;
    }
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fmt::print("soak: {} steps, {} episodes, {} non-finite values, {:.1f} s wall\n", steps, episodes, nonfinite,
             seconds);
  return nonfinite == 0 ? 0 : 1;
}

}  // namespace
}  // namespace rmpmarl::rl

int main(int argc, char** argv) {
  try {
    return rmpmarl::rl::Main(argc, argv);
  } catch (const rmpmarl::InputError& e) {
    fmt::print(stderr, "rmpmarl_soak: error: {}\n", e.what());
    return 2;
  }
}
