// The trainer: rollouts over a VecEnv and PPO/MAPPO updates. Its checkpoints (format, save, resume, upgrade) and
// policy export are in trainer_checkpoint.cc; the training loop and evaluation runs in training_run.cc.
#include "rmpmarl/rl/torch/trainer.h"

#include "trainer_internal.h"

#include <dlfcn.h>
#include <fmt/format.h>
#include <torch/types.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/ppo.h"

namespace rmpmarl::rl {
namespace {

using namespace internal;

}  // namespace

void SetTorchThreads(int threads) {
  torch::set_num_threads(std::max(threads, 1));
  using SetThreads = void (*)(int);
  if (auto fn = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) {
    fn(std::max(threads, 1));
  }
}


Trainer::Trainer(const TrainConfig& config, tasks::EnvFactory factory, Collective* collective)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (collective != nullptr) {
    m.collective = collective;
    m.rank = collective->rank();
    m.world = collective->world_size();
  }
  m.config = config;
  m.factory = std::move(factory);
  SetTorchThreads(config.torch_threads);
  m.env = std::make_unique<VecEnv>(
      m.factory, VecEnvOptions{config.num_envs, config.seed + static_cast<std::uint64_t>(m.rank) * config.num_envs,
                               config.env_threads});
  m.spec = m.env->spec();
  if (config.algorithm == "ppo" && m.spec.num_agents != 1) {
    throw InputError(fmt::format("algorithm \"ppo\" is single-agent, but task {} has {} agents (use \"mappo\", or a "
                                 "single-agent interface of the task)", m.spec.task, m.spec.num_agents));
  }
  m.ppo = std::make_unique<Ppo>(m.spec, config.network, config.ppo, config.seed);
  if (!config.init_actor_from.empty()) {
    if (!std::filesystem::is_regular_file(config.init_actor_from)) {
      throw InputError(fmt::format("init_actor_from: expected the checkpoint of a finished pre-training run, got '{}' "
                                   "(no such file: train that run first, e.g. `rmpmarl train "
                                   "configs/train/pretrain-2link.yaml`, or set init_actor_from)",
                                   config.init_actor_from));
    }
    LoadedCheckpoint pre = LoadLearner(config.init_actor_from);
    try {
      m.ppo->InitActorFrom(*pre.ppo);
    } catch (const InputError& e) {
      throw InputError(fmt::format("init_actor_from {}: {}", config.init_actor_from, e.what()));
    }
  }
  m.ppo->SetCollective(collective);
}

Trainer::~Trainer() = default;

bool Trainer::finished() const { return impl_->update >= impl_->config.total_updates; }
int Trainer::update() const { return impl_->update; }
int Trainer::rank() const { return impl_->rank; }
int Trainer::world_size() const { return impl_->world; }
std::int64_t Trainer::env_steps() const { return impl_->env_steps; }
const TrainConfig& Trainer::config() const { return impl_->config; }
const tasks::EnvSpec& Trainer::spec() const { return impl_->spec; }

UpdateSummary Trainer::RunUpdate() { return impl_->RunUpdate(); }

