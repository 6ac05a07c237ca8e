// PPO's maths: GAE, advantage normalisation, masked means, running mean/variance normalisers and the clipped
// losses (the learner that uses them: learner.cc).
#include <torch/types.h>
#include <fmt/format.h>
#include <torch/serialize.h>

#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/networks.h"
#include "rmpmarl/rl/torch/ppo.h"

namespace rmpmarl::rl {

GaeResult ComputeGae(const GaeInputs& in, double gamma, double lambda) {
  TORCH_CHECK(in.rewards.dim() == 2, "Expected rewards of shape [T, N], but got ", in.rewards.sizes());
  const int64_t T = in.rewards.size(0), N = in.rewards.size(1);
  for (const auto* t : {&in.values, &in.terminated, &in.truncated, &in.final_values}) {
    TORCH_CHECK(t->sizes() == in.rewards.sizes(), "Expected GAE inputs of shape ", in.rewards.sizes(), ", but got ",
                t->sizes());
  }
  TORCH_CHECK(in.last_values.dim() == 1 && in.last_values.size(0) == N, "Expected last_values of shape [", N,
              "], but got ", in.last_values.sizes());
  const torch::Tensor r = in.rewards.to(torch::kDouble).contiguous();
  const torch::Tensor v = in.values.to(torch::kDouble).contiguous();
  const torch::Tensor term = in.terminated.to(torch::kDouble).contiguous();
  const torch::Tensor trunc = in.truncated.to(torch::kDouble).contiguous();
  const torch::Tensor fin = in.final_values.to(torch::kDouble).contiguous();
  const torch::Tensor last = in.last_values.to(torch::kDouble).contiguous();
  torch::Tensor adv = torch::zeros({T, N}, torch::kDouble);
  const double *pr = r.data_ptr<double>(), *pv = v.data_ptr<double>(), *pterm = term.data_ptr<double>(),
               *ptrunc = trunc.data_ptr<double>(), *pfin = fin.data_ptr<double>(), *plast = last.data_ptr<double>();
  double* pa = adv.data_ptr<double>();
  for (int64_t n = 0; n < N; ++n) {
    double next_adv = 0.0;
    for (int64_t t = T - 1; t >= 0; --t) {
      const int64_t i = t * N + n;
      const bool terminated = pterm[i] > 0.5, truncated = ptrunc[i] > 0.5;
      double next_value = t == T - 1 ? plast[n] : pv[i + N];
      if (truncated) next_value = pfin[i];
      if (terminated) next_value = 0.0;
      const double delta = pr[i] + gamma * next_value - pv[i];
      const double carry = (terminated || truncated) ? 0.0 : next_adv;
      pa[i] = delta + gamma * lambda * carry;
      next_adv = pa[i];
    }
  }
  GaeResult out;
  out.advantages = adv.to(torch::kFloat);
  out.returns = (adv + v).to(torch::kFloat);
  return out;
}

torch::Tensor NormalizeAdvantages(const torch::Tensor& advantages, double eps) {
  return (advantages - advantages.mean()) / (advantages.std() + eps);
}

torch::Tensor MaskedMean(const torch::Tensor& x, const torch::Tensor& mask) {
  return (x * mask).sum() / torch::clamp_min(mask.sum(), 1.0);
}

torch::Tensor ClippedSurrogateLoss(const torch::Tensor& log_prob, const torch::Tensor& old_log_prob,
                                   const torch::Tensor& advantages, double clip) {
  const torch::Tensor ratio = torch::exp(log_prob - old_log_prob);
  const torch::Tensor unclipped = ratio * advantages;
  const torch::Tensor clipped = torch::clamp(ratio, 1.0 - clip, 1.0 + clip) * advantages;
  return -torch::min(unclipped, clipped).mean();
}

torch::Tensor ClippedValueLoss(const torch::Tensor& values, const torch::Tensor& old_values,
                               const torch::Tensor& returns, double clip) {
  const torch::Tensor error = (values - returns).pow(2);
  if (clip <= 0.0) return 0.5 * error.mean();
  const torch::Tensor clipped = old_values + torch::clamp(values - old_values, -clip, clip);
  return 0.5 * torch::max(error, (clipped - returns).pow(2)).mean();
}

namespace {

// the parallel update of the statistics (mean, var, count) of a set with those of n more samples: their mean b_mean
// and their summed squared deviations from it b_m2 (Chan, Golub & LeVeque)
void MergeMoments(torch::Tensor& mean, torch::Tensor& var, double& count, double n, const torch::Tensor& b_mean,
                  const torch::Tensor& b_m2) {
  const torch::Tensor delta = b_mean - mean;
  const double total = count + n;
  mean = mean + delta * (n / total);
  var = (var * count + b_m2 + delta * delta * (count * n / total)) / total;
  count = total;
}

}  // namespace

RunningMeanStd::RunningMeanStd(int dim)
    : dim_(dim), mean_(torch::zeros({dim}, torch::kDouble)), var_(torch::ones({dim}, torch::kDouble)) {
  MarkSynchronized();
}

void RunningMeanStd::MarkSynchronized() {
  base_mean_ = mean_;
  base_var_ = var_;
  base_count_ = count_;
  share_mean_ = torch::zeros({dim_}, torch::kDouble);
  share_var_ = torch::zeros({dim_}, torch::kDouble);
  share_count_ = 0.0;
}

void RunningMeanStd::Update(const torch::Tensor& batch) {
  Fold(batch);
  MarkSynchronized();
}

void RunningMeanStd::Accumulate(const torch::Tensor& batch) {
  Fold(batch);
  const torch::Tensor x = batch.reshape({-1, dim_}).to(torch::kDouble);
  const double n = static_cast<double>(x.size(0));
  if (n == 0) return;
  MergeMoments(share_mean_, share_var_, share_count_, n, x.mean(0), x.var(0, /*unbiased=*/false) * n);
}

void RunningMeanStd::Synchronize(const std::vector<RunningMeanStd*>& normalizers, Collective* collective) {
  if (collective == nullptr || collective->world_size() == 1) {
    for (RunningMeanStd* n : normalizers) n->MarkSynchronized();
    return;
  }
  // the union's count and mean, then its squared deviations from that mean: one all-reduce each for them all
  std::vector<torch::Tensor> parts;
  for (RunningMeanStd* n : normalizers) {
    parts.push_back(torch::tensor({n->share_count_}, torch::kDouble));
    parts.push_back(n->share_mean_ * n->share_count_);
  }
  torch::Tensor sums = torch::cat(parts);
  collective->AllReduceSum(sums);
  std::vector<double> counts;
  std::vector<torch::Tensor> means;
  parts.clear();
  int64_t at = 0;
  for (RunningMeanStd* n : normalizers) {
    const double count = sums[at].item<double>();
    const torch::Tensor mean = count > 0 ? sums.slice(0, at + 1, at + 1 + n->dim_) / count
                                         : torch::zeros({n->dim_}, torch::kDouble);
    at += 1 + n->dim_;
    counts.push_back(count);
    means.push_back(mean);
    parts.push_back((n->share_var_ + (n->share_mean_ - mean).square()) * n->share_count_);
  }
  torch::Tensor m2 = torch::cat(parts);
  collective->AllReduceSum(m2);
  at = 0;
  for (size_t k = 0; k < normalizers.size(); ++k) {
    RunningMeanStd& n = *normalizers[k];
    const torch::Tensor share_m2 = m2.slice(0, at, at + n.dim_);
    at += n.dim_;
    if (counts[k] > 0) {
      // the statistics of the last synchronisation with every rank's share folded in
      n.mean_ = n.base_mean_;
      n.var_ = n.base_var_;
      n.count_ = n.base_count_;
      MergeMoments(n.mean_, n.var_, n.count_, counts[k], means[k], share_m2);
    }
    n.MarkSynchronized();
  }
}

void RunningMeanStd::Fold(const torch::Tensor& batch) {
  const torch::Tensor x = batch.reshape({-1, dim_}).to(torch::kDouble);
  const double n = static_cast<double>(x.size(0));
  if (n == 0) return;
  MergeMoments(mean_, var_, count_, n, x.mean(0), x.var(0, /*unbiased=*/false) * n);
}

void RunningMeanStd::Set(const torch::Tensor& mean, const torch::Tensor& var, double count) {
  TORCH_CHECK(mean.numel() == dim_ && var.numel() == dim_, "Expected normaliser statistics of size ", dim_, ", but got ",
              mean.numel(), " and ", var.numel());
  mean_ = mean.to(torch::kDouble).reshape({dim_}).clone();
  var_ = var.to(torch::kDouble).reshape({dim_}).clone();
  count_ = count;
  MarkSynchronized();
}

void RunningMeanStd::Update(const torch::Tensor& batch, Collective* collective) {
  if (collective == nullptr || collective->world_size() == 1) return Update(batch);
  Accumulate(batch);
  Synchronize({this}, collective);
}

torch::Tensor RunningMeanStd::Normalize(const torch::Tensor& x, double clip) const {
  const torch::Tensor mean = mean_.to(torch::kFloat), std = torch::sqrt(var_ + kNormalizerEps).to(torch::kFloat);
  torch::Tensor y = (x.to(torch::kFloat) - mean) / std;
  if (dim_ == 1 && x.dim() == 1) y = y.reshape({-1});
  return clip > 0.0 ? torch::clamp(y, -clip, clip) : y;
}

torch::Tensor RunningMeanStd::Denormalize(const torch::Tensor& x) const {
  const torch::Tensor mean = mean_.to(torch::kFloat), std = torch::sqrt(var_ + kNormalizerEps).to(torch::kFloat);
  torch::Tensor y = x.to(torch::kFloat) * std + mean;
  if (dim_ == 1 && x.dim() == 1) y = y.reshape({-1});
  return y;
}

void RunningMeanStd::Save(TensorArchive& archive, const std::string& key) const {
  archive.Put(key + "/mean", mean_);
  archive.Put(key + "/var", var_);
  archive.Put(key + "/count", torch::tensor({count_}, torch::kDouble));
}

void RunningMeanStd::Load(const TensorArchive& archive, const std::string& key) {
  mean_ = archive.Tensor(key + "/mean", torch::kDouble, {dim_}).clone();
  var_ = archive.Tensor(key + "/var", torch::kDouble, {dim_}).clone();
  count_ = archive.Tensor(key + "/count", torch::kDouble, {1}).item<double>();
  if (!std::isfinite(count_) || count_ < 0.0 || !torch::isfinite(mean_).all().item<bool>() ||
      !(var_ >= 0.0).all().item<bool>()) {
    throw InputError(fmt::format("normaliser {}: expected finite statistics with var >= 0 and count >= 0", key));
  }
  MarkSynchronized();
}

void RunningMeanStd::Load(torch::serialize::InputArchive& archive, const std::string& key) {
  torch::Tensor mean, var, count;
  archive.read(key + "/mean", mean);
  archive.read(key + "/var", var);
  archive.read(key + "/count", count);
  TORCH_CHECK(mean.numel() == dim_ && var.numel() == dim_, "Expected normaliser ", key, " of size ", dim_,
              ", but got ", mean.numel());
  mean_ = mean.to(torch::kDouble).reshape({dim_});
  var_ = var.to(torch::kDouble).reshape({dim_});
  count_ = count.item<double>();
  MarkSynchronized();
}

LossTerms ComputePpoLoss(const LossInputs& in, const PpoOptions& options) {
  const HeadLogProbs lp = LogProbs(in.head, in.layout, in.actions);
  // the continuous part counts where the env read it (all rows when no mask is given)
  const torch::Tensor joint = in.continuous_mask.defined()
                                  ? JointLogProb(lp, in.option_mask, in.continuous_mask, in.termination_mask)
                                  : JointLogProb(lp, in.option_mask, in.termination_mask);
  const torch::Tensor old_joint =
      in.continuous_mask.defined()
          ? JointLogProb(in.old_log_probs, in.option_mask, in.continuous_mask, in.termination_mask)
          : JointLogProb(in.old_log_probs, in.option_mask, in.termination_mask);
  LossTerms terms;
  terms.policy = ClippedSurrogateLoss(joint, old_joint, in.advantages, options.clip());
  terms.value = ClippedValueLoss(in.values, in.old_values, in.returns, options.value_clip());
  const HeadEntropies h = Entropies(in.head, in.layout);
  // data-parallel: the denominators of every rank's minibatch (see LossInputs)
  const torch::Tensor h_option = in.option_mask_total > 0.0 ? (h.option * in.option_mask).sum() / in.option_mask_total
                                                             : MaskedMean(h.option, in.option_mask);
  const torch::Tensor h_continuous = h.continuous.mean();
  const torch::Tensor h_termination = in.termination_mask_total > 0.0
                                          ? (h.termination * in.termination_mask).sum() / in.termination_mask_total
                                          : MaskedMean(h.termination, in.termination_mask);
  terms.entropy = options.entropy_option() * h_option + options.entropy_continuous() * h_continuous +
                  options.entropy_termination() * h_termination;
  terms.total = terms.policy + options.value_coef() * terms.value - terms.entropy;
  torch::NoGradGuard no_grad;
  const torch::Tensor log_ratio = joint - old_joint;
  const torch::Tensor ratio = torch::exp(log_ratio);
  terms.entropy_option = h_option.item<double>();
  terms.entropy_continuous = h_continuous.item<double>();
  terms.entropy_termination = h_termination.item<double>();
  terms.approx_kl = ((ratio - 1.0) - log_ratio).mean().item<double>();
  terms.clip_fraction = ((ratio - 1.0).abs() > options.clip()).to(torch::kFloat).mean().item<double>();
  return terms;
}

}  // namespace rmpmarl::rl
