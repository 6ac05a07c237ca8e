// Networks, the hybrid action distribution and the PPO/MAPPO learner (GAE, losses, normalisers: ppo_math.cc).
#if defined(__x86_64__)
#include <cpuid.h>
#endif
#include <torch/types.h>
#include <ATen/CPUGeneratorImpl.h>
#include <ATen/autocast_mode.h>
#include <fmt/format.h>
#include <torch/nn/utils/clip_grad.h>
#include <torch/serialize.h>

#include <cmath>
#include <numbers>

#include "rmpmarl/common/error.h"
#include "rmpmarl/common/random.h"
#include "rmpmarl/rl/torch/networks.h"
#include "rmpmarl/rl/torch/ppo.h"

namespace rmpmarl::rl {
namespace {

constexpr double kLogSqrt2Pi = 0.91893853320467274178;  // ½ log 2π

// orthogonal initialisation drawn from `generator` (Saxe et al.; the QR of a Gaussian matrix, sign-corrected).
void OrthogonalInit(const torch::Tensor& weight, double gain, at::Generator& generator) {
  const int64_t rows = weight.size(0), cols = weight.size(1);
  torch::Tensor flat = at::normal(0.0, 1.0, {std::max(rows, cols), std::min(rows, cols)}, generator);
  auto [q, r] = torch::linalg_qr(flat);
  q = q * torch::sign(torch::diagonal(r)).unsqueeze(0);
  if (rows < cols) q = q.t();
  weight.copy_(q.narrow(0, 0, rows).narrow(1, 0, cols) * gain);
}

torch::Tensor ZerosLike(const torch::Tensor& batch_source) {
  return torch::zeros({batch_source.size(0)}, batch_source.options());
}

}  // namespace

bool CpuHasFastBf16() {
#if defined(__x86_64__)
  unsigned a = 0, b = 0, c = 0, d = 0;
  if (__get_cpuid_count(7, 0, &a, &b, &c, &d) == 0) return false;
  const bool amx_bf16 = (d >> 22) & 1u;  // CPUID.(7,0):EDX[22]
  const unsigned max_subleaf = a;
  bool avx512_bf16 = false;
  if (max_subleaf >= 1 && __get_cpuid_count(7, 1, &a, &b, &c, &d) != 0) avx512_bf16 = (a >> 5) & 1u;  // (7,1):EAX[5]
  return amx_bf16 || avx512_bf16;
#else
  return false;
#endif
}

namespace {

at::Generator MakeGenerator(std::uint64_t seed) { return at::make_generator<at::CPUGeneratorImpl>(seed); }

// the seed of the action-sampling generator: a one-process run's for rank 0, one of its own for every other rank
std::uint64_t SamplerSeed(std::uint64_t seed, int rank) {
  const std::uint64_t base = SplitMix64(seed ^ 0x5A3D1E);
  return rank == 0 ? base : SplitMix64(base + static_cast<std::uint64_t>(rank));
}

// PpoOptions::bf16_autocast where it pays: requested, and the CPU has native bf16 matmuls
bool Bf16Active(const PpoOptions& options) {
  static const bool fast = CpuHasFastBf16();
  return options.bf16_autocast() && fast;
}

// bfloat16 CPU autocast for the forward passes inside its scope; a no-op when off.
class Bf16Autocast {
 public:
  explicit Bf16Autocast(bool on) : on_(on) {
    if (!on_) return;
    previous_ = at::autocast::is_cpu_enabled();
    previous_dtype_ = at::autocast::get_autocast_cpu_dtype();
    at::autocast::set_cpu_enabled(true);
    at::autocast::set_autocast_cpu_dtype(at::kBFloat16);
    at::autocast::increment_nesting();
  }
  ~Bf16Autocast() {
    if (!on_) return;
    if (at::autocast::decrement_nesting() == 0) at::autocast::clear_cache();
    at::autocast::set_cpu_enabled(previous_);
    at::autocast::set_autocast_cpu_dtype(previous_dtype_);
  }
  Bf16Autocast(const Bf16Autocast&) = delete;
  Bf16Autocast& operator=(const Bf16Autocast&) = delete;

