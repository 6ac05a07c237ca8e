// The torch-free policy runtime: the batch-1 forward pass of the shared per-joint actor.
// The AVX2/FMA kernel packs each layer's weights in blocks of 8 outputs (in × 8 floats, contiguous) so that one
// weight load feeds one FMA per agent; the portable path is plain Eigen.
#include "rmpmarl/control/policy_runtime.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>
#if defined(__x86_64__) || defined(__i386__)
#define RMPMARL_RUNTIME_X86 1
#include <immintrin.h>
#endif

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "rmpmarl/common/cpu.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::control {
namespace {

// ---------------------------------------------------------------------------------------------------------------
// AVX2/FMA kernel: y[a][o] = act(b[o] + Σ_k W[o][k] x[a][k]) for NA agents, NB blocks of 8 outputs at a time.
using KernelFn = void (*)(const float* packed, const float* bias, int in, int blocks, const float* x, int x_stride,
                          float* y, int y_stride, bool relu);

#ifdef RMPMARL_RUNTIME_X86
template <int NA, int NB>
__attribute__((target("avx2,fma"))) void DenseBlocks(const float* packed, const float* bias, int in, int ob,
                                                     const float* x, int x_stride, float* y, int y_stride,
                                                     bool relu) {
  __m256 acc[NB][NA];
  for (int j = 0; j < NB; ++j) {
    const __m256 b = _mm256_loadu_ps(bias + (ob + j) * 8);
    for (int a = 0; a < NA; ++a) acc[j][a] = b;
  }
  const float* w = packed + static_cast<std::size_t>(ob) * in * 8;
  const std::size_t block_stride = static_cast<std::size_t>(in) * 8;
  for (int k = 0; k < in; ++k) {
    __m256 wk[NB];
    for (int j = 0; j < NB; ++j) wk[j] = _mm256_loadu_ps(w + j * block_stride + k * 8);
    for (int a = 0; a < NA; ++a) {
      const __m256 xa = _mm256_broadcast_ss(x + a * x_stride + k);
      for (int j = 0; j < NB; ++j) acc[j][a] = _mm256_fmadd_ps(wk[j], xa, acc[j][a]);
    }
  }
  const __m256 zero = _mm256_setzero_ps();
  for (int j = 0; j < NB; ++j) {
    for (int a = 0; a < NA; ++a) {
      _mm256_storeu_ps(y + a * y_stride + (ob + j) * 8, relu ? _mm256_max_ps(acc[j][a], zero) : acc[j][a]);
    }
  }
}

template <int NA>
__attribute__((target("avx2,fma"))) void DenseAvx2(const float* packed, const float* bias, int in, int blocks,
                                                   const float* x, int x_stride, float* y, int y_stride, bool relu) {
  // enough independent accumulators (NA·NB ≈ 8) to cover the FMA latency, within 16 ymm registers.
  constexpr int NB = NA == 1 ? 8 : NA == 2 ? 4 : NA <= 4 ? 2 : 1;
  int ob = 0;
  for (; ob + NB <= blocks; ob += NB) DenseBlocks<NA, NB>(packed, bias, in, ob, x, x_stride, y, y_stride, relu);
  for (; ob < blocks; ++ob) DenseBlocks<NA, 1>(packed, bias, in, ob, x, x_stride, y, y_stride, relu);
}

constexpr std::array<KernelFn, 9> kKernels = {nullptr,       DenseAvx2<1>, DenseAvx2<2>, DenseAvx2<3>, DenseAvx2<4>,
                                              DenseAvx2<5>, DenseAvx2<6>, DenseAvx2<7>, DenseAvx2<8>};
#else
constexpr std::array<KernelFn, 9> kKernels = {};
#endif  // RMPMARL_RUNTIME_X86

int RoundUp8(int n) { return (n + 7) / 8 * 8; }

}  // namespace

