#pragma once
/// PPO and MAPPO (libtorch): GAE(λ), the clipped surrogate and clipped value losses, per-head entropy bonuses,
/// running observation/return normalisation, and the learner that owns the networks and the optimiser.
///
/// MAPPO (centralised training, decentralised execution; Sec. III.D, eq 11–13): every agent's actor sees only its
/// local observation and all agents share one actor's parameters; one centralised critic V(x) sees the global
/// state x and is trained on the team reward. Single-agent PPO is the same code with num_agents = 1.
#include <torch/nn/module.h>
#include <torch/optim/adam.h>
#include <torch/serialize/archive.h>

#include "rmpmarl/rl/torch/tensor_archive.h"

#include <cstdint>
#include <memory>

#include "rmpmarl/tasks/env.h"
#include "rmpmarl/rl/torch/distributed.h"
#include "rmpmarl/rl/torch/networks.h"
#include "rmpmarl/rl/torch/ppo_options.h"

namespace rmpmarl::rl {

/// Inputs of GAE over a rollout of T steps of N envs (each T × N unless noted; flags as 0/1 floats).
struct GaeInputs {
  torch::Tensor rewards;       ///< r_t
  torch::Tensor values;        ///< V(s_t)
  torch::Tensor terminated;    ///< the episode ended at step t with no future: no bootstrap
  torch::Tensor truncated;     ///< the episode was cut at step t (time limit): bootstrap from final_values
  torch::Tensor final_values;  ///< V(s_{t+1}) of a truncated episode's last state (read only where truncated)
  torch::Tensor last_values;   ///< N: V(s_T), the state after the rollout
};

/// Advantages Â_t and returns Â_t + V(s_t) (each T × N).
struct GaeResult {
  torch::Tensor advantages;
  torch::Tensor returns;
};

/// generalised advantage estimation: δ_t = r_t + γ V_next − V(s_t) with V_next = 0 where terminated,
/// final_values where truncated, V(s_{t+1}) otherwise (last_values at t = T−1); Â_t = δ_t + γλ (1 − end_t) Â_{t+1}
/// where end_t = terminated ∨ truncated.
GaeResult ComputeGae(const GaeInputs& inputs, double gamma, double lambda);

/// (a − mean(a)) / (std(a) + eps), with the unbiased standard deviation.
torch::Tensor NormalizeAdvantages(const torch::Tensor& advantages, double eps);

/// Σ mask·x / max(Σ mask, 1).
torch::Tensor MaskedMean(const torch::Tensor& x, const torch::Tensor& mask);

/// PPO's clipped surrogate, as a loss: −mean(min(ρ Â, clip(ρ, 1 − ε, 1 + ε) Â)), ρ = exp(log π − log π_old).
torch::Tensor ClippedSurrogateLoss(const torch::Tensor& log_prob, const torch::Tensor& old_log_prob,
                                   const torch::Tensor& advantages, double clip);

/// the value loss ½ mean(max((V − R)², (V_old + clip(V − V_old, ±ε) − R)²)); clip <= 0: ½ mean((V − R)²).
torch::Tensor ClippedValueLoss(const torch::Tensor& values, const torch::Tensor& old_values,
                               const torch::Tensor& returns, double clip);

/// ε in a normaliser's σ = sqrt(var + ε), shared by Normalize and the exported policy's obs_inv_std.
inline constexpr double kNormalizerEps = 1e-8;

/// Running mean and variance of vectors (parallel Welford update, in double precision).
class RunningMeanStd {
 public:
  explicit RunningMeanStd(int dim = 1);
  /// folds a batch (B × dim, or B when dim == 1) into the statistics.
  void Update(const torch::Tensor& batch);
  /// the same for the union of every rank's batch (Accumulate, then Synchronize); every rank then holds the same
  /// statistics. A null or one-rank collective is Update(batch).
  void Update(const torch::Tensor& batch, Collective* collective);
  /// data-parallel rollouts: folds a batch into the statistics and into this rank's share since the last
  /// synchronisation, without communicating (until then each rank's statistics include only its own new samples).
  void Accumulate(const torch::Tensor& batch);
  /// merges every rank's share accumulated since the last synchronisation into the statistics of that moment, so
  /// that every rank holds what one process folding all the samples would, and starts new shares; two all-reduces
  /// for all the normalisers given.
  static void Synchronize(const std::vector<RunningMeanStd*>& normalizers, Collective* collective);
  /// clamp((x − mean) / sqrt(var + 1e-8), ±clip) as float; clip <= 0: no clamp.
  torch::Tensor Normalize(const torch::Tensor& x, double clip = 0.0) const;
  /// x · sqrt(var + 1e-8) + mean, as float.
  torch::Tensor Denormalize(const torch::Tensor& x) const;
  int dim() const { return dim_; }
  const torch::Tensor& mean() const { return mean_; }
  const torch::Tensor& var() const { return var_; }
  double count() const { return count_; }
  /// replaces the statistics (sizes checked).
  void Set(const torch::Tensor& mean, const torch::Tensor& var, double count);
  void Save(TensorArchive& archive, const std::string& key) const;
  /// InputError when the stored statistics are not of this normaliser's size.
  void Load(const TensorArchive& archive, const std::string& key);
  /// from a format-1 (torch::serialize) checkpoint, for UpgradeCheckpoint only
  void Load(torch::serialize::InputArchive& archive, const std::string& key);