 private:
  bool on_;
  bool previous_ = false;
  at::ScalarType previous_dtype_ = at::kBFloat16;
};

// the head's tensors as float (after a bf16 forward).
HeadOutputs ToFloat(HeadOutputs h) {
  for (torch::Tensor* t : {&h.option_logits, &h.mean, &h.log_std, &h.termination_logit}) {
    if (t->defined()) *t = t->to(torch::kFloat);
  }
  return h;
}

}  // namespace

// ------------------------------------------------------------------------------------------------- networks
HeadLayout HeadLayout::From(const tasks::ActionSpec& spec) {
  if (spec.num_options < 0 || spec.num_continuous < 0) {
    throw InputError(fmt::format("action spec: expected non-negative sizes, got {} options and {} continuous",
                                 spec.num_options, spec.num_continuous));
  }
  if (static_cast<int>(spec.low.size()) != spec.num_continuous ||
      static_cast<int>(spec.high.size()) != spec.num_continuous) {
    throw InputError(fmt::format("action spec: expected {} low/high bounds, got {}/{}", spec.num_continuous,
                                 spec.low.size(), spec.high.size()));
  }
  HeadLayout layout{spec.num_options, spec.num_continuous, spec.has_termination};
  if (layout.outputs() == 0) throw InputError("action spec: the action has no part (no option, continuous, termination)");
  return layout;
}

MlpImpl::MlpImpl(int in, const std::vector<int>& hidden, int out, Activation activation)
    : activation_(activation) {
  int width = in;
  for (size_t l = 0; l <= hidden.size(); ++l) {
    const int next = l < hidden.size() ? hidden[l] : out;
    layers_.push_back(register_module(fmt::format("linear{}", l), torch::nn::Linear(width, next)));
    width = next;
  }
}

torch::Tensor MlpImpl::forward(const torch::Tensor& x) {
  torch::Tensor h = x;
  for (size_t l = 0; l < layers_.size(); ++l) {
    h = layers_[l]->forward(h);
    if (l + 1 < layers_.size()) h = activation_ == Activation::kRelu ? torch::relu(h) : torch::tanh(h);
  }
  return h;
}

namespace {

// orthogonal weights (gain √2 hidden, `output_gain` output) and zero biases.
void InitMlp(Mlp& mlp, double output_gain, at::Generator& generator) {
  torch::NoGradGuard no_grad;
  const auto& layers = mlp->layers();
  for (size_t l = 0; l < layers.size(); ++l) {
    OrthogonalInit(layers[l]->weight, l + 1 < layers.size() ? std::sqrt(2.0) : output_gain, generator);
    layers[l]->bias.zero_();
  }
}

}  // namespace

ActorImpl::ActorImpl(int obs_dim, const HeadLayout& layout, const NetworkOptions& options)
    : obs_dim_(obs_dim), layout_(layout) {
  mlp_ = register_module("mlp", Mlp(obs_dim, options.actor_hidden(), layout.outputs(), options.activation()));
  log_std_ = register_parameter("log_std", torch::full({layout.num_continuous}, options.init_log_std()));
}

HeadOutputs ActorImpl::forward(const torch::Tensor& obs) {
  const torch::Tensor out = mlp_->forward(obs);
  HeadOutputs head;
  const int K = layout_.num_options, C = layout_.num_continuous;
  if (K > 0) head.option_logits = out.narrow(1, 0, K);
  if (C > 0) {
    head.mean = out.narrow(1, K, C);
    head.log_std = log_std_;
  }
  if (layout_.has_termination) head.termination_logit = out.select(1, K + C);
  return head;
}

CriticImpl::CriticImpl(int state_dim, const NetworkOptions& options) {
  mlp_ = register_module("mlp", Mlp(state_dim, options.critic_hidden(), 1, options.activation()));
}

torch::Tensor CriticImpl::forward(const torch::Tensor& state) { return mlp_->forward(state).squeeze(1); }

HeadLogProbs LogProbs(const HeadOutputs& head, const HeadLayout& layout, const torch::Tensor& actions) {
  TORCH_CHECK(actions.dim() == 2 && actions.size(1) == layout.action_size(), "Expected actions of shape [B, ",
              layout.action_size(), "], but got ", actions.sizes());
  HeadLogProbs lp;
  const torch::Tensor zeros = ZerosLike(actions);
  lp.option = lp.continuous = lp.termination = zeros;
  if (layout.num_options > 0) {
    const torch::Tensor index = actions.select(1, 0).to(torch::kLong).unsqueeze(1);
    lp.option = torch::log_softmax(head.option_logits, 1).gather(1, index).squeeze(1);
  }
  if (layout.num_continuous > 0) {
    const torch::Tensor a = actions.narrow(1, layout.continuous_offset(), layout.num_continuous);
    const torch::Tensor z = (a - head.mean) * torch::exp(-head.log_std);
    lp.continuous = (-0.5 * z * z - head.log_std - kLogSqrt2Pi).sum(1);
  }
  if (layout.has_termination) {
    const torch::Tensor b = actions.select(1, layout.termination_offset());
    const torch::Tensor& l = head.termination_logit;
    lp.termination = b * torch::log_sigmoid(l) + (1.0 - b) * torch::log_sigmoid(-l);
  }
  return lp;
}

HeadEntropies Entropies(const HeadOutputs& head, const HeadLayout& layout) {
  const torch::Tensor& any = layout.num_options > 0 ? head.option_logits
                             : layout.num_continuous > 0 ? head.mean
                                                         : head.termination_logit.unsqueeze(1);
  HeadEntropies h;
  h.option = h.continuous = h.termination = ZerosLike(any);
  if (layout.num_options > 0) {
    const torch::Tensor log_p = torch::log_softmax(head.option_logits, 1);
    h.option = -(log_p.exp() * log_p).sum(1);
  }
  if (layout.num_continuous > 0) {
    h.continuous = (0.5 + kLogSqrt2Pi + head.log_std).sum().expand({any.size(0)});
  }
  if (layout.has_termination) {
    const torch::Tensor& l = head.termination_logit;
    const torch::Tensor p = torch::sigmoid(l);
    h.termination = -(p * torch::log_sigmoid(l) + (1.0 - p) * torch::log_sigmoid(-l));
  }
  return h;
}

torch::Tensor JointLogProb(const HeadLogProbs& lp, const torch::Tensor& option_mask,
                           const torch::Tensor& termination_mask) {
  return option_mask * lp.option + lp.continuous + termination_mask * lp.termination;
}

torch::Tensor JointLogProb(const HeadLogProbs& lp, const torch::Tensor& option_mask,
                           const torch::Tensor& continuous_mask, const torch::Tensor& termination_mask) {
  return option_mask * lp.option + continuous_mask * lp.continuous + termination_mask * lp.termination;
}

SampledActions SampleActions(const HeadOutputs& head, const HeadLayout& layout, torch::Generator& generator,
                             bool deterministic) {
  std::vector<torch::Tensor> parts;
  if (layout.num_options > 0) {
    torch::Tensor option = deterministic ? head.option_logits.argmax(1, /*keepdim=*/true)
                                         : torch::multinomial(torch::softmax(head.option_logits, 1), 1, false,
                                                              generator);
    parts.push_back(option.to(torch::kFloat));
  }
  if (layout.num_continuous > 0) {
    parts.push_back(deterministic ? head.mean
                                  : head.mean + torch::exp(head.log_std) *
                                                    at::normal(0.0, 1.0, head.mean.sizes(), generator));
  }
  if (layout.has_termination) {
    const torch::Tensor p = torch::sigmoid(head.termination_logit).unsqueeze(1);
    parts.push_back(deterministic ? (p > 0.5).to(torch::kFloat) : at::bernoulli(p, generator));
  }
  SampledActions s;
  s.actions = torch::cat(parts, 1);
  s.log_probs = LogProbs(head, layout, s.actions);
  return s;
}

control::PolicyWeights ExportActor(Actor& actor, const Eigen::VectorXf& obs_mean, const Eigen::VectorXf& obs_inv_std,
                          float obs_clip, const tasks::ActionSpec& spec) {
  control::PolicyWeights w;
  const HeadLayout& layout = actor->layout();
  w.obs_dim = actor->obs_dim();
  w.num_options = layout.num_options;
  w.num_continuous = layout.num_continuous;
  w.has_termination = layout.has_termination;
  w.activation = static_cast<int>(actor->mlp()->activation());
  auto to_layer = [](const torch::nn::Linear& linear) {
    const torch::Tensor W = linear->weight.detach().contiguous().to(torch::kFloat);
    const torch::Tensor b = linear->bias.detach().contiguous().to(torch::kFloat);
    control::DenseLayer layer;
    layer.weight = Eigen::Map<const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
        W.data_ptr<float>(), W.size(0), W.size(1));
    layer.bias = Eigen::Map<const Eigen::VectorXf>(b.data_ptr<float>(), b.size(0));
    return layer;
  };
  const auto& layers = actor->mlp()->layers();
  for (size_t l = 0; l + 1 < layers.size(); ++l) w.hidden.push_back(to_layer(layers[l]));
  w.head = to_layer(layers.back());
  w.obs_mean = obs_mean;
  w.obs_inv_std = obs_inv_std;
  w.obs_clip = obs_clip;
  const torch::Tensor log_std = actor->log_std().detach().contiguous();
  w.log_std = Eigen::Map<const Eigen::VectorXf>(log_std.data_ptr<float>(), layout.num_continuous);
  w.low = Eigen::Map<const Eigen::VectorXf>(spec.low.data(), layout.num_continuous);
  w.high = Eigen::Map<const Eigen::VectorXf>(spec.high.data(), layout.num_continuous);
  w.Validate();
  return w;
}

