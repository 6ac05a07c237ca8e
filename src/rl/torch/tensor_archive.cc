// The checkpoint payload: a key → value store with a bounds-checked reader (tensor_archive.h).
#include "rmpmarl/rl/torch/tensor_archive.h"

#include <ATen/ATen.h>
#include <fmt/format.h>

#include <cstring>
#include <limits>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rl {
namespace {

constexpr int kMaxRank = 8;

int DtypeCode(at::ScalarType t) {
  switch (t) {
    case at::kFloat: return 0;
    case at::kDouble: return 1;
    case at::kLong: return 2;
    case at::kByte: return 3;
    default: return -1;
  }
}

at::ScalarType DtypeOf(int code) {
  constexpr at::ScalarType types[] = {at::kFloat, at::kDouble, at::kLong, at::kByte};
  return types[code];
}

template <typename T>
void Append(std::string* out, T value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// reads from the archive's bytes, refusing to read past their end
class Cursor {
 public:
  Cursor(std::string_view bytes, const std::string& what) : bytes_(bytes), what_(what) {}
  template <typename T>
  T Read(const char* field) {
    T value;
    std::memcpy(&value, Take(sizeof(T), field), sizeof(T));
    return value;
  }
  const char* Take(std::uint64_t n, const char* field) {
    if (n > bytes_.size() - pos_) {
      throw InputError(fmt::format("{}: truncated: {} needs {} bytes at offset {}, only {} left", what_, field, n,
                                   pos_, bytes_.size() - pos_));
    }
    const char* p = bytes_.data() + pos_;
    pos_ += n;
    return p;
  }
  std::uint64_t left() const { return bytes_.size() - pos_; }
  std::uint64_t pos() const { return pos_; }

 private:
  std::string_view bytes_;
  const std::string& what_;
  std::uint64_t pos_ = 0;
};

}  // namespace

void TensorArchive::Put(const std::string& key, std::string value) {
  Entry e;
  e.kind = Kind::kString;
  e.text = std::move(value);
  entries_[key] = std::move(e);
}

void TensorArchive::Put(const std::string& key, std::int64_t value) {
  Entry e;
  e.kind = Kind::kInt;
  e.integer = value;
  entries_[key] = std::move(e);
}

void TensorArchive::Put(const std::string& key, const at::Tensor& value) {
  if (!value.defined() || value.device().type() != c10::DeviceType::CPU || DtypeCode(value.scalar_type()) < 0 ||
      value.dim() > kMaxRank) {
    throw InputError(fmt::format("archive key '{}': expected a CPU tensor of float32, float64, int64 or uint8 with "
                                 "at most {} dimensions", key, kMaxRank));
  }
  Entry e;
  e.kind = Kind::kTensor;
  e.tensor = value.detach().contiguous().clone();
  entries_[key] = std::move(e);
}

std::string TensorArchive::Serialize() const {
  std::string out;
  Append<std::uint64_t>(&out, entries_.size());
  for (const auto& [key, e] : entries_) {
    Append<std::uint32_t>(&out, static_cast<std::uint32_t>(key.size()));
    out += key;
    Append<std::uint8_t>(&out, static_cast<std::uint8_t>(e.kind));
    switch (e.kind) {
      case Kind::kString:
        Append<std::uint64_t>(&out, e.text.size());
        out += e.text;
        break;
      case Kind::kInt: Append<std::int64_t>(&out, e.integer); break;
      case Kind::kTensor: {
        Append<std::uint8_t>(&out, static_cast<std::uint8_t>(DtypeCode(e.tensor.scalar_type())));
        Append<std::uint8_t>(&out, static_cast<std::uint8_t>(e.tensor.dim()));
        for (std::int64_t s : e.tensor.sizes()) Append<std::int64_t>(&out, s);
        out.append(static_cast<const char*>(e.tensor.data_ptr()), e.tensor.numel() * e.tensor.element_size());
        break;
      }
    }
  }
  return out;
}

TensorArchive TensorArchive::Parse(std::string_view bytes, const std::string& what) {
  TensorArchive a;
  a.what_ = what;
  Cursor in(bytes, a.what_);
  const std::uint64_t count = in.Read<std::uint64_t>("the entry count");
  // every entry takes at least 4 + 1 + 8 bytes: a count beyond that is corrupt (and no reservation is made from it)
  if (count > in.left() / 13) {
    throw InputError(fmt::format("{}: {} entries cannot fit in {} bytes", what, count, in.left()));
  }
  for (std::uint64_t i = 0; i < count; ++i) {
    const std::uint32_t key_size = in.Read<std::uint32_t>("a key length");
    std::string key(in.Take(key_size, "a key"), key_size);
    if (a.entries_.count(key)) throw InputError(fmt::format("{}: key '{}' appears twice", what, key));
    Entry e;
    const std::uint8_t kind = in.Read<std::uint8_t>("an entry kind");
    switch (kind) {
      case 0: {
        e.kind = Kind::kString;
        const std::uint64_t n = in.Read<std::uint64_t>("a string length");
        e.text.assign(in.Take(n, "a string"), n);
        break;
      }
      case 1:
        e.kind = Kind::kInt;
        e.integer = in.Read<std::int64_t>("an integer");
        break;
      case 2: {
        e.kind = Kind::kTensor;
        const int code = in.Read<std::uint8_t>("a tensor dtype");
        const int rank = in.Read<std::uint8_t>("a tensor rank");
        if (code > 3 || rank > kMaxRank) {
          throw InputError(fmt::format("{}: key '{}': expected a tensor dtype code 0–3 and rank ≤ {}, got {} and {}",
                                       what, key, kMaxRank, code, rank));
        }
        std::vector<std::int64_t> sizes(rank);
        const std::uint64_t element = c10::elementSize(DtypeOf(code));
        std::uint64_t numel = 1;
        for (int d = 0; d < rank; ++d) {
          sizes[d] = in.Read<std::int64_t>("a tensor size");
          if (sizes[d] < 0) throw InputError(fmt::format("{}: key '{}': negative tensor size {}", what, key, sizes[d]));
          // the elements must fit in the bytes left: checked before multiplying further (no overflow)
          if (sizes[d] != 0 && numel > in.left() / element / static_cast<std::uint64_t>(sizes[d])) {
            throw InputError(fmt::format("{}: truncated: key '{}' declares more tensor data than the {} bytes left",
                                         what, key, in.left()));
          }
          numel *= static_cast<std::uint64_t>(sizes[d]);
        }
        const char* data = in.Take(numel * element, "tensor data");
        e.tensor = at::empty(sizes, at::TensorOptions().dtype(DtypeOf(code)));
        if (numel > 0) std::memcpy(e.tensor.data_ptr(), data, numel * element);
        break;
      }
      default: throw InputError(fmt::format("{}: key '{}': unknown entry kind {}", what, key, int(kind)));
    }
    a.entries_.emplace(std::move(key), std::move(e));
  }
  if (in.left() != 0) throw InputError(fmt::format("{}: {} bytes after the last entry", what, in.left()));
  return a;
}

const TensorArchive::Entry& TensorArchive::Find(const std::string& key, Kind kind) const {
  static constexpr const char* kNames[] = {"a string", "an integer", "a tensor"};
  const auto it = entries_.find(key);
  if (it == entries_.end()) throw InputError(fmt::format("{}: no key '{}'", what_, key));
  if (it->second.kind != kind) {
    throw InputError(fmt::format("{}: key '{}': expected {}, got {}", what_, key, kNames[int(kind)],
                                 kNames[int(it->second.kind)]));
  }
  return it->second;
}

const std::string& TensorArchive::String(const std::string& key) const { return Find(key, Kind::kString).text; }

std::int64_t TensorArchive::Int(const std::string& key) const { return Find(key, Kind::kInt).integer; }

at::Tensor TensorArchive::Tensor(const std::string& key) const { return Find(key, Kind::kTensor).tensor; }

at::Tensor TensorArchive::Tensor(const std::string& key, at::ScalarType dtype, c10::IntArrayRef sizes) const {
  const at::Tensor& t = Find(key, Kind::kTensor).tensor;
  if (t.scalar_type() != dtype || t.sizes() != sizes) {
    throw InputError(fmt::format("{}: key '{}': expected a {} tensor of sizes [{}], got {} [{}]", what_, key,
                                 c10::toString(dtype), fmt::join(sizes, ", "), c10::toString(t.scalar_type()),
                                 fmt::join(t.sizes(), ", ")));
  }
  return t;
}

}  // namespace rmpmarl::rl
