#pragma once
/// TensorBoard scalar summaries without protobuf or TensorFlow: an event file is a sequence of TFRecords
///   uint64 length · uint32 masked_crc32c(length) · data[length] · uint32 masked_crc32c(data)
/// whose data are serialised tensorflow.Event protos, here written by hand:
///   Event { double wall_time = 1; int64 step = 2; string file_version = 3; Summary summary = 5; }
///   Summary { repeated Value value = 1; }  Value { string tag = 1; float simple_value = 2; }
/// The first record carries file_version "brain.Event:2".
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

namespace rmpmarl::rl {

/// TFRecord's masked CRC-32C: ((crc >> 15) | (crc << 17)) + 0xa282ead8.
std::uint32_t MaskedCrc32c(const void* data, std::size_t size);

/// the serialised Event proto of scalars at `step` (exposed for tests).
std::string EncodeScalarEvent(double wall_time, std::int64_t step,
                              const std::vector<std::pair<std::string, float>>& scalars);
/// one TFRecord around `data`.
std::string FrameRecord(std::string_view data);

/// Appends scalar summaries to <dir>/events.out.tfevents.<unix time>.<host>.
class TensorBoardWriter {
 public:
  /// creates the directory and the event file; throws InputError when it cannot.
  explicit TensorBoardWriter(const std::string& dir);
  /// writes scalars at `step` and flushes.
  void Write(std::int64_t step, const std::vector<std::pair<std::string, float>>& scalars);
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::ofstream out_;
};

}  // namespace rmpmarl::rl