// ------------------------------------------------------------------------------------------------- learner
Ppo::Ppo(const tasks::EnvSpec& spec, const NetworkOptions& network, const PpoOptions& options, std::uint64_t seed)
    : spec_(spec),
      network_(network),
      options_(options),
      layout_(HeadLayout::From(spec.action)),
      obs_norm_(spec.local_obs_dim),
      state_norm_(spec.global_state_dim),
      value_norm_(1),
      generator_(MakeGenerator(SamplerSeed(seed, 0))),
      seed_(seed) {
  if (spec.local_obs_dim < 1 || spec.global_state_dim < 1 || spec.num_agents < 1) {
    throw InputError(fmt::format("env spec of task {}: expected positive obs/state dims and agents, got {}/{}/{}",
                                 spec.task, spec.local_obs_dim, spec.global_state_dim, spec.num_agents));
  }
  actor_ = Actor(spec.local_obs_dim, layout_, network);
  critic_ = Critic(spec.global_state_dim, network);
  at::Generator init = MakeGenerator(SplitMix64(seed));
  InitMlp(actor_->mlp(), network.actor_output_gain(), init);
  InitMlp(critic_->mlp(), 1.0, init);
  std::vector<torch::optim::OptimizerParamGroup> groups;
  groups.emplace_back(actor_->parameters(), std::make_unique<torch::optim::AdamOptions>(options.lr()));
  const double critic_lr = options.critic_lr() > 0.0 ? options.critic_lr() : options.lr();
  groups.emplace_back(critic_->parameters(), std::make_unique<torch::optim::AdamOptions>(critic_lr));
  optimizer_ = std::make_unique<torch::optim::Adam>(std::move(groups),
                                                    torch::optim::AdamOptions(options.lr()).eps(options.adam_eps()));
  for (auto& group : optimizer_->param_groups()) {
    static_cast<torch::optim::AdamOptions&>(group.options()).eps(options.adam_eps());
  }
}

