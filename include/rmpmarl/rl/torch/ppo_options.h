#pragma once
/// Options of the learning layers (networks, PPO/MAPPO), torch-free so that the CLI and configs can use them
/// without compiling libtorch headers. Fluent setters in the style of torch's options structs:
///   `PpoOptions{}.clip(0.2).epochs(8)`; `NetworkOptions{}.actor_hidden({64, 64})`.
#include <string>
#include <vector>

/// declares a fluent option `name` of type T with default `value`: `opts.name(v)` sets it and returns *this,
/// `opts.name()` reads it.
#define RMPMARL_OPTION(T, name, ...)                         \
 public:                                                     \
  auto name(const T& new_##name)->decltype(*this) {          \
    this->name##_ = new_##name;                              \
    return *this;                                            \
  }                                                          \
  const T& name() const noexcept { return this->name##_; }   \
                                                             \
 private:                                                    \
  T name##_ = __VA_ARGS__

namespace rmpmarl::rl {

/// Hidden-layer activation of the MLPs.
enum class Activation { kRelu = 0, kTanh = 1 };

/// The actor and critic MLPs. Defaults are the paper's agent (Sec. III.C): three hidden layers of 128 units with
/// ReLU, followed by a linear output layer (the hybrid action head for the actor, a scalar for the critic).
class NetworkOptions {
  RMPMARL_OPTION(std::vector<int>, actor_hidden, {128, 128, 128});
  RMPMARL_OPTION(std::vector<int>, critic_hidden, {128, 128, 128});
  RMPMARL_OPTION(Activation, activation, Activation::kRelu);
  /// initial value of the state-independent log standard deviation of the Gaussian head.
  RMPMARL_OPTION(double, init_log_std, -0.5);
  /// orthogonal-init gain of the actor's output layer (small: near-uniform options, near-zero means at start).
  RMPMARL_OPTION(double, actor_output_gain, 0.01);
};

/// Learning-rate schedule over the run.
enum class LrSchedule { kConstant = 0, kLinear = 1 };

/// PPO (and MAPPO: the same algorithm with decentralised actors and a centralised critic) — every knob.
class PpoOptions {
  // ---- rollout and returns
  /// env steps per env per update (rollout length T).
  RMPMARL_OPTION(int, rollout_steps, 128);
  /// discount γ (eq 10/13).
  RMPMARL_OPTION(double, gamma, 0.99);
  /// GAE λ.
  RMPMARL_OPTION(double, gae_lambda, 0.95);
  // ---- the update
  RMPMARL_OPTION(int, epochs, 5);
  /// minibatches per epoch (the env-steps T·N are split; all agents of an env-step go in the same minibatch).
  RMPMARL_OPTION(int, minibatches, 4);
  /// ε of the clipped surrogate: ratio clipped to [1 − ε, 1 + ε].
  RMPMARL_OPTION(double, clip, 0.2);
  /// value-loss clip around the rollout's value prediction (in normalised units); <= 0 disables it.
  RMPMARL_OPTION(double, value_clip, 0.2);
  /// weight of the value loss in the total loss.
  RMPMARL_OPTION(double, value_coef, 0.5);
  /// entropy-bonus weights per head of the hybrid action.
  RMPMARL_OPTION(double, entropy_option, 0.01);
  RMPMARL_OPTION(double, entropy_continuous, 0.0);
  RMPMARL_OPTION(double, entropy_termination, 0.01);
  /// gradients of the actor and of the critic are each clipped to this global L2 norm; <= 0 disables it.
  RMPMARL_OPTION(double, max_grad_norm, 0.5);
  /// stop the epochs of an update early when the approximate KL exceeds 1.5 × target_kl; <= 0 disables it.
  RMPMARL_OPTION(double, target_kl, 0.0);
  // ---- optimiser
  RMPMARL_OPTION(double, lr, 3e-4);
  /// critic learning rate; <= 0: the same as lr.
  RMPMARL_OPTION(double, critic_lr, 0.0);
  RMPMARL_OPTION(LrSchedule, lr_schedule, LrSchedule::kLinear);
  /// lr at the end of the run as a fraction of lr (linear schedule).
  RMPMARL_OPTION(double, lr_final_fraction, 0.0);
  RMPMARL_OPTION(double, adam_eps, 1e-5);
  // ---- normalisation
  /// advantages normalised over the whole batch: (A − mean(A)) / (std(A) + advantage_eps).
  RMPMARL_OPTION(bool, normalize_advantage, true);
  RMPMARL_OPTION(double, advantage_eps, 1e-8);
  /// running mean/variance normalisation of local observations (actor) and global states (critic).
  RMPMARL_OPTION(bool, normalize_observations, true);
  /// normalised observations are clipped to ±obs_clip.
  RMPMARL_OPTION(double, obs_clip, 10.0);
  /// the critic predicts returns normalised by their running mean/variance (MAPPO's value normalisation).
  RMPMARL_OPTION(bool, normalize_value, true);
  // ---- speed
  /// run the networks' matrix products in bfloat16 (CPU autocast; fp32 master weights, losses and optimiser). About
  /// 4× faster on CPUs with AMX/AVX512-BF16 (oneDNN); on other CPUs, where bf16 is emulated and about 10× slower,
  /// the learner stays in fp32 (CpuHasFastBf16). The exported policy is fp32 either way.
  RMPMARL_OPTION(bool, bf16_autocast, false);
};

/// Name of an activation / schedule (as written in configs); parse throws InputError on unknown names.
std::string ToString(Activation activation);
std::string ToString(LrSchedule schedule);
Activation ParseActivation(const std::string& name);
LrSchedule ParseLrSchedule(const std::string& name);

/// true when this CPU computes bfloat16 matmuls natively (AMX-BF16 or AVX512-BF16): where bf16_autocast pays.
bool CpuHasFastBf16();

}  // namespace rmpmarl::rl
