// The checkpoint payload (TensorArchive): round trip, every truncation and byte flip ends in a parsed archive or an
// InputError, declared sizes are checked before anything is allocated; format-1 checkpoints are refused by the
// readers and converted by UpgradeCheckpoint without changing the policy.
#include "rmpmarl/rl/torch/tensor_archive.h"

#include <gtest/gtest.h>
#include <torch/torch.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/trainer.h"

namespace rmpmarl::rl {
namespace {

namespace fs = std::filesystem;

TensorArchive Sample() {
  TensorArchive a;
  a.Put("meta/name", std::string("toy\0with nul", 12));
  a.Put("meta/count", std::int64_t{-42});
  a.Put("w/float", torch::arange(6, torch::kFloat).reshape({2, 3}));
  a.Put("w/double", torch::tensor({1.5, -2.25}, torch::kDouble));
  a.Put("w/long", torch::tensor(std::int64_t{7}));  // rank 0
  a.Put("w/bytes", torch::full({5}, 200, torch::kByte));
  a.Put("w/empty", torch::zeros({0, 3}, torch::kFloat));
  a.Put("w/strided", torch::arange(12, torch::kDouble).reshape({3, 4}).t());  // not contiguous
  return a;
}

TEST(TensorArchiveTest, RoundTripKeepsEveryValue) {
  const TensorArchive a = TensorArchive::Parse(Sample().Serialize(), "sample");
  EXPECT_EQ(a.String("meta/name"), std::string("toy\0with nul", 12));
  EXPECT_EQ(a.Int("meta/count"), -42);
  EXPECT_TRUE(torch::equal(a.Tensor("w/float", torch::kFloat, {2, 3}), torch::arange(6, torch::kFloat).reshape({2, 3})));
  EXPECT_TRUE(torch::equal(a.Tensor("w/double"), torch::tensor({1.5, -2.25}, torch::kDouble)));
  EXPECT_EQ(a.Tensor("w/long").dim(), 0);
  EXPECT_EQ(a.Tensor("w/long").item<std::int64_t>(), 7);
  EXPECT_TRUE(torch::equal(a.Tensor("w/bytes"), torch::full({5}, 200, torch::kByte)));
  EXPECT_EQ(a.Tensor("w/empty").sizes(), (std::vector<std::int64_t>{0, 3}));
  EXPECT_TRUE(torch::equal(a.Tensor("w/strided"), torch::arange(12, torch::kDouble).reshape({3, 4}).t()));
  EXPECT_EQ(Sample().Serialize(), a.Serialize());  // deterministic bytes
}

TEST(TensorArchiveTest, WrongKeysKindsDtypesAndSizesAreInputErrors) {
  const TensorArchive a = TensorArchive::Parse(Sample().Serialize(), "sample.ckpt");
  auto message = [](auto&& f) {
    try {
      f();
    } catch (const InputError& e) {
      return std::string(e.what());
    }
    return std::string("no InputError");
  };
  EXPECT_NE(message([&] { a.Int("missing"); }).find("sample.ckpt: no key 'missing'"), std::string::npos);
  EXPECT_NE(message([&] { a.Int("meta/name"); }).find("expected an integer, got a string"), std::string::npos);
  EXPECT_NE(message([&] { a.Tensor("w/float", torch::kDouble, {2, 3}); }).find("expected a Double tensor of sizes [2, 3]"),
            std::string::npos);
  EXPECT_NE(message([&] { a.Tensor("w/float", torch::kFloat, {3, 2}); }).find("got Float [2, 3]"), std::string::npos);
  TensorArchive b;
  EXPECT_THROW(b.Put("half", torch::zeros({2}, torch::kHalf)), InputError);
  EXPECT_THROW(b.Put("undefined", torch::Tensor()), InputError);
}

// every prefix of a valid archive, and every single-byte change of it, ends parsed or in an InputError
TEST(TensorArchiveTest, TruncationsAndByteFlipsEndInAnArchiveOrAnInputError) {
  const std::string bytes = Sample().Serialize();
  int refused = 0;
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    EXPECT_THROW(TensorArchive::Parse(std::string_view(bytes).substr(0, n), "prefix"), InputError) << n;
  }
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    for (unsigned char x : {0x01, 0x80, 0xFF}) {
      std::string changed = bytes;
      changed[i] = static_cast<char>(changed[i] ^ x);
      try {
        TensorArchive::Parse(changed, "flipped");
      } catch (const InputError&) {
        ++refused;
      }
    }
  }
  EXPECT_GT(refused, 0);
  EXPECT_THROW(TensorArchive::Parse(bytes + "x", "trailing"), InputError);
}