void Ppo::SetCollective(Collective* collective) {
  collective_ = collective;
  if (!Distributed()) return;
  torch::NoGradGuard no_grad;
  // one starting point: rank 0's networks and normaliser statistics (a pre-trained actor, a loaded checkpoint)
  for (torch::Tensor p : actor_->parameters()) collective_->Broadcast(p);
  for (torch::Tensor p : critic_->parameters()) collective_->Broadcast(p);
  for (RunningMeanStd* n : {&obs_norm_, &state_norm_, &value_norm_}) {
    torch::Tensor stats = torch::cat({n->mean(), n->var(), torch::tensor({n->count()}, torch::kDouble)});
    collective_->Broadcast(stats);
    const int d = n->dim();
    n->Set(stats.slice(0, 0, d), stats.slice(0, d, 2 * d), stats[2 * d].item<double>());
  }
  // each rank samples its own actions; rank 0 keeps the generator a one-process run has
  if (collective_->rank() > 0) generator_ = MakeGenerator(SamplerSeed(seed_, collective_->rank()));
}

ActResult Ppo::Act(const torch::Tensor& local_obs, const torch::Tensor& global_state, bool update_normalizers,
                   bool deterministic) {
  torch::NoGradGuard no_grad;
  ActResult r;
  if (options_.normalize_observations()) {
    if (update_normalizers && Distributed()) {
      // each rank folds its own samples; Update merges every rank's before it learns (no communication per step)
      obs_norm_.Accumulate(local_obs);
      state_norm_.Accumulate(global_state);
    } else if (update_normalizers) {
      obs_norm_.Update(local_obs);
      state_norm_.Update(global_state);
    }
    r.actor_obs = obs_norm_.Normalize(local_obs, options_.obs_clip());
    r.critic_state = state_norm_.Normalize(global_state, options_.obs_clip());
  } else {
    r.actor_obs = local_obs.to(torch::kFloat);
    r.critic_state = global_state.to(torch::kFloat);
  }
  HeadOutputs head;
  {
    Bf16Autocast autocast(Bf16Active(options_));
    head = ToFloat(actor_->forward(r.actor_obs));
    r.raw_values = critic_->forward(r.critic_state).to(torch::kFloat);
  }
  r.sampled = SampleActions(head, layout_, generator_, deterministic);
  r.values = options_.normalize_value() ? value_norm_.Denormalize(r.raw_values) : r.raw_values;
  return r;
}