void PolicyWeights::Validate() const {
  auto fail = [](const std::string& message) { throw InputError("policy weights: " + message); };
  if (obs_dim < 1) fail(fmt::format("obs_dim: expected >= 1, got {}", obs_dim));
  if (num_options < 0 || num_continuous < 0) {
    fail(fmt::format("head sizes: expected >= 0, got {} options and {} continuous", num_options, num_continuous));
  }
  if (head_size() < 1) fail("the head has no outputs (no options, no continuous values, no termination)");
  if (activation != 0 && activation != 1) fail(fmt::format("activation: expected 0 or 1, got {}", activation));
  int in = obs_dim;
  for (std::size_t l = 0; l <= hidden.size(); ++l) {
    const DenseLayer& layer = l < hidden.size() ? hidden[l] : head;
    if (layer.weight.cols() != in || layer.bias.size() != layer.weight.rows()) {
      fail(fmt::format("layer {}: expected weight with {} columns and bias of its rows, got {}×{} and {}", l, in,
                       layer.weight.rows(), layer.weight.cols(), layer.bias.size()));
    }
    in = static_cast<int>(layer.weight.rows());
  }
  if (head.weight.rows() != head_size()) {
    fail(fmt::format("head: expected {} outputs, got {}", head_size(), head.weight.rows()));
  }
  if (obs_mean.size() != obs_dim || obs_inv_std.size() != obs_dim) {
    fail(fmt::format("observation normaliser: expected {} values, got {} and {}", obs_dim, obs_mean.size(),
                     obs_inv_std.size()));
  }
  if (log_std.size() != num_continuous || low.size() != num_continuous || high.size() != num_continuous) {
    fail(fmt::format("log_std/low/high: expected {} values, got {}/{}/{}", num_continuous, log_std.size(),
                     low.size(), high.size()));
  }
}

// ---------------------------------------------------------------------------------------------------------------
struct PolicyRuntime::Impl {
  PolicyWeights w;
  int max_agents = 0;
  bool avx2 = false;
  // AVX2 path: per layer (hidden..., head) the packed weights and the padded bias.
  struct Packed {
    int in = 0, out = 0, blocks = 0;
    std::vector<float> weight;  // blocks × in × 8
    std::vector<float> bias;    // blocks × 8
  };
  std::vector<Packed> packed;
  int stride = 0;  // floats per agent row in the activation buffers
  std::vector<float> x, h0, h1, head_out;
  // ActWhere: the evaluated agents' observations and actions, gathered, and their indices
  std::vector<float> obs_rows, act_rows;
  std::vector<int> rows;
  // portable path
  Eigen::MatrixXf e_in, e_h0, e_h1;

  void Pack() {
    const int n = static_cast<int>(w.hidden.size()) + 1;
    packed.resize(n);
    stride = RoundUp8(w.obs_dim);
    for (int l = 0; l < n; ++l) {
      const DenseLayer& layer = l + 1 < n ? w.hidden[l] : w.head;
      Packed& p = packed[l];
      p.in = static_cast<int>(layer.weight.cols());
      p.out = static_cast<int>(layer.weight.rows());
      p.blocks = RoundUp8(p.out) / 8;
      p.weight.assign(static_cast<std::size_t>(p.blocks) * p.in * 8, 0.0f);
      p.bias.assign(static_cast<std::size_t>(p.blocks) * 8, 0.0f);
      for (int o = 0; o < p.out; ++o) {
        p.bias[o] = layer.bias[o];
        for (int k = 0; k < p.in; ++k) {
          p.weight[(static_cast<std::size_t>(o / 8) * p.in + k) * 8 + o % 8] = layer.weight(o, k);
        }
      }
      stride = std::max(stride, p.blocks * 8);
    }
    x.assign(static_cast<std::size_t>(max_agents) * stride, 0.0f);
    h0 = x;
    h1 = x;
  }

