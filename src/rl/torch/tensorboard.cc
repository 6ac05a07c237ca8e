// TensorBoard event files by hand: TFRecord framing with masked CRC-32C around hand-encoded Event protos.
// (torch-free translation unit.)
#include "rmpmarl/rl/torch/tensorboard.h"

#include <fmt/format.h>
#include <unistd.h>

#include <chrono>
#include <cstring>
#include <filesystem>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/policy_file.h"

namespace rmpmarl::rl {
namespace {

// protobuf wire format helpers.
void Varint(std::string& out, std::uint64_t v) {
  while (v >= 0x80) {
    out.push_back(static_cast<char>((v & 0x7F) | 0x80));
    v >>= 7;
  }
  out.push_back(static_cast<char>(v));
}
void Tag(std::string& out, int field, int wire_type) { Varint(out, static_cast<std::uint64_t>(field) << 3 | wire_type); }
void LengthDelimited(std::string& out, int field, std::string_view bytes) {
  Tag(out, field, 2);
  Varint(out, bytes.size());
  out.append(bytes);
}
template <typename T>
void Fixed(std::string& out, int field, T value) {
  Tag(out, field, sizeof(T) == 8 ? 1 : 5);
  char buf[sizeof(T)];
  std::memcpy(buf, &value, sizeof(T));
  out.append(buf, sizeof(T));
}

std::string FileVersionEvent(double wall_time) {
  std::string event;
  Fixed(event, 1, wall_time);
  LengthDelimited(event, 3, "brain.Event:2");
  return event;
}

double Now() {
  return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count();
}

}  // namespace

std::uint32_t MaskedCrc32c(const void* data, std::size_t size) {
  const std::uint32_t crc = control::Crc32c(data, size);
  return ((crc >> 15) | (crc << 17)) + 0xa282ead8u;
}

std::string EncodeScalarEvent(double wall_time, std::int64_t step,
                              const std::vector<std::pair<std::string, float>>& scalars) {
  std::string summary;
  for (const auto& [tag, value] : scalars) {
    std::string v;
    LengthDelimited(v, 1, tag);
    Fixed(v, 2, value);
    LengthDelimited(summary, 1, v);
  }
  std::string event;
  Fixed(event, 1, wall_time);
  Tag(event, 2, 0);
  Varint(event, static_cast<std::uint64_t>(step));
  LengthDelimited(event, 5, summary);
  return event;
}

std::string FrameRecord(std::string_view data) {
  std::string out;
  const std::uint64_t length = data.size();
  char len[8];
  std::memcpy(len, &length, 8);
  const std::uint32_t len_crc = MaskedCrc32c(len, 8);
  const std::uint32_t data_crc = MaskedCrc32c(data.data(), data.size());
  out.append(len, 8);
  out.append(reinterpret_cast<const char*>(&len_crc), 4);
  out.append(data);
  out.append(reinterpret_cast<const char*>(&data_crc), 4);
  return out;
}

TensorBoardWriter::TensorBoardWriter(const std::string& dir) {
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  char host[256] = "localhost";
  gethostname(host, sizeof(host) - 1);
  path_ = fmt::format("{}/events.out.tfevents.{}.{}", dir, static_cast<long long>(Now()), host);
  out_.open(path_, std::ios::binary | std::ios::app);
  if (!out_) throw InputError(fmt::format("tensorboard: cannot create {}", path_));
  const std::string record = FrameRecord(FileVersionEvent(Now()));
  out_.write(record.data(), static_cast<std::streamsize>(record.size()));
  out_.flush();
}

void TensorBoardWriter::Write(std::int64_t step, const std::vector<std::pair<std::string, float>>& scalars) {
  const std::string record = FrameRecord(EncodeScalarEvent(Now(), step, scalars));
  out_.write(record.data(), static_cast<std::streamsize>(record.size()));
  out_.flush();
}

}  // namespace rmpmarl::rl