UpdateSummary Trainer::Impl::RunUpdate() {
  const auto start = std::chrono::steady_clock::now();
  if (update % config.checkpoint_every == 0 && envs_reset_at != update) ResetEnvs(update);
  if (envs_reset_at < 0) ResetEnvs(update);
  const int T = config.ppo.rollout_steps(), N = config.num_envs, A = spec.num_agents;
  const int d = spec.local_obs_dim, S = spec.global_state_dim, as = spec.action.size();
  const auto f = torch::kFloat;
  torch::Tensor obs = torch::empty({T, N * A, d}, f), state = torch::empty({T, N, S}, f);
  torch::Tensor actions = torch::empty({T, N * A, as}, f);
  torch::Tensor lp_option = torch::empty({T, N * A}, f), lp_cont = torch::empty({T, N * A}, f),
                lp_term = torch::empty({T, N * A}, f);
  // the option's log-prob counts where the option choice took effect; the termination flag is a decision at every
  // step (it ends the running option after the step), so its mask is all ones
  torch::Tensor option_mask = torch::empty({T, N * A}, f), term_mask = torch::ones({T, N * A}, f);
  // the continuous part counts where the env read it (parameters held between reads were not this step's action)
  torch::Tensor param_mask = torch::empty({T, N * A}, f);
  torch::Tensor raw_values = torch::empty({T, N}, f), values = torch::empty({T, N}, f);
  torch::Tensor rewards = torch::empty({T, N}, f), terminated = torch::zeros({T, N}, f),
                truncated = torch::zeros({T, N}, f), final_values = torch::zeros({T, N}, f);
  int finished = 0;

  for (int t = 0; t < T; ++t) {
    const Batch& b = env->batch();
    const torch::Tensor local = torch::from_blob(const_cast<float*>(b.local_obs.data()), {N * A, d}, f);
    const torch::Tensor global = torch::from_blob(const_cast<float*>(b.global_state.data()), {N, S}, f);
    const ActResult r = ppo->Act(local, global, /*update_normalizers=*/true, /*deterministic=*/false);
    obs[t].copy_(r.actor_obs);
    state[t].copy_(r.critic_state);
    actions[t].copy_(r.sampled.actions);
    lp_option[t].copy_(r.sampled.log_probs.option);
    lp_cont[t].copy_(r.sampled.log_probs.continuous);
    lp_term[t].copy_(r.sampled.log_probs.termination);
    raw_values[t].copy_(r.raw_values);
    values[t].copy_(r.values);
    const torch::Tensor step_actions = actions[t].contiguous();
    env->Step(step_actions.data_ptr<float>());
    const Batch& after = env->batch();
    std::memcpy(option_mask[t].data_ptr<float>(), after.option_started.data(), sizeof(float) * N * A);
    std::memcpy(param_mask[t].data_ptr<float>(), after.parameters_read.data(), sizeof(float) * N * A);
    std::memcpy(rewards[t].data_ptr<float>(), after.reward.data(), sizeof(float) * N);
    float* term = terminated[t].data_ptr<float>();
    float* trunc = truncated[t].data_ptr<float>();
    bool any_truncated = false;
    for (int k = 0; k < N; ++k) {
      term[k] = after.terminated[k] ? 1.0f : 0.0f;
      trunc[k] = (!after.terminated[k] && after.truncated[k]) ? 1.0f : 0.0f;
      any_truncated |= trunc[k] > 0.0f;
      if (after.terminated[k] || after.truncated[k]) {
        ++finished;
        recent.push_back(after.metrics[k]);
        if (static_cast<int>(recent.size()) > config.stats_window) recent.pop_front();
      }
    }
    if (any_truncated) {
      const torch::Tensor fin =
          torch::from_blob(const_cast<float*>(after.final_global_state.data()), {N, S}, f);
      final_values[t].copy_(ppo->Values(fin));
    }
  }
  const Batch& last = env->batch();
  const torch::Tensor last_state = torch::from_blob(const_cast<float*>(last.global_state.data()), {N, S}, f);
  const torch::Tensor last_values = ppo->Values(last_state);
  const auto rollout_end = std::chrono::steady_clock::now();
  const GaeResult gae = ComputeGae({rewards, values, terminated, truncated, final_values, last_values},
                                   config.ppo.gamma(), config.ppo.gae_lambda());

  RolloutBatch batch;
  batch.num_agents = A;
  batch.actor_obs = obs.reshape({T * N * A, d});
  batch.critic_state = state.reshape({T * N, S});
  batch.actions = actions.reshape({T * N * A, as});
  batch.old_log_probs = {lp_option.reshape({-1}), lp_cont.reshape({-1}), lp_term.reshape({-1})};
  batch.option_mask = option_mask.reshape({-1});
  batch.termination_mask = term_mask.reshape({-1});
  batch.continuous_mask = param_mask.reshape({-1});
  batch.old_values = raw_values.reshape({-1});
  batch.returns = gae.returns.reshape({-1});
  batch.advantages = gae.advantages.reshape({-1});
  double lr_scale = 1.0;
  if (config.ppo.lr_schedule() == LrSchedule::kLinear) {
    lr_scale = 1.0 - (1.0 - config.ppo.lr_final_fraction()) * update / config.total_updates;
  }
  const UpdateStats learn = ppo->Update(batch, lr_scale);
  ++update;
  env_steps += static_cast<std::int64_t>(T) * N * world;

  EpisodeStats episodes;
  for (const tasks::EpisodeMetrics& m : recent) episodes.Add(m);
  if (world > 1) {
    // the logs' episode statistics over every rank's window
    torch::Tensor sums = torch::tensor(
        {double(episodes.episodes), double(episodes.successes), double(episodes.collisions),
         double(episodes.clearance_count), episodes.return_sum, episodes.track_sum, episodes.final_track_sum,
         episodes.clearance_sum, episodes.length_sum, double(finished)}, torch::kDouble);
    collective->AllReduceSum(sums);
    const double* v = sums.data_ptr<double>();
    episodes.episodes = static_cast<int>(v[0]);
    episodes.successes = static_cast<int>(v[1]);
    episodes.collisions = static_cast<int>(v[2]);
    episodes.clearance_count = static_cast<int>(v[3]);
    episodes.return_sum = v[4];
    episodes.track_sum = v[5];
    episodes.final_track_sum = v[6];
    episodes.clearance_sum = v[7];
    episodes.length_sum = v[8];
    finished = static_cast<int>(v[9]);
  }
  UpdateSummary s;
  s.update = update;
  s.env_steps = env_steps;
  s.episodes = finished;
  s.window_episodes = episodes.episodes;
  s.mean_return = episodes.Mean(episodes.return_sum);
  s.success_rate = episodes.Mean(episodes.successes);
  s.tracking_error_mm = episodes.Mean(episodes.track_sum);
  s.final_tracking_error_mm = episodes.Mean(episodes.final_track_sum);
  s.min_clearance_m = episodes.clearance_count > 0 ? episodes.clearance_sum / episodes.clearance_count : kNaN;
  s.collisions_per_episode = episodes.Mean(episodes.collisions);
  s.episode_length = episodes.Mean(episodes.length_sum);
  s.policy_loss = learn.policy_loss;
  s.value_loss = learn.value_loss;
  s.entropy_option = learn.entropy_option;
  s.entropy_continuous = learn.entropy_continuous;
  s.entropy_termination = learn.entropy_termination;
  s.approx_kl = learn.approx_kl;
  s.clip_fraction = learn.clip_fraction;
  s.explained_variance = learn.explained_variance;
  s.actor_grad_norm = learn.actor_grad_norm;
  s.critic_grad_norm = learn.critic_grad_norm;
  s.lr = config.ppo.lr() * lr_scale;
  const auto end = std::chrono::steady_clock::now();
  s.seconds = std::chrono::duration<double>(end - start).count();
  s.rollout_seconds = std::chrono::duration<double>(rollout_end - start).count();
  s.learn_seconds = std::chrono::duration<double>(end - rollout_end).count();
  s.fps = static_cast<double>(T) * N * world / std::max(s.seconds, 1e-9);
  return s;
}


}  // namespace rmpmarl::rl