// sizes far beyond the bytes present are refused before any allocation is made from them
TEST(TensorArchiveTest, DeclaredSizesAreCheckedAgainstTheBytesPresent) {
  auto entry_header = [](const std::string& key, std::uint8_t kind) {
    std::string s;
    const std::uint32_t n = static_cast<std::uint32_t>(key.size());
    s.append(reinterpret_cast<const char*>(&n), 4);
    s += key;
    s.push_back(static_cast<char>(kind));
    return s;
  };
  auto u64 = [](std::uint64_t v) { return std::string(reinterpret_cast<const char*>(&v), 8); };
  // 2^62 entries
  EXPECT_THROW(TensorArchive::Parse(u64(std::uint64_t{1} << 62) + std::string(64, '\0'), "count"), InputError);
  // a string of 2^63 bytes
  EXPECT_THROW(TensorArchive::Parse(u64(1) + entry_header("s", 0) + u64(std::uint64_t{1} << 63), "string"),
               InputError);
  // a float tensor of 2^31 x 2^31 x 2^31 elements, and one whose sizes overflow 64 bits when multiplied
  std::string tensor = u64(1) + entry_header("t", 2);
  tensor.push_back(0);  // float32
  tensor.push_back(3);  // rank 3
  std::string huge = tensor + u64(std::uint64_t{1} << 31) + u64(std::uint64_t{1} << 31) + u64(std::uint64_t{1} << 31);
  EXPECT_THROW(TensorArchive::Parse(huge, "huge"), InputError);
  std::string overflow = tensor + u64(std::uint64_t{1} << 62) + u64(4) + u64(4) + std::string(16, '\0');
  EXPECT_THROW(TensorArchive::Parse(overflow, "overflow"), InputError);
  std::string negative = tensor + u64(static_cast<std::uint64_t>(-1)) + u64(1) + u64(1);
  EXPECT_THROW(TensorArchive::Parse(negative, "negative"), InputError);
}

std::string ReadBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// a checkpoint of format 1 (torch::serialize, the toy-reach fuzz seed as it was before format 2) is refused by the
// readers with the upgrade command in the message; upgraded, it exports the same policy file as before
TEST(CheckpointFormatTest, FormatOneIsRefusedAndUpgradesToTheSamePolicy) {
  const fs::path data = fs::path(RMPMARL_TEST_DATA_DIR);
  const fs::path old = data / "checkpoints" / "format1-toy-reach-tiny.ckpt";
  try {
    ReadCheckpointConfig(old.string());
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rmpmarl upgrade-checkpoint"), std::string::npos) << e.what();
  }
  const fs::path dir = fs::temp_directory_path() / ("rmpmarl_upgrade_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path upgraded = dir / "upgraded.ckpt";
  UpgradeCheckpoint(old.string(), upgraded.string());
  EXPECT_EQ(ReadCheckpointConfig(upgraded.string()).task.name, "toy-reach");
  ExportCheckpointPolicy(upgraded.string(), (dir / "policy.rmpp").string());
  // the policy exported from the format-1 file when it was shipped as the fuzz seed
  EXPECT_EQ(ReadBytes(dir / "policy.rmpp"), ReadBytes(data / ".." / ".." / "fuzz" / "seeds" / "toy-reach-tiny.rmpp"));
  EXPECT_THROW(UpgradeCheckpoint(upgraded.string(), (dir / "again.ckpt").string()), InputError);  // already 2
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rmpmarl::rl
