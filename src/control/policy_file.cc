// Controller files (.rmpp, format 2): the actor's weights, the task the controller runs on and its provenance, in one
// checksummed file.
#include "rmpmarl/control/policy_file.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::control {
namespace {

static_assert(std::endian::native == std::endian::little, "the policy file format is little-endian");

constexpr char kMagic[8] = {'R', 'M', 'P', 'M', 'P', 'O', 'L', '\0'};
constexpr int kMaxDim = 1 << 16;
constexpr std::uint32_t kMaxText = 1u << 20;  // task and provenance texts

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
  /// a length-prefixed UTF-8 text of at most kMaxText bytes.
  std::string Text(const char* what) {
    const std::uint32_t n = U32(what);
    if (n > kMaxText) {
      throw InputError(fmt::format("policy file {}: {}: expected at most {} bytes, got {}", path_, what, kMaxText, n));
    }
    std::string s(n, '\0');
    Raw(s.data(), n, what);
    return s;
  }
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

// throws unless `text` is empty or a YAML mapping.
void CheckMapping(const std::string& text, const std::string& what, const std::string& path) {
  if (text.empty()) return;
  const YAML::Node node = rmpmarl::internal::LoadYamlText(text, path + ": " + what);
  if (!node.IsMap()) throw InputError(fmt::format("policy file {}: {}: expected a YAML mapping", path, what));
}

void WriteWeights(Writer& w, const PolicyWeights& weights) {
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
}

PolicyWeights ReadWeights(Reader& r) {
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
  return p;
}

// reads and checks a file of format `want`: magic, version, checksum; then the contents.
PolicyFile ReadFile(const std::string& path, std::uint32_t want) {
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
  if (version == 1 && want == 2) {
    throw InputError(fmt::format(
        "policy file {}: format 1 holds the network alone (its basic layer and provenance lived in a YAML beside "
        "it), this version reads format 2, which carries them. Upgrade it once: `rmpmarl policy upgrade {} --task "
        "TASK --out NEW.rmpp` (reads the YAML card beside it when there is one)", path, path));
  }
  if (version == 2 && want == 1) {
    throw InputError(fmt::format("policy file {}: already format 2 (network, basic layer and provenance in one "
                                 "file): nothing to upgrade; `rmpmarl policy show {}` prints its card", path, path));
  }
  if (version != want) {
    throw InputError(fmt::format("policy file {}: format version {} is not supported (expected {})", path, version,
                                 want));
  }
  std::uint32_t stored_crc;
  std::memcpy(&stored_crc, bytes.data() + bytes.size() - 4, 4);
  const std::uint32_t crc = Crc32c(bytes.data(), bytes.size() - 4);
  if (crc != stored_crc) {
    throw InputError(fmt::format("policy file {} is corrupt: checksum mismatch (stored crc32c {:08x}, computed "
                                 "{:08x})", path, stored_crc, crc));
  }
  PolicyFile file;
  file.weights = ReadWeights(r);
  if (version >= 2) {
    file.task_yaml = r.Text("task");
    file.provenance_yaml = r.Text("provenance");
  }
  if (r.position() != bytes.size() - 4) {
    throw InputError(fmt::format("policy file {}: {} unexpected bytes after the {}", path,
                                 bytes.size() - 4 - r.position(), version >= 2 ? "provenance" : "weights"));
  }
  file.weights.Validate();
  CheckMapping(file.task_yaml, "task", path);
  CheckMapping(file.provenance_yaml, "provenance", path);
  return file;
}

}  // namespace

std::uint32_t Crc32c(const void* data, std::size_t size, std::uint32_t crc) {
  const auto* p = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = kCrcTable[(crc ^ p[i]) & 0xFF] ^ (crc >> 8);
  return ~crc;
}

void SavePolicyFile(const PolicyFile& file, const std::string& path) {
  file.weights.Validate();
  CheckMapping(file.task_yaml, "task", path);
  CheckMapping(file.provenance_yaml, "provenance", path);
  for (const std::string* text : {&file.task_yaml, &file.provenance_yaml}) {
    if (text->size() > kMaxText) {
      throw InputError(fmt::format("policy file {}: a task or provenance text of {} bytes (at most {})", path,
                                   text->size(), kMaxText));
    }
  }
  Writer w;
  w.Raw(kMagic, sizeof(kMagic));
  w.U32(kPolicyFormatVersion);
  WriteWeights(w, file.weights);
  for (const std::string* text : {&file.task_yaml, &file.provenance_yaml}) {
    w.U32(static_cast<std::uint32_t>(text->size()));
    w.Raw(text->data(), text->size());
  }
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

PolicyFile LoadPolicyFile(const std::string& path) { return ReadFile(path, kPolicyFormatVersion); }

PolicyWeights LoadPolicyFileV1(const std::string& path) { return ReadFile(path, 1).weights; }

AgentConfig PolicyAgentConfig(const PolicyFile& file, const std::string& path) {
  if (!file.has_task()) {
    throw InputError(fmt::format("policy file {} carries no task (a policy of a task outside the manipulator "
                                 "tasks), so it builds no controller", path));
  }
  return ParseAgentConfig(file.task_yaml, path + " (its task)");
}

}  // namespace rmpmarl::control
