#pragma once
/// Actor–critic networks with a hybrid action head sized from the ActionSpec (libtorch).
///
/// The actor maps one agent's local observation to the parameters of three independent distributions, one per part
/// of the flat action [option?, continuous..., terminate?] (env.h):
///   - option: Categorical(softmax(logits)), num_options logits;
///   - continuous: Normal(mean, exp(log_std)), num_continuous means and a state-independent log_std parameter;
///   - termination: Bernoulli(sigmoid(logit)), one logit when has_termination.
/// The joint log-probability of an action is the masked sum of the per-head log-probabilities (JointLogProb).
#include <torch/nn/module.h>
#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/modules/linear.h>
#include <torch/nn/pimpl.h>

#include <vector>

#include "rmpmarl/tasks/env.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/rl/torch/ppo_options.h"

namespace rmpmarl::rl {

/// Sizes of the hybrid head, read from an ActionSpec (never hard-coded).
struct HeadLayout {
  int num_options = 0;
  int num_continuous = 0;
  bool has_termination = false;

  static HeadLayout From(const tasks::ActionSpec& spec);
  /// network outputs: logits, means, termination logit.
  int outputs() const { return num_options + num_continuous + (has_termination ? 1 : 0); }
  /// floats of one flat action (env.h layout).
  int action_size() const { return (num_options > 0 ? 1 : 0) + num_continuous + (has_termination ? 1 : 0); }
  int continuous_offset() const { return num_options > 0 ? 1 : 0; }
  int termination_offset() const { return continuous_offset() + num_continuous; }
};

/// Distribution parameters of a batch of B agents' actions. Absent heads hold empty (undefined) tensors.
struct HeadOutputs {
  torch::Tensor option_logits;      ///< B × num_options
  torch::Tensor mean;               ///< B × num_continuous
  torch::Tensor log_std;            ///< num_continuous (shared by the batch)
  torch::Tensor termination_logit;  ///< B
};

/// Per-head log-probabilities (each B; zeros for an absent head).
struct HeadLogProbs {
  torch::Tensor option;
  torch::Tensor continuous;   ///< summed over the continuous dimensions
  torch::Tensor termination;
};

/// Per-head entropies (each B; zeros for an absent head).
struct HeadEntropies {
  torch::Tensor option;
  torch::Tensor continuous;   ///< summed over the continuous dimensions
  torch::Tensor termination;
};

/// A multilayer perceptron: Linear + activation per hidden layer, then a linear output layer.
class MlpImpl : public torch::nn::Module {
 public:
  /// layers in → hidden... → out (initialised by the owner: see Ppo, orthogonal with gain √2 hidden).
  MlpImpl(int in, const std::vector<int>& hidden, int out, Activation activation);
  torch::Tensor forward(const torch::Tensor& x);
  const std::vector<torch::nn::Linear>& layers() const { return layers_; }
  Activation activation() const { return activation_; }

 private:
  std::vector<torch::nn::Linear> layers_;
  Activation activation_;
};
TORCH_MODULE(Mlp);

/// The decentralised actor: one agent's local observation (already normalised) → hybrid head parameters.
/// In MAPPO its parameters are shared by all agents.
class ActorImpl : public torch::nn::Module {
 public:
  ActorImpl(int obs_dim, const HeadLayout& layout, const NetworkOptions& options);
  HeadOutputs forward(const torch::Tensor& obs);
  const HeadLayout& layout() const { return layout_; }
  int obs_dim() const { return obs_dim_; }
  Mlp& mlp() { return mlp_; }
  torch::Tensor& log_std() { return log_std_; }

 private:
  int obs_dim_;
  HeadLayout layout_;
  Mlp mlp_{nullptr};
  torch::Tensor log_std_;
};
TORCH_MODULE(Actor);

/// The critic: a state (the global state for MAPPO's centralised critic) → a scalar value (B).
class CriticImpl : public torch::nn::Module {
 public:
  CriticImpl(int state_dim, const NetworkOptions& options);
  torch::Tensor forward(const torch::Tensor& state);
  Mlp& mlp() { return mlp_; }

 private:
  Mlp mlp_{nullptr};
};
TORCH_MODULE(Critic);

/// log-probabilities of flat actions (B × action_size, env.h layout) under `head`.
HeadLogProbs LogProbs(const HeadOutputs& head, const HeadLayout& layout, const torch::Tensor& actions);
/// entropies of the head's distributions.
HeadEntropies Entropies(const HeadOutputs& head, const HeadLayout& layout);
/// joint log π(a|o) = option_mask·log p(option) + log p(continuous) + termination_mask·log p(terminate).
/// The trainer passes option_mask = StepOutput::option_started (the option index of an action is read only when
/// the agent was idle, so elsewhere it is not part of the action taken) and termination_mask = 1 (the flag of step
/// t ends the running option after step t, a decision at every step; where an env ignores it, e.g. when the option
/// ended by its own condition, counting it adds variance but no bias).
torch::Tensor JointLogProb(const HeadLogProbs& log_probs, const torch::Tensor& option_mask,
                           const torch::Tensor& termination_mask);
/// the same with the continuous part masked too: continuous_mask = StepOutput::parameters_read (an env that holds an
/// agent's RMP parameters between reads, options.parameter_period > 1, did not act on the held steps' values).
torch::Tensor JointLogProb(const HeadLogProbs& log_probs, const torch::Tensor& option_mask,
                           const torch::Tensor& continuous_mask, const torch::Tensor& termination_mask);

/// Sampled (or deterministic) flat actions and their per-head log-probabilities.
struct SampledActions {
  torch::Tensor actions;  ///< B × action_size
  HeadLogProbs log_probs;
};
/// samples actions from `head` with `generator`; deterministic: argmax option, mean, terminate iff p > 0.5.
SampledActions SampleActions(const HeadOutputs& head, const HeadLayout& layout, torch::Generator& generator,
                             bool deterministic);

/// the actor as plain arrays for the torch-free runtime (observation normaliser and action bounds supplied).
control::PolicyWeights ExportActor(Actor& actor, const Eigen::VectorXf& obs_mean, const Eigen::VectorXf& obs_inv_std,
                          float obs_clip, const tasks::ActionSpec& spec);

}  // namespace rmpmarl::rl
