// `rmpmarl_soak [--steps N] [--envs N] [--threads N] [--seed S]`: random-action env steps over every task × interface
// mode through the VecEnv engine (outside ctest; `make soak`), counting non-finite values in every observation,
// global state and reward. Prints one row per task/mode and the wall time; exits 1 when any value was non-finite.
#include <fmt/core.h>

#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/random_rollout.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::rl {
namespace {

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
  const tasks::TaskKind tasks[] = {tasks::TaskKind::kPretrain2Link, tasks::TaskKind::kReachAvoid, tasks::TaskKind::kLineCrossing,
                            tasks::TaskKind::kCluttered};
  const tasks::InterfaceMode modes[] = {tasks::InterfaceMode::kPerJointRmp, tasks::InterfaceMode::kDirect, tasks::InterfaceMode::kPerJointDirect};
  const long per_run = (total + 11) / 12;
  fmt::print("soak: {} random-action steps per task x interface mode (12 runs), {} envs, {} threads, seed {}\n",
             per_run, envs, threads, seed);
  long steps = 0, nonfinite = 0, episodes = 0;
  const auto start = std::chrono::steady_clock::now();
  for (const tasks::TaskKind task : tasks) {
    for (const tasks::InterfaceMode mode : modes) {
      tasks::TaskConfig c = tasks::LoadShippedTaskConfig(tasks::TaskKindName(task));
      c.interface = mode;
      c.episode.max_steps = 200;  // more resets per step budget
      const RandomRolloutStats s = RandomRollout(
          c, {.num_envs = envs, .threads = threads, .steps = per_run, .seed = seed + static_cast<std::uint64_t>(steps)});
      fmt::print("  {:<15} {:<16} {:>9} steps {:>6} episodes ({} invalid, {} collisions) {:7.1f} s {:8.0f} steps/s  "
                 "non-finite {}\n", tasks::TaskKindName(task), tasks::InterfaceModeName(mode), s.steps, s.episodes,
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
