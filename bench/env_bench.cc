// Env steps per second of the manipulator environment (reach-avoid, Panda, 4 crossing cubes), single env on one
// core, beside a bare mj_step on the same compiled model. Run:
//   build/bench/env_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// Variants (benchmark arguments): interface mode, when the scenario moves obstacles/target (every physics step or
// once per env step), and physics steps per env step (5 = the tasks' 100 Hz control at 2 ms; 1 = 500 Hz control).
#include <benchmark/benchmark.h>
#include <mujoco/mujoco.h>

#include <fmt/format.h>

#include <memory>
#include <random>
#include <vector>

#include "learned_default.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/rl/vec_env.h"

namespace rmpmarl::rl {
namespace {

tasks::TaskConfig BenchConfig(tasks::InterfaceMode mode, tasks::ScenarioUpdate update, int physics_steps, double lookahead = 0.0) {
  tasks::TaskConfig c = tasks::LoadShippedTaskConfig("reach-avoid");
  c.observation.lookahead = lookahead;
  c.robot = "panda";
  c.interface = mode;
  c.scenario.crossing.num_obstacles = 4;
  c.episode.scenario_update = update;
  c.episode.control_rate = 1.0 / (physics_steps * c.episode.physics_timestep);
  c.controller.control_rate = c.episode.control_rate;
  c.controller.max_substep = 1.0 / c.episode.control_rate;
  return c;
}

// 4096 random joint actions of `spec`'s interface, drawn before timing and cycled
std::vector<float> RandomActions(const tasks::EnvSpec& spec, std::mt19937_64& rng) {
  const int action_size = spec.num_agents * spec.action.size();
  std::vector<float> actions(4096 * static_cast<size_t>(action_size));
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), flag(0.0f, 1.0f);
  for (size_t k = 0; k < actions.size(); ++k) actions[k] = u(rng);
  if (spec.action.num_options > 0) {
    for (size_t k = 0; k < actions.size(); k += spec.action.size()) {
      actions[k] = static_cast<float>(std::uniform_int_distribution<int>(0, 2)(rng));
      if (spec.action.has_termination) actions[k + spec.action.termination_offset()] = flag(rng) < 0.1f ? 1.0f : 0.0f;
    }
  }
  return actions;
}

// one env of `config` and its step buffers
struct OneEnv {
  explicit OneEnv(const tasks::TaskConfig& config)
      : context(tasks::MakeTaskContext(config)), env(context), buffers(env.spec()), out(buffers.out()) {}
  std::shared_ptr<const tasks::TaskContext> context;
  tasks::ManipulatorEnv env;
  tasks::StepBuffers buffers;
  tasks::StepOutput out;
};

using bench::LearnedDefaultConfig;

// one env of `config`, random actions drawn before timing, auto-reset at episode ends (resets are included in the
// time)
void RunEnvSteps(benchmark::State& state, const tasks::TaskConfig& config) {
  OneEnv one(config);
  auto& [context, env, buffers, out] = one;
  const tasks::EnvSpec& spec = env.spec();
  std::mt19937_64 rng(7);
  const int action_size = spec.num_agents * spec.action.size();
  const std::vector<float> actions = RandomActions(spec, rng);
  for (int r = 0; r < 3 * context->num_variants(); ++r) env.Reset(rng, out);  // make every variant's scenario
  env.Reset(rng, out);
  long k = 0, warnings = 0;
  for (auto _ : state) {
    env.Step(actions.data() + (k++ % 4096) * action_size, rng, out);
    warnings += static_cast<long>(env.world().mj_data()->ncon);
    if (buffers.terminated || buffers.truncated) env.Reset(rng, out);
  }
  state.counters["env_steps/s"] = benchmark::Counter(static_cast<double>(state.iterations()),
                                                     benchmark::Counter::kIsRate);
  state.counters["contacts"] = benchmark::Counter(static_cast<double>(warnings) / state.iterations());
}

void BM_EnvStep(benchmark::State& state) {
  const auto mode = static_cast<tasks::InterfaceMode>(state.range(0));
  const auto update = static_cast<tasks::ScenarioUpdate>(state.range(1));
  const int physics_steps = static_cast<int>(state.range(2));
  const double lookahead = static_cast<double>(state.range(3));  // [s]: the look-ahead block (0: off)
  RunEnvSteps(state, BenchConfig(mode, update, physics_steps, lookahead));
}
BENCHMARK(BM_EnvStep)
    ->ArgNames({"mode", "update", "physics", "lookahead"})
    ->Args({static_cast<int>(tasks::InterfaceMode::kPerJointRmp), static_cast<int>(tasks::ScenarioUpdate::kPhysicsStep), 5, 0})
    ->Args({static_cast<int>(tasks::InterfaceMode::kPerJointRmp), static_cast<int>(tasks::ScenarioUpdate::kPhysicsStep), 5, 1})
    ->Args({static_cast<int>(tasks::InterfaceMode::kPerJointRmp), static_cast<int>(tasks::ScenarioUpdate::kControlStep), 5, 0})
    ->Args({static_cast<int>(tasks::InterfaceMode::kPerJointRmp), static_cast<int>(tasks::ScenarioUpdate::kControlStep), 1, 0})
    ->Args({static_cast<int>(tasks::InterfaceMode::kPerJointDirect), static_cast<int>(tasks::ScenarioUpdate::kControlStep), 5, 0})
    ->Args({static_cast<int>(tasks::InterfaceMode::kPerJointDirect), static_cast<int>(tasks::ScenarioUpdate::kControlStep), 1, 0})
    ->Unit(benchmark::kMicrosecond);

// the shipped learned default's own task as its controller file carries it (the coupled basic layer, the hand gate,
// the look-ahead block and observation of the reach-avoid scene it was trained in): the env step it is trained on
void BM_EnvStepLearnedDefault(benchmark::State& state) {
  const tasks::TaskConfig config = LearnedDefaultConfig();
  RunEnvSteps(state, config);
  state.SetLabel(fmt::format("{}, lookahead {} s, scenario update per {}", config.robot, config.observation.lookahead,
                             config.episode.scenario_update == tasks::ScenarioUpdate::kPhysicsStep ? "physics step"
                                                                                                   : "control step"));
}
BENCHMARK(BM_EnvStepLearnedDefault)->Unit(benchmark::kMicrosecond);

// the batched engine: 32 envs (per-joint RMP agents, 1 physics step per env step) on 1 or 2 worker threads;
// wall-clock rate, so the thread scaling is visible (goal: 2 threads ≥ 1.8× one).
void BM_VecEnvStep(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  auto context = tasks::MakeTaskContext(BenchConfig(tasks::InterfaceMode::kPerJointRmp, tasks::ScenarioUpdate::kControlStep, 1));
  const int num_envs = 32;
  VecEnv envs(tasks::MakeManipulatorEnvFactory(context), {.num_envs = num_envs, .seed = 3, .num_threads = threads});
  const tasks::EnvSpec& spec = envs.spec();
  const int action_size = spec.num_agents * spec.action.size();
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<std::vector<float>> batches(16, std::vector<float>(static_cast<size_t>(num_envs) * action_size));
  for (auto& b : batches) {
    for (size_t k = 0; k < b.size(); ++k) b[k] = u(rng);
    for (size_t k = 0; k < b.size(); k += spec.action.size()) {
      b[k] = static_cast<float>(std::uniform_int_distribution<int>(0, 2)(rng));
    }
  }
  envs.Reset();
  long k = 0;
  for (auto _ : state) envs.Step(batches[k++ % 16].data());
  state.counters["env_steps/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * num_envs, benchmark::Counter::kIsRate);
}
BENCHMARK(BM_VecEnvStep)->ArgName("threads")->Arg(1)->Arg(2)->UseRealTime()->Unit(benchmark::kMillisecond);

// the shipped reach-avoid task (configs/tasks/reach-avoid.yaml, per-joint RMP agents) at 64 envs on 1 or 2 threads:
// the C++ side of bench/python_bench.py's comparison (Python batched stepping of the same envs and actions).
void BM_VecEnvReachAvoid64(benchmark::State& state) {
  const int threads = static_cast<int>(state.range(0));
  auto context = tasks::MakeTaskContext(tasks::LoadShippedTaskConfig("reach-avoid"));
  const int num_envs = 64;
  VecEnv envs(tasks::MakeManipulatorEnvFactory(context), {.num_envs = num_envs, .seed = 3, .num_threads = threads});
  const tasks::EnvSpec& spec = envs.spec();
  // option 0 (target), unit scales, no termination: the same actions the Python benchmark sends
  std::vector<float> actions(static_cast<size_t>(num_envs) * spec.num_agents * spec.action.size(), 0.0f);
  envs.Reset();
  for (auto _ : state) envs.Step(actions.data());
  state.counters["env_steps/s"] =
      benchmark::Counter(static_cast<double>(state.iterations()) * num_envs, benchmark::Counter::kIsRate);
}
// two whole episodes (600 steps each) from the reset: the same work as the Python side's
BENCHMARK(BM_VecEnvReachAvoid64)->ArgName("threads")->Arg(1)->Arg(2)->Iterations(1200)->UseRealTime()
    ->Unit(benchmark::kMillisecond);

// bare mj_step (physics only: no servo targets change, no scenario, no observation) on the compiled model of
// `config`'s env, from a state of a reset episode (obstacles placed, arm at its start posture).
void RunBareMjSteps(benchmark::State& state, const tasks::TaskConfig& config) {
  OneEnv one(config);
  auto& [context, env, buffers, out] = one;
  std::mt19937_64 rng(7);
  env.Reset(rng, out);
  const mjModel* m = env.world().mj_model();
  mjData* d = mj_makeData(m);
  mj_copyData(d, m, env.world().mj_data());
  long k = 0, contacts = 0;
  for (auto _ : state) {
    mj_step(m, d);
    contacts += d->ncon;
    if (++k % 1000 == 0) mj_copyData(d, m, env.world().mj_data());  // stay near the start posture
  }
  state.counters["mj_steps/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["contacts"] = benchmark::Counter(static_cast<double>(contacts) / state.iterations());
  mj_deleteData(d);
}

void BM_BareMjStep(benchmark::State& state) {
  RunBareMjSteps(state, BenchConfig(tasks::InterfaceMode::kPerJointRmp, tasks::ScenarioUpdate::kPhysicsStep, 5));
}
BENCHMARK(BM_BareMjStep)->Unit(benchmark::kMicrosecond);

// the same on the learned default's own model: its 0.5 m warning distance is the sensing margin of the arm's
// capsules, so MuJoCo finds (and sorts out) every pair within it at every step
void BM_BareMjStepLearnedDefault(benchmark::State& state) { RunBareMjSteps(state, LearnedDefaultConfig()); }
BENCHMARK(BM_BareMjStepLearnedDefault)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rmpmarl::rl
