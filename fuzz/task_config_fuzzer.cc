// libFuzzer target: the task config loader (see fuzz_loaders.h); every input ends loaded or in an InputError.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "fuzz_loaders.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  rmpmarl::fuzz::LoadsOrInputError(rmpmarl::fuzz::LoadTaskConfigInput, bytes);
  return 0;
}