 private:
  void Fold(const torch::Tensor& batch);
  void MarkSynchronized();

  int dim_;
  torch::Tensor mean_, var_;  // double
  double count_ = 1e-4;
  // data-parallel: the statistics at the last synchronisation, and those of this rank's samples since
  torch::Tensor base_mean_, base_var_, share_mean_, share_var_;
  double base_count_ = 1e-4, share_count_ = 0.0;
};

/// The loss of one minibatch, as named terms.
struct LossTerms {
  torch::Tensor policy;   ///< clipped surrogate loss
  torch::Tensor value;    ///< clipped value loss
  torch::Tensor entropy;  ///< the weighted entropy bonus Σ_h c_h H_h (subtracted in total)
  torch::Tensor total;    ///< policy + value_coef · value − entropy
  // diagnostics (no gradient)
  double entropy_option = 0.0, entropy_continuous = 0.0, entropy_termination = 0.0;
  double approx_kl = 0.0;      ///< mean((ρ − 1) − log ρ)
  double clip_fraction = 0.0;  ///< share of |ρ − 1| > ε
};

/// What the loss needs for a minibatch of M env-steps with A agents each (actor rows are env-step major).
struct LossInputs {
  HeadOutputs head;               ///< the current actor on the (M·A) observations
  HeadLayout layout;
  torch::Tensor actions;          ///< (M·A) × action_size
  HeadLogProbs old_log_probs;     ///< at collection, per head (M·A)
  torch::Tensor option_mask;      ///< M·A
  torch::Tensor termination_mask; ///< M·A
  torch::Tensor continuous_mask;  ///< M·A, optional (undefined: the continuous part counts on every row)
  torch::Tensor advantages;       ///< M·A (each agent gets its env-step's advantage)
  torch::Tensor values;           ///< M, current critic output (normalised units)
  torch::Tensor old_values;       ///< M, critic output at collection (normalised with the current statistics)
  torch::Tensor returns;          ///< M, normalised with the current statistics
  /// data-parallel training: the option and termination entropies' mask sums over every rank's minibatch divided
  /// by the number of ranks, as their denominators (so that the averaged gradient is the union's); 0: this
  /// minibatch's own sums
  double option_mask_total = 0.0, termination_mask_total = 0.0;
};

/// the PPO loss: clipped surrogate on the joint (masked) log-probability, clipped value loss, entropy bonus per
/// head (option and termination entropies averaged where their mask is 1, continuous over all rows).
LossTerms ComputePpoLoss(const LossInputs& inputs, const PpoOptions& options);

/// A rollout flattened for the update: M = T·N env-steps, A agents each.
struct RolloutBatch {
  int num_agents = 1;
  torch::Tensor actor_obs;         ///< (M·A) × obs_dim, normalised as the actor saw them
  torch::Tensor critic_state;      ///< M × state_dim, normalised as the critic saw them
  torch::Tensor actions;           ///< (M·A) × action_size
  HeadLogProbs old_log_probs;      ///< per head, (M·A)
  torch::Tensor option_mask;       ///< M·A
  torch::Tensor termination_mask;  ///< M·A
  torch::Tensor continuous_mask;   ///< M·A, optional: Batch::parameters_read (undefined: all ones)
  torch::Tensor old_values;        ///< M, critic outputs at collection (normalised units of the old statistics)
  torch::Tensor returns;           ///< M
  torch::Tensor advantages;        ///< M
};

/// Averages over an update's minibatches.
struct UpdateStats {
  double policy_loss = 0.0, value_loss = 0.0;
  double entropy_option = 0.0, entropy_continuous = 0.0, entropy_termination = 0.0;
  double approx_kl = 0.0, clip_fraction = 0.0;
  double explained_variance = 0.0;  ///< 1 − Var(R − V) / Var(R) of the rollout's values
  double actor_grad_norm = 0.0, critic_grad_norm = 0.0;  ///< before clipping
  int epochs = 0;                   ///< epochs run (fewer when target_kl stopped early)
};

/// Actions and values for one batch of observations.
struct ActResult {
  SampledActions sampled;     ///< (N·A) rows
  torch::Tensor actor_obs;    ///< (N·A) × obs_dim, normalised
  torch::Tensor critic_state; ///< N × state_dim, normalised
  torch::Tensor raw_values;   ///< N, critic output (normalised units)
  torch::Tensor values;       ///< N, denormalised
};

/// The learner: shared actor, centralised critic, normalisers, Adam, and the sampling RNG.
class Ppo {
 public:
  /// builds fresh networks for `spec` (seeded: the same seed gives the same initial parameters).
  Ppo(const tasks::EnvSpec& spec, const NetworkOptions& network, const PpoOptions& options, std::uint64_t seed);

