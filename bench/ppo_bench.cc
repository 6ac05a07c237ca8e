// Learning-layer benchmarks: one PPO gradient step (forward + backward + Adam) at batch 4096 with the paper's
// 3 × 128 MLPs, and the torch-free runtime evaluating the 7 per-joint agents of a 7-DoF arm at batch 1.
// Thread counts: the first argument of the PPO benchmarks is the libtorch/OpenBLAS thread count.
#include <benchmark/benchmark.h>
#include <torch/types.h>

#include <random>

#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/rl/torch/ppo.h"
#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::rl {
namespace {

// the per-joint-rmp agent of a 7-DoF arm: local obs 38, options 3, continuous 4, termination; state 140.
tasks::EnvSpec PerJointRmpSpec(int agents) {
  tasks::EnvSpec s;
  s.task = "bench";
  s.num_agents = agents;
  s.local_obs_dim = 38;
  s.global_state_dim = 140;
  s.action.num_options = 3;
  s.action.num_continuous = 4;
  s.action.low.assign(4, -1.0f);
  s.action.high.assign(4, 1.0f);
  s.action.has_termination = true;
  return s;
}

// a rollout of M env-steps with A agents, from the learner's own policy.
RolloutBatch MakeBatch(Ppo& ppo, int M) {
  const tasks::EnvSpec& s = ppo.spec();
  const int A = s.num_agents;
  torch::manual_seed(1);
  const ActResult r = ppo.Act(torch::randn({M * A, s.local_obs_dim}), torch::randn({M, s.global_state_dim}), true,
                              false);
  RolloutBatch b;
  b.num_agents = A;
  b.actor_obs = r.actor_obs;
  b.critic_state = r.critic_state;
  b.actions = r.sampled.actions;
  b.old_log_probs = r.sampled.log_probs;
  b.option_mask = (torch::rand({M * A}) < 0.3).to(torch::kFloat);
  b.termination_mask = torch::ones({M * A});
  b.old_values = r.raw_values;
  b.returns = torch::randn({M}) * 10.0;
  b.advantages = torch::randn({M});
  return b;
}

// one PPO gradient step on a minibatch of 4096 actor rows (epochs 1, minibatches 1); bf16: autocast matmuls.
void BM_PpoUpdateBatch4096(benchmark::State& state) {
  SetTorchThreads(static_cast<int>(state.range(0)));
  const int agents = static_cast<int>(state.range(1));
  const int M = 4096 / agents;
  Ppo ppo(PerJointRmpSpec(agents), NetworkOptions{},
          PpoOptions{}.epochs(1).minibatches(1).bf16_autocast(state.range(2) != 0), 1);
  const RolloutBatch batch = MakeBatch(ppo, M);
  for (auto _ : state) {
    const UpdateStats stats = ppo.Update(batch, 1.0);
    benchmark::DoNotOptimize(stats.policy_loss);
  }
  state.counters["actor_rows"] = M * agents;
  state.counters["critic_rows"] = M;
  SetTorchThreads(1);
}
BENCHMARK(BM_PpoUpdateBatch4096)
    ->ArgsProduct({{1, 2}, {1, 7}, {0, 1}})
    ->ArgNames({"threads", "agents", "bf16"})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// the acting step of a rollout: normalise, actor + sampling, critic, for 64 envs × 7 agents.
void BM_PpoActBatch64Envs7Agents(benchmark::State& state) {
  SetTorchThreads(static_cast<int>(state.range(0)));
  Ppo ppo(PerJointRmpSpec(7), NetworkOptions{}, PpoOptions{}, 1);
  const torch::Tensor obs = torch::randn({64 * 7, 38}), global = torch::randn({64, 140});
  for (auto _ : state) {
    const ActResult r = ppo.Act(obs, global, true, false);
    benchmark::DoNotOptimize(r.values.data_ptr());
  }
  SetTorchThreads(1);
}
BENCHMARK(BM_PpoActBatch64Envs7Agents)->Arg(1)->Arg(2)->ArgName("threads")->Unit(benchmark::kMicrosecond)->UseRealTime();

control::PolicyWeights SevenJointPolicy() {
  Ppo ppo(PerJointRmpSpec(7), NetworkOptions{}.actor_output_gain(1.0), PpoOptions{}, 3);
  torch::manual_seed(2);
  ppo.obs_norm().Update(torch::randn({256, 38}));
  return ppo.Export();
}

// all 7 agents of a 7-DoF arm at batch 1 (one observation each): normalise, 3 × 128 ReLU, head, mode actions.
void BM_RuntimeSevenAgents(benchmark::State& state) {
  control::PolicyRuntime rt(SevenJointPolicy(), 7);
  if (state.range(0) == 0) rt.DisableAvx2();
  std::mt19937 rng(1);
  std::normal_distribution<float> n;
  std::vector<float> obs(7 * 38), actions(7 * rt.action_size());
  for (float& o : obs) o = n(rng);
  for (auto _ : state) {
    rt.Act(obs.data(), 7, actions.data());
    benchmark::DoNotOptimize(actions.data());
    benchmark::ClobberMemory();
  }
  state.SetLabel(rt.uses_avx2() ? "avx2+fma" : "portable eigen");
}
BENCHMARK(BM_RuntimeSevenAgents)->Arg(1)->Arg(0)->ArgName("avx2")->Unit(benchmark::kMicrosecond);

// one agent at batch 1 (e.g. a single joint's controller).
void BM_RuntimeOneAgent(benchmark::State& state) {
  control::PolicyRuntime rt(SevenJointPolicy(), 1);
  std::vector<float> obs(38, 0.3f), actions(rt.action_size());
  for (auto _ : state) {
    rt.Act(obs.data(), 1, actions.data());
    benchmark::DoNotOptimize(actions.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RuntimeOneAgent)->Unit(benchmark::kMicrosecond);

// the same 7 agents through libtorch (for comparison).
void BM_LibtorchActorSevenAgents(benchmark::State& state) {
  SetTorchThreads(1);
  Ppo ppo(PerJointRmpSpec(7), NetworkOptions{}, PpoOptions{}, 3);
  const torch::Tensor obs = torch::randn({7, 38});
  torch::NoGradGuard no_grad;
  for (auto _ : state) {
    const HeadOutputs head = ppo.actor()->forward(ppo.obs_norm().Normalize(obs, 10.0));
    benchmark::DoNotOptimize(head.option_logits.data_ptr());
  }
}
BENCHMARK(BM_LibtorchActorSevenAgents)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rmpmarl::rl