  // normalised observations into `dst` (row a at dst + a * dst_stride).
  void Normalize(const float* obs, int num_agents, float* dst, int dst_stride) const {
    const int d = w.obs_dim;
    for (int a = 0; a < num_agents; ++a) {
      for (int i = 0; i < d; ++i) {
        float v = (obs[a * d + i] - w.obs_mean[i]) * w.obs_inv_std[i];
        if (w.obs_clip > 0.0f) v = std::clamp(v, -w.obs_clip, w.obs_clip);
        dst[a * dst_stride + i] = v;
      }
    }
  }

  void HeadAvx2(const float* obs, int num_agents, float* head) {
    const bool relu = w.activation == 0;
    const int n = static_cast<int>(packed.size());
    for (int a0 = 0; a0 < num_agents; a0 += 8) {
      const int na = std::min(8, num_agents - a0);
      Normalize(obs + static_cast<std::size_t>(a0) * w.obs_dim, na, x.data(), stride);
      const float* src = x.data();
      for (int l = 0; l < n; ++l) {
        float* dst = (l % 2 == 0) ? h0.data() : h1.data();
        const Packed& p = packed[l];
        const bool last = l + 1 == n;
        kKernels[na](p.weight.data(), p.bias.data(), p.in, p.blocks, src, stride, dst, stride, relu && !last);
        if (!relu && !last) {
          for (int a = 0; a < na; ++a) {
            for (int o = 0; o < p.out; ++o) dst[a * stride + o] = std::tanh(dst[a * stride + o]);
          }
        }
        src = dst;
      }
      const int hs = w.head_size();
      for (int a = 0; a < na; ++a) std::memcpy(head + (a0 + a) * hs, src + a * stride, sizeof(float) * hs);
    }
  }

  void HeadEigen(const float* obs, int num_agents, float* head) {
    Eigen::Map<Eigen::MatrixXf> in(e_in.data(), w.obs_dim, num_agents);
    Normalize(obs, num_agents, in.data(), w.obs_dim);
    const Eigen::MatrixXf* src_owner = &e_in;
    Eigen::Index rows = w.obs_dim;
    const int n = static_cast<int>(w.hidden.size()) + 1;
    for (int l = 0; l < n; ++l) {
      const DenseLayer& layer = l + 1 < n ? w.hidden[l] : w.head;
      Eigen::MatrixXf& dst_owner = (l % 2 == 0) ? e_h0 : e_h1;
      Eigen::Map<const Eigen::MatrixXf> src(src_owner->data(), rows, num_agents);
      Eigen::Map<Eigen::MatrixXf> dst(dst_owner.data(), layer.weight.rows(), num_agents);
      dst.noalias() = layer.weight * src;
      dst.colwise() += layer.bias;
      if (l + 1 < n) {
        if (w.activation == 0) {
          dst = dst.cwiseMax(0.0f);
        } else {
          dst = dst.array().tanh();
        }
      }
      src_owner = &dst_owner;
      rows = layer.weight.rows();
    }
    std::memcpy(head, src_owner->data(), sizeof(float) * w.head_size() * num_agents);
  }
};

PolicyRuntime::PolicyRuntime(const PolicyWeights& weights, int max_agents) : impl_(std::make_unique<Impl>()) {
  weights.Validate();
  if (max_agents < 1) throw InputError(fmt::format("max_agents: expected >= 1, got {}", max_agents));
  Impl& m = *impl_;
  m.w = weights;
  m.max_agents = max_agents;
  m.avx2 = CpuHasAvx2Fma();
  m.Pack();
  int widest = weights.obs_dim;
  for (const DenseLayer& layer : weights.hidden) widest = std::max<int>(widest, layer.weight.rows());
  widest = std::max(widest, weights.head_size());
  m.e_in.setZero(weights.obs_dim, max_agents);
  m.e_h0.setZero(widest, max_agents);
  m.e_h1.setZero(widest, max_agents);
  m.head_out.assign(static_cast<std::size_t>(max_agents) * weights.head_size(), 0.0f);
  m.obs_rows.assign(static_cast<std::size_t>(max_agents) * weights.obs_dim, 0.0f);
  m.act_rows.assign(static_cast<std::size_t>(max_agents) * weights.action_size(), 0.0f);
  m.rows.assign(max_agents, 0);
}

