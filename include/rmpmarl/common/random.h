#pragma once
/// Seed derivation shared by every module: independent, well-mixed seeds from a base seed and an index.
#include <cstdint>

namespace rmpmarl {

/// the splitmix64 finaliser (Steele, Lea & Flood, "Fast splittable pseudorandom number generators", OOPSLA 2014):
/// a bijection of 64-bit integers whose outputs for neighbouring inputs are decorrelated.
constexpr std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

}  // namespace rmpmarl