torch::Tensor Ppo::Values(const torch::Tensor& global_state) {
  torch::NoGradGuard no_grad;
  const torch::Tensor state = options_.normalize_observations() ? state_norm_.Normalize(global_state, options_.obs_clip())
                                                                : global_state.to(torch::kFloat);
  torch::Tensor raw;
  {
    Bf16Autocast autocast(Bf16Active(options_));
    raw = critic_->forward(state).to(torch::kFloat);
  }
  return options_.normalize_value() ? value_norm_.Denormalize(raw) : raw;
}

UpdateStats Ppo::Update(const RolloutBatch& batch, double lr_scale) {
  const int A = batch.num_agents;
  const int64_t M = batch.returns.size(0);
  TORCH_CHECK(batch.actor_obs.size(0) == M * A, "Expected ", M * A, " actor rows, but got ", batch.actor_obs.size(0));
  auto& groups = optimizer_->param_groups();
  const double critic_lr = options_.critic_lr() > 0.0 ? options_.critic_lr() : options_.lr();
  static_cast<torch::optim::AdamOptions&>(groups[0].options()).lr(options_.lr() * lr_scale);
  static_cast<torch::optim::AdamOptions&>(groups[1].options()).lr(critic_lr * lr_scale);

  // data-parallel: the observation normalisers of every rank become those of all the rollout's samples
  if (Distributed()) RunningMeanStd::Synchronize({&obs_norm_, &state_norm_}, collective_);
  UpdateStats stats;
  torch::Tensor returns_n, old_values_n;
  {
    torch::NoGradGuard no_grad;
    const torch::Tensor old_values = options_.normalize_value() ? value_norm_.Denormalize(batch.old_values)
                                                                : batch.old_values;
    const double var_returns = batch.returns.var().item<double>();
    stats.explained_variance =
        var_returns > 0.0 ? 1.0 - (batch.returns - old_values).var().item<double>() / var_returns : 0.0;
    if (options_.normalize_value()) {
      value_norm_.Update(batch.returns, collective_);
      returns_n = value_norm_.Normalize(batch.returns);
      old_values_n = value_norm_.Normalize(old_values);
    } else {
      returns_n = batch.returns;
      old_values_n = batch.old_values;
    }
  }
  torch::Tensor advantages = batch.advantages;
  if (options_.normalize_advantage()) {
    if (Distributed()) {
      // the union's mean and unbiased standard deviation, as NormalizeAdvantages takes them of one batch
      torch::Tensor sums = torch::stack({torch::tensor(static_cast<double>(M), torch::kDouble),
                                         advantages.sum().to(torch::kDouble)});
      collective_->AllReduceSum(sums);
      const double n = sums[0].item<double>(), mean = sums[1].item<double>() / n;
      torch::Tensor squares = (advantages.to(torch::kDouble) - mean).square().sum().reshape({1});
      collective_->AllReduceSum(squares);
      const double std = std::sqrt(squares.item<double>() / std::max(n - 1.0, 1.0));
      advantages = (advantages - mean) / (std + options_.advantage_eps());
    } else {
      advantages = NormalizeAdvantages(advantages, options_.advantage_eps());
    }
  }
  const int world = Distributed() ? collective_->world_size() : 1;
  std::vector<torch::Tensor> parameters = actor_->parameters();
  for (const torch::Tensor& p : critic_->parameters()) parameters.push_back(p);
  const torch::Tensor agent_offsets = torch::arange(A, torch::kLong);
  // the actor rows of env-steps idx: A agents each, env-step major
  auto agent_rows = [&](const torch::Tensor& idx) {
    return (idx.unsqueeze(1) * A + agent_offsets.unsqueeze(0)).reshape({-1});
  };

  const int nb = options_.minibatches();
  int minibatches_run = 0;
  for (int epoch = 0; epoch < options_.epochs(); ++epoch) {
    const torch::Tensor perm = torch::randperm(M, generator_, torch::kLong);
    double epoch_kl = 0.0;
    torch::Tensor mask_totals;  // data-parallel: each minibatch's option and termination mask sums over the ranks
    if (world > 1) {
      mask_totals = torch::zeros({nb, 2}, torch::kDouble);
      for (int b = 0; b < nb; ++b) {
        const torch::Tensor rows = agent_rows(perm.slice(0, M * b / nb, M * (b + 1) / nb));
        mask_totals[b][0] = batch.option_mask.index_select(0, rows).sum().item<double>();
        mask_totals[b][1] = batch.termination_mask.index_select(0, rows).sum().item<double>();
      }
      collective_->AllReduceSum(mask_totals);
    }
    for (int b = 0; b < nb; ++b) {
      const int64_t begin = M * b / nb, end = M * (b + 1) / nb;
      if (end <= begin) continue;
      const torch::Tensor idx = perm.slice(0, begin, end);
      const torch::Tensor rows = agent_rows(idx);
      LossInputs in;
      in.layout = layout_;
      {
        Bf16Autocast autocast(Bf16Active(options_));
        in.head = ToFloat(actor_->forward(batch.actor_obs.index_select(0, rows)));
        in.values = critic_->forward(batch.critic_state.index_select(0, idx)).to(torch::kFloat);
      }
      in.actions = batch.actions.index_select(0, rows);
      in.old_log_probs = {batch.old_log_probs.option.index_select(0, rows),
                          batch.old_log_probs.continuous.index_select(0, rows),
                          batch.old_log_probs.termination.index_select(0, rows)};
      in.option_mask = batch.option_mask.index_select(0, rows);
      in.termination_mask = batch.termination_mask.index_select(0, rows);
      if (batch.continuous_mask.defined()) in.continuous_mask = batch.continuous_mask.index_select(0, rows);
      in.advantages = advantages.index_select(0, idx).repeat_interleave(A);
      in.old_values = old_values_n.index_select(0, idx);
      in.returns = returns_n.index_select(0, idx);
      if (world > 1) {
        // the entropies' masked means over the union of the ranks' minibatches
        in.option_mask_total = std::max(mask_totals[b][0].item<double>(), 1.0) / world;
        in.termination_mask_total = std::max(mask_totals[b][1].item<double>(), 1.0) / world;
      }
      const LossTerms terms = ComputePpoLoss(in, options_);
      optimizer_->zero_grad();
      terms.total.backward();
      if (world > 1) {
        // the gradient of the union's loss: every rank's, summed in one all-reduce and divided by the ranks
        std::vector<torch::Tensor> grads;
        grads.reserve(parameters.size());
        for (const torch::Tensor& p : parameters) {
          grads.push_back(p.grad().defined() ? p.grad().reshape({-1}) : torch::zeros({p.numel()}, p.options()));
        }
        torch::Tensor flat = torch::cat(grads);
        collective_->AllReduceSum(flat);
        flat.div_(world);
        int64_t at = 0;
        for (torch::Tensor& p : parameters) {
          if (!p.grad().defined()) p.mutable_grad() = torch::zeros_like(p);
          p.mutable_grad().copy_(flat.slice(0, at, at + p.numel()).view_as(p));
          at += p.numel();
        }
      }
      const double max_norm = options_.max_grad_norm() > 0.0 ? options_.max_grad_norm() : 1e30;
      stats.actor_grad_norm += torch::nn::utils::clip_grad_norm_(actor_->parameters(), max_norm);
      stats.critic_grad_norm += torch::nn::utils::clip_grad_norm_(critic_->parameters(), max_norm);
      optimizer_->step();
      stats.policy_loss += terms.policy.item<double>();
      stats.value_loss += terms.value.item<double>();
      stats.entropy_option += terms.entropy_option;
      stats.entropy_continuous += terms.entropy_continuous;
      stats.entropy_termination += terms.entropy_termination;
      stats.approx_kl += terms.approx_kl;
      stats.clip_fraction += terms.clip_fraction;
      epoch_kl += terms.approx_kl / nb;
      ++minibatches_run;
    }
    ++stats.epochs;
    if (options_.target_kl() > 0.0 && world > 1) {
      // every rank stops at the same epoch: on the ranks' mean KL
      torch::Tensor kl = torch::tensor({epoch_kl}, torch::kDouble);
      collective_->AllReduceSum(kl);
      epoch_kl = kl.item<double>() / world;
    }
    if (options_.target_kl() > 0.0 && epoch_kl > 1.5 * options_.target_kl()) break;
  }
  const double n = std::max(minibatches_run, 1);
  for (double* v : {&stats.policy_loss, &stats.value_loss, &stats.entropy_option, &stats.entropy_continuous,
                    &stats.entropy_termination, &stats.approx_kl, &stats.clip_fraction, &stats.actor_grad_norm,
                    &stats.critic_grad_norm}) {
    *v /= n;
  }
  return stats;
}

