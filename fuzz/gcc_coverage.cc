// Coverage for libFuzzer from g++ (the gcc-built checkpoint fuzzer, fuzz/CMakeLists.txt): g++ instruments code with
// -fsanitize-coverage=trace-pc,trace-cmp, which calls __sanitizer_cov_trace_pc() at every basic block and the
// __sanitizer_cov_trace_cmp* hooks at every comparison. libFuzzer takes the comparison hooks as they are, but it
// only counts edges through the inline 8-bit counters clang emits (-fsanitize-coverage=inline-8bit-counters), and
// its own __sanitizer_cov_trace_pc aborts ("no longer supported"); the build links a copy of libFuzzer with that
// symbol weakened. Here every basic block's return address is hashed into one table of 8-bit counters registered
// with libFuzzer as a module, so libFuzzer sees basic-block hit counts (up to hash collisions in 2^16 slots).
// This file itself is compiled without coverage instrumentation.
#include <cstddef>
#include <cstdint>

extern "C" {
void __sanitizer_cov_8bit_counters_init(std::uint8_t* begin, std::uint8_t* end);
void __sanitizer_cov_pcs_init(const std::uintptr_t* begin, const std::uintptr_t* end);
}

namespace {

constexpr std::size_t kCounters = std::size_t{1} << 16;
alignas(64) std::uint8_t counters[kCounters];
// libFuzzer's PC table: one (pc, flags) pair per counter; the "pc" is the slot index (its reports name slots, not
// source lines)
std::uintptr_t pcs[2 * kCounters];

__attribute__((constructor)) void RegisterCounters() {
  for (std::size_t i = 0; i < kCounters; ++i) {
    pcs[2 * i] = i + 1;
    pcs[2 * i + 1] = 0;
  }
  __sanitizer_cov_8bit_counters_init(counters, counters + kCounters);
  __sanitizer_cov_pcs_init(pcs, pcs + 2 * kCounters);
}

}  // namespace

extern "C" {

// g++'s basic-block hook: the caller's address (the block) hashed into a counter
__attribute__((no_sanitize_address, no_sanitize_undefined)) void __sanitizer_cov_trace_pc() {
  auto pc = reinterpret_cast<std::uintptr_t>(__builtin_return_address(0));
  pc ^= pc >> 17;
  pc *= 0x9E3779B97F4A7C15ull;
  std::uint8_t& c = counters[(pc >> 40) & (kCounters - 1)];
  c = static_cast<std::uint8_t>(c + 1);
}

// g++ also traces floating-point comparisons, which libFuzzer has no hooks for
void __sanitizer_cov_trace_cmpf(float, float) {}
void __sanitizer_cov_trace_cmpd(double, double) {}

}  // extern "C"
