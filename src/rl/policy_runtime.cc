// The torch-free policy runtime: policy-file I/O and the batch-1 forward pass of the shared per-joint actor.
// The AVX2/FMA kernel packs each layer's weights in blocks of 8 outputs (in × 8 floats, contiguous) so that one
// weight load feeds one FMA per agent; the portable path is plain Eigen.
#include "rmpmarl/rl/policy_runtime.h"

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

#include "rmpmarl/common/error.h"

namespace rmpmarl::rl {
namespace {

static_assert(std::endian::native == std::endian::little, "the policy file format is little-endian");

constexpr char kMagic[8] = {'R', 'M', 'P', 'M', 'P', 'O', 'L', '\0'};
constexpr std::uint32_t kVersion = 1;
constexpr int kMaxDim = 1 << 16;

// the CRC-32C table for the reflected polynomial 0x82F63B78.
constexpr std::array<std::uint32_t, 256> MakeCrcTable() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1) ? (c >> 1) ^ 0x82F63B78u : c >> 1;
    table[i] = c;
  }
  return table;
}
constexpr std::array<std::uint32_t, 256> kCrcTable = MakeCrcTable();

// appends plain values to a byte buffer.
class Writer {
 public:
  void U32(std::uint32_t v) { Raw(&v, 4); }
  void F32(float v) { Raw(&v, 4); }
  void Floats(const float* v, Eigen::Index n) { Raw(v, static_cast<std::size_t>(n) * 4); }
  void Raw(const void* p, std::size_t n) {
    const auto* c = static_cast<const char*>(p);
    bytes.insert(bytes.end(), c, c + n);
  }
  std::vector<char> bytes;
};

// reads plain values from a byte buffer; running past the end throws InputError naming the file.
class Reader {
 public:
  Reader(const std::vector<char>& bytes, std::size_t end, const std::string& path)
      : bytes_(bytes), end_(end), path_(path) {}
  std::uint32_t U32(const char* what) {
    std::uint32_t v;
    Raw(&v, 4, what);
    return v;
  }
  float F32(const char* what) {
    float v;
    Raw(&v, 4, what);
    return v;
  }
  int Dim(const char* what, int min = 0) {
    const std::uint32_t v = U32(what);
    if (v > static_cast<std::uint32_t>(kMaxDim) || static_cast<int>(v) < min) {
      throw InputError(fmt::format("policy file {}: {}: expected {}..{}, got {}", path_, what, min, kMaxDim, v));
    }
    return static_cast<int>(v);
  }
  void Floats(float* v, Eigen::Index n, const char* what) { Raw(v, static_cast<std::size_t>(n) * 4, what); }
  std::size_t position() const { return pos_; }

 private:
  void Raw(void* p, std::size_t n, const char* what) {
    if (pos_ + n > end_) {
      throw InputError(fmt::format("policy file {} is truncated: reading {} needs {} bytes at offset {}, the payload "
                                   "has {}", path_, what, n, pos_, end_));
    }
    if (n > 0) std::memcpy(p, bytes_.data() + pos_, n);  // p may be null for an empty array (found by fuzzing)
    pos_ += n;
  }
  const std::vector<char>& bytes_;
  std::size_t end_;
  const std::string& path_;
  std::size_t pos_ = 0;
};

void ReadLayer(Reader& r, int in, int out, DenseLayer* layer) {
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> w(out, in);
  r.Floats(w.data(), w.size(), "layer weight");
  layer->weight = w;
  layer->bias.resize(out);
  r.Floats(layer->bias.data(), out, "layer bias");
}

void WriteLayer(Writer& w, const DenseLayer& layer) {
  const Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> rm = layer.weight;
  w.Floats(rm.data(), rm.size());
  w.Floats(layer.bias.data(), layer.bias.size());
}

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

bool CpuHasAvx2() {
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
}
#else
constexpr std::array<KernelFn, 9> kKernels = {};
bool CpuHasAvx2() { return false; }
#endif  // RMPMARL_RUNTIME_X86

int RoundUp8(int n) { return (n + 7) / 8 * 8; }

}  // namespace