void Ppo::InitActorFrom(Ppo& other) {
  const HeadLayout& a = layout_;
  const HeadLayout& b = other.layout_;
  if (spec_.local_obs_dim != other.spec_.local_obs_dim || a.num_options != b.num_options ||
      a.num_continuous != b.num_continuous || a.has_termination != b.has_termination ||
      network_.actor_hidden() != other.network_.actor_hidden() ||
      network_.activation() != other.network_.activation()) {
    throw InputError(fmt::format(
        "pre-trained actor does not fit: it has obs {} / options {} / continuous {} / termination {} / {} hidden "
        "layers, this task's agent needs {} / {} / {} / {} / {}",
        other.spec_.local_obs_dim, b.num_options, b.num_continuous, b.has_termination,
        other.network_.actor_hidden().size(), spec_.local_obs_dim, a.num_options, a.num_continuous,
        a.has_termination, network_.actor_hidden().size()));
  }
  torch::NoGradGuard no_grad;
  const auto src = other.actor_->parameters();
  auto dst = actor_->parameters();
  for (size_t i = 0; i < dst.size(); ++i) dst[i].copy_(src[i]);
  obs_norm_ = other.obs_norm_;
}

namespace {

void PutModule(TensorArchive& archive, const std::string& prefix, const torch::nn::Module& module) {
  for (const auto& p : module.named_parameters()) archive.Put(prefix + "/" + p.key(), p.value());
  for (const auto& b : module.named_buffers()) archive.Put(prefix + "/buffer/" + b.key(), b.value());
}

void GetModule(const TensorArchive& archive, const std::string& prefix, torch::nn::Module& module) {
  torch::NoGradGuard no_grad;
  for (auto& p : module.named_parameters()) {
    p.value().copy_(archive.Tensor(prefix + "/" + p.key(), p.value().scalar_type(), p.value().sizes()));
  }
  for (auto& b : module.named_buffers()) {
    b.value().copy_(archive.Tensor(prefix + "/buffer/" + b.key(), b.value().scalar_type(), b.value().sizes()));
  }
}

// Adam's per-parameter state (step, first and second moments), parameters numbered over the groups in order
std::string AdamKey(const torch::Tensor& p) { return c10::guts::to_string(p.unsafeGetTensorImpl()); }

void PutAdam(TensorArchive& archive, const torch::optim::Adam& optimizer) {
  std::int64_t i = 0;
  for (const auto& group : optimizer.param_groups()) {
    for (const torch::Tensor& p : group.params()) {
      const std::string key = fmt::format("optimizer/{}", i++);
      const auto it = optimizer.state().find(AdamKey(p));
      if (it == optimizer.state().end()) continue;
      const auto& s = static_cast<const torch::optim::AdamParamState&>(*it->second);
      archive.Put(key + "/step", static_cast<std::int64_t>(s.step()));
      archive.Put(key + "/exp_avg", s.exp_avg());
      archive.Put(key + "/exp_avg_sq", s.exp_avg_sq());
      if (s.max_exp_avg_sq().defined()) archive.Put(key + "/max_exp_avg_sq", s.max_exp_avg_sq());
    }
  }
  archive.Put("optimizer/parameters", i);
}

void GetAdam(const TensorArchive& archive, torch::optim::Adam& optimizer) {
  std::int64_t count = 0;
  for (const auto& group : optimizer.param_groups()) count += static_cast<std::int64_t>(group.params().size());
  if (archive.Int("optimizer/parameters") != count) {
    throw InputError(fmt::format("optimizer state for {} parameter tensors, expected {}",
                                 archive.Int("optimizer/parameters"), count));
  }
  optimizer.state().clear();
  std::int64_t i = 0;
  for (const auto& group : optimizer.param_groups()) {
    for (const torch::Tensor& p : group.params()) {
      const std::string key = fmt::format("optimizer/{}", i++);
      if (!archive.Has(key + "/step")) continue;  // a parameter Adam has not stepped yet
      auto s = std::make_unique<torch::optim::AdamParamState>();
      const std::int64_t step = archive.Int(key + "/step");
      if (step < 0) throw InputError(fmt::format("{}/step: expected >= 0, got {}", key, step));
      s->step(step);
      s->exp_avg(archive.Tensor(key + "/exp_avg", p.scalar_type(), p.sizes()).clone());
      s->exp_avg_sq(archive.Tensor(key + "/exp_avg_sq", p.scalar_type(), p.sizes()).clone());
      if (archive.Has(key + "/max_exp_avg_sq")) {
        s->max_exp_avg_sq(archive.Tensor(key + "/max_exp_avg_sq", p.scalar_type(), p.sizes()).clone());
      }
      optimizer.state()[AdamKey(p)] = std::move(s);
    }
  }
}

}  // namespace