PolicyRuntime::~PolicyRuntime() = default;
PolicyRuntime::PolicyRuntime(PolicyRuntime&&) noexcept = default;
PolicyRuntime& PolicyRuntime::operator=(PolicyRuntime&&) noexcept = default;

int PolicyRuntime::obs_dim() const { return impl_->w.obs_dim; }
int PolicyRuntime::head_size() const { return impl_->w.head_size(); }
int PolicyRuntime::action_size() const { return impl_->w.action_size(); }
int PolicyRuntime::max_agents() const { return impl_->max_agents; }
bool PolicyRuntime::uses_avx2() const { return impl_->avx2; }
void PolicyRuntime::DisableAvx2() { impl_->avx2 = false; }

void PolicyRuntime::EvaluateHead(const float* obs, int num_agents, float* head) {
  RMPMARL_ASSERT(num_agents >= 0 && num_agents <= impl_->max_agents, "PolicyRuntime: num_agents > max_agents");
  if (impl_->avx2) {
    impl_->HeadAvx2(obs, num_agents, head);
  } else {
    impl_->HeadEigen(obs, num_agents, head);
  }
}

void PolicyRuntime::Act(const float* obs, int num_agents, float* actions) {
  Impl& m = *impl_;
  EvaluateHead(obs, num_agents, m.head_out.data());
  const PolicyWeights& w = m.w;
  const int hs = w.head_size(), as = w.action_size();
  for (int a = 0; a < num_agents; ++a) {
    const float* h = m.head_out.data() + a * hs;
    float* act = actions + a * as;
    int j = 0;
    if (w.num_options > 0) {
      act[j++] = static_cast<float>(std::max_element(h, h + w.num_options) - h);
    }
    for (int c = 0; c < w.num_continuous; ++c) act[j++] = std::clamp(h[w.num_options + c], w.low[c], w.high[c]);
    if (w.has_termination) act[j++] = h[hs - 1] > 0.0f ? 1.0f : 0.0f;
  }
}

int PolicyRuntime::ActWhere(const float* obs, int num_agents, const float* read, float* actions) {
  Impl& m = *impl_;
  RMPMARL_ASSERT(num_agents >= 0 && num_agents <= m.max_agents, "PolicyRuntime: num_agents > max_agents");
  RMPMARL_ASSERT(read != nullptr || num_agents == 0, "PolicyRuntime::ActWhere: null read flags");
  int n = 0;
  for (int a = 0; a < num_agents; ++a) {
    if (read[a] != 0.0f) m.rows[n++] = a;
  }
  if (n == num_agents) {
    Act(obs, num_agents, actions);
    return n;
  }
  const int d = m.w.obs_dim, as = m.w.action_size();
  if (!m.avx2 && n > 0) {
    // Eigen's product of a batch may round a row differently from the same row alone: the whole batch, then the
    // rows asked for
    Act(obs, num_agents, m.act_rows.data());
    for (int k = 0; k < n; ++k) {
      const std::size_t offset = static_cast<std::size_t>(m.rows[k]) * as;
      std::memcpy(actions + offset, m.act_rows.data() + offset, sizeof(float) * as);
    }
    return n;
  }
  for (int k = 0; k < n; ++k) {
    std::memcpy(m.obs_rows.data() + static_cast<std::size_t>(k) * d, obs + static_cast<std::size_t>(m.rows[k]) * d,
                sizeof(float) * d);
  }
  if (n > 0) Act(m.obs_rows.data(), n, m.act_rows.data());
  for (int k = 0; k < n; ++k) {
    std::memcpy(actions + static_cast<std::size_t>(m.rows[k]) * as,
                m.act_rows.data() + static_cast<std::size_t>(k) * as, sizeof(float) * as);
  }
  return n;
}

}  // namespace rmpmarl::control