std::uint32_t Crc32c(const void* data, std::size_t size, std::uint32_t crc) {
  const auto* p = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = kCrcTable[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

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

void SavePolicyFile(const PolicyWeights& weights, const std::string& path) {
  weights.Validate();
  Writer w;
  w.Raw(kMagic, sizeof(kMagic));
  w.U32(kVersion);
  w.U32(weights.obs_dim);
  w.U32(weights.num_options);
  w.U32(weights.num_continuous);
  w.U32(weights.has_termination ? 1 : 0);
  w.U32(weights.activation);
  w.U32(static_cast<std::uint32_t>(weights.hidden.size()));
  for (const DenseLayer& layer : weights.hidden) w.U32(static_cast<std::uint32_t>(layer.weight.rows()));
  w.F32(weights.obs_clip);
  w.Floats(weights.obs_mean.data(), weights.obs_mean.size());
  w.Floats(weights.obs_inv_std.data(), weights.obs_inv_std.size());
  for (const DenseLayer& layer : weights.hidden) WriteLayer(w, layer);
  WriteLayer(w, weights.head);
  w.Floats(weights.log_std.data(), weights.log_std.size());
  w.Floats(weights.low.data(), weights.low.size());
  w.Floats(weights.high.data(), weights.high.size());
  w.U32(Crc32c(w.bytes.data(), w.bytes.size()));

  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out.write(w.bytes.data(), static_cast<std::streamsize>(w.bytes.size()));
    out.flush();
    if (!out) throw InputError(fmt::format("policy file {}: cannot write {}", path, tmp));
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw InputError(fmt::format("policy file {}: cannot rename {} into place", path, tmp));
  }
}

PolicyWeights LoadPolicyFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("policy file {}: cannot open it", path));
  const std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < sizeof(kMagic) + 8 || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    throw InputError(fmt::format("policy file {}: not an rmpmarl policy file (expected magic \"RMPMPOL\")", path));
  }
  Reader r(bytes, bytes.size() - 4, path);
  r.U32("magic[0:4]");  // checked above
  r.U32("magic[4:8]");
  const std::uint32_t version = r.U32("version");
  if (version != kVersion) {
    throw InputError(fmt::format("policy file {}: format version {} is not supported (expected {})", path, version,
                                 kVersion));
  }
  std::uint32_t stored_crc;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  const std::uint32_t crc = Crc32c(bytes.data(), bytes.size() - 4);
  if (crc != stored_crc) {
    throw InputError(fmt::format("policy file {} is corrupt: checksum mismatch (stored crc32c {:08x}, computed "
                                 "{:08x})", path, stored_crc, crc));
  }
  PolicyWeights p;
  p.obs_dim = r.Dim("obs_dim", 1);
  p.num_options = r.Dim("num_options");
  p.num_continuous = r.Dim("num_continuous");
  p.has_termination = r.Dim("has_termination") != 0;
  p.activation = r.Dim("activation");
  const int num_hidden = r.Dim("num_hidden");
  std::vector<int> sizes(num_hidden);
  for (int& s : sizes) s = r.Dim("hidden size", 1);
  p.obs_clip = r.F32("obs_clip");
  p.obs_mean.resize(p.obs_dim);
  p.obs_inv_std.resize(p.obs_dim);
  r.Floats(p.obs_mean.data(), p.obs_dim, "obs_mean");
  r.Floats(p.obs_inv_std.data(), p.obs_dim, "obs_inv_std");
  int in_dim = p.obs_dim;
  p.hidden.resize(num_hidden);
  for (int l = 0; l < num_hidden; ++l) {
    ReadLayer(r, in_dim, sizes[l], &p.hidden[l]);
    in_dim = sizes[l];
  }
  ReadLayer(r, in_dim, p.head_size(), &p.head);
  for (Eigen::VectorXf* v : {&p.log_std, &p.low, &p.high}) {
    v->resize(p.num_continuous);
    r.Floats(v->data(), p.num_continuous, "log_std/low/high");
  }
  if (r.position() != bytes.size() - 4) {
    throw InputError(fmt::format("policy file {}: {} unexpected bytes after the weights", path,
                                 bytes.size() - 4 - r.position()));
  }
  p.Validate();
  return p;
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
  m.avx2 = CpuHasAvx2();
  m.Pack();
  int widest = weights.obs_dim;
  for (const DenseLayer& layer : weights.hidden) widest = std::max<int>(widest, layer.weight.rows());
  widest = std::max(widest, weights.head_size());
  m.e_in.setZero(weights.obs_dim, max_agents);
  m.e_h0.setZero(widest, max_agents);
  m.e_h1.setZero(widest, max_agents);
  m.head_out.assign(static_cast<std::size_t>(max_agents) * weights.head_size(), 0.0f);
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

std::string LoadPolicyTaskOverrides(const std::string& policy_path) {
  const std::filesystem::path yaml_path = std::filesystem::path(policy_path).replace_extension(".yaml");
  if (!std::filesystem::exists(yaml_path)) return "";
  YAML::Node root;
  try {
    root = YAML::LoadFile(yaml_path.string());
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", yaml_path.string(), e.mark.line + 1, e.msg));
  }
  if (!root.IsMap()) {
    throw InputError(fmt::format("{}: expected a YAML mapping beside the policy file", yaml_path.string()));
  }
  const YAML::Node overrides = root["task_overrides"];
  if (!overrides) return "";
  if (!overrides.IsScalar()) {
    throw InputError(fmt::format("{}: key 'task_overrides': expected a string holding a YAML mapping, e.g. "
                                 "\"{{controller: {{max_substep: 0.002}}}}\"", yaml_path.string()));
  }
  return overrides.Scalar();
}

}  // namespace rmpmarl::rl
