#pragma once
/// The payload of a checkpoint (format 2): a flat key → value store of strings, integers and CPU tensors in a plain
/// length-prefixed binary layout of our own, read with every length and size checked against the bytes present.
///
/// It replaces torch::serialize archives (checkpoint format 1), whose reader runs TorchScript's importer: that
/// importer is not memory-safe on a corrupted or crafted file — fuzzing found an uncaught torch::jit::ErrorReport and
/// a SEGV in libtorch 1.13's type parser within seconds (tests/data/fuzz/checkpoint/; upstream: pytorch/pytorch
/// #77575, #179581, "TorchScript models are treated as executable code").
///
/// Layout (little-endian): u64 entry count, then per entry: u32 key length, key bytes, u8 kind, and
///   kind 0 (string):  u64 length, bytes
///   kind 1 (integer): i64
///   kind 2 (tensor):  u8 dtype (0 float32, 1 float64, 2 int64, 3 uint8), u8 rank ≤ 8, i64 sizes[rank] (≥ 0),
///                     then the elements, row-major.
#include <ATen/core/Tensor.h>
#include <c10/util/ArrayRef.h>

#include <cstdint>
#include <map>
#include <string>
#include <string_view>

namespace rmpmarl::rl {

class TensorArchive {
 public:
  /// stores `value` under `key` (replacing an earlier one).
  void Put(const std::string& key, std::string value);
  void Put(const std::string& key, std::int64_t value);
  /// a copy of `value` (any strided CPU tensor of a supported dtype; InputError otherwise).
  void Put(const std::string& key, const at::Tensor& value);

  /// the bytes of the layout above.
  std::string Serialize() const;
  /// the archive in `bytes`; InputError naming `what` for anything malformed (truncated, overlong, unknown kind or
  /// dtype, duplicate key, trailing bytes).
  static TensorArchive Parse(std::string_view bytes, const std::string& what);

  bool Has(const std::string& key) const { return entries_.count(key) != 0; }
  /// the value under `key`; InputError naming `what` and the key when it is missing or of another kind.
  const std::string& String(const std::string& key) const;
  std::int64_t Int(const std::string& key) const;
  at::Tensor Tensor(const std::string& key) const;
  /// ... and of this dtype and these sizes (InputError naming expected vs got otherwise).
  at::Tensor Tensor(const std::string& key, at::ScalarType dtype, c10::IntArrayRef sizes) const;

 private:
  enum class Kind : std::uint8_t { kString = 0, kInt = 1, kTensor = 2 };
  struct Entry {
    Kind kind = Kind::kInt;
    std::string text;
    std::int64_t integer = 0;
    at::Tensor tensor;
  };
  const Entry& Find(const std::string& key, Kind kind) const;

  std::map<std::string, Entry> entries_;
  std::string what_ = "archive";
};

}  // namespace rmpmarl::rl