  /// normalises (optionally folding the batch into the normaliser statistics first), then samples actions
  /// (deterministic: modes) and evaluates the critic. local_obs: (N·A) × obs_dim, global_state: N × state_dim.
  ActResult Act(const torch::Tensor& local_obs, const torch::Tensor& global_state, bool update_normalizers,
                bool deterministic);
  /// denormalised critic values of raw global states (N × state_dim); statistics unchanged.
  torch::Tensor Values(const torch::Tensor& global_state);
  /// epochs of minibatch updates on `batch`; lr_scale multiplies the learning rates (the schedule).
  UpdateStats Update(const RolloutBatch& batch, double lr_scale);

  /// trains data-parallel with the other ranks of `collective` (null: alone): rank 0's parameters and normaliser
  /// statistics are broadcast now, ranks other than 0 sample from their own generator, and from here on every
  /// normaliser update, advantage normalisation and gradient step uses every rank's samples. Call after
  /// InitActorFrom, before Act. The Adam moments are not broadcast: every rank starts from a fresh optimiser or
  /// loads the same checkpoint (Trainer::Resume checks that they did).
  void SetCollective(Collective* collective);
  Collective* collective() const { return collective_; }

  /// copies the actor parameters and observation normaliser of `other` (pre-trained initialisation). Throws
  /// InputError when the observation size or head layout differ.
  void InitActorFrom(Ppo& other);

  /// the learner's whole state (networks, Adam moments, normalisers, sampling generator) under "actor/", "critic/",
  /// "optimizer/", "*_norm/", "generator".
  void Save(TensorArchive& archive) const;
  /// the state Save wrote; InputError when a tensor is missing or of another dtype or size than this learner's.
  void Load(const TensorArchive& archive);
  /// from a format-1 (torch::serialize) checkpoint, for UpgradeCheckpoint only: TorchScript's reader is not safe
  /// on untrusted files (tensor_archive.h)
  void Load(torch::serialize::InputArchive& archive);

  const tasks::EnvSpec& spec() const { return spec_; }
  const PpoOptions& options() const { return options_; }
  const NetworkOptions& network() const { return network_; }
  Actor& actor() { return actor_; }
  Critic& critic() { return critic_; }
  RunningMeanStd& obs_norm() { return obs_norm_; }
  RunningMeanStd& state_norm() { return state_norm_; }
  RunningMeanStd& value_norm() { return value_norm_; }
  torch::Generator& generator() { return generator_; }
  torch::optim::Adam& optimizer() { return *optimizer_; }
  /// the exported actor (observation normaliser folded in) for the torch-free runtime.
  control::PolicyWeights Export();

 private:
  tasks::EnvSpec spec_;
  NetworkOptions network_;
  PpoOptions options_;
  HeadLayout layout_;
  Actor actor_{nullptr};
  Critic critic_{nullptr};
  RunningMeanStd obs_norm_, state_norm_, value_norm_;
  torch::Generator generator_;
  std::unique_ptr<torch::optim::Adam> optimizer_;
  std::uint64_t seed_ = 0;
  Collective* collective_ = nullptr;  // null or one rank: no communication
  bool Distributed() const { return collective_ != nullptr && collective_->world_size() > 1; }
};

}  // namespace rmpmarl::rl