void Ppo::Save(TensorArchive& archive) const {
  PutModule(archive, "actor", *actor_);
  PutModule(archive, "critic", *critic_);
  PutAdam(archive, *optimizer_);
  obs_norm_.Save(archive, "obs_norm");
  state_norm_.Save(archive, "state_norm");
  value_norm_.Save(archive, "value_norm");
  archive.Put("generator", generator_.get_state());
}

void Ppo::Load(const TensorArchive& archive) {
  GetModule(archive, "actor", *actor_);
  GetModule(archive, "critic", *critic_);
  GetAdam(archive, *optimizer_);
  obs_norm_.Load(archive, "obs_norm");
  state_norm_.Load(archive, "state_norm");
  value_norm_.Load(archive, "value_norm");
  const torch::Tensor current = generator_.get_state();
  generator_.set_state(archive.Tensor("generator", current.scalar_type(), current.sizes()));
}

void Ppo::Load(torch::serialize::InputArchive& archive) {
  torch::serialize::InputArchive actor, critic, optimizer;
  archive.read("actor", actor);
  archive.read("critic", critic);
  archive.read("optimizer", optimizer);
  actor_->load(actor);
  critic_->load(critic);
  optimizer_->load(optimizer);
  obs_norm_.Load(archive, "obs_norm");
  state_norm_.Load(archive, "state_norm");
  value_norm_.Load(archive, "value_norm");
  torch::Tensor state;
  archive.read("generator", state);
  generator_.set_state(state);
}

control::PolicyWeights Ppo::Export() {
  const int d = spec_.local_obs_dim;
  Eigen::VectorXf mean = Eigen::VectorXf::Zero(d), inv_std = Eigen::VectorXf::Ones(d);
  float clip = 0.0f;
  if (options_.normalize_observations()) {
    const torch::Tensor m = obs_norm_.mean().to(torch::kFloat).contiguous();
    const torch::Tensor s = torch::sqrt(obs_norm_.var() + kNormalizerEps).to(torch::kFloat).contiguous();
    for (int i = 0; i < d; ++i) {
      mean[i] = m.data_ptr<float>()[i];
      inv_std[i] = 1.0f / s.data_ptr<float>()[i];
    }
    clip = static_cast<float>(options_.obs_clip());
  }
  return ExportActor(actor_, mean, inv_std, clip, spec_.action);
}

}  // namespace rmpmarl::rl
