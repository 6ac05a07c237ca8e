// The vectorised exp of the coupled layer's leaf kernel against the C library's std::exp, bit for bit (a white-box
// test of an internal kernel; EvaluateCoupledLayer's own comparison with its scalar loop is in coupled_layer_test.cc).
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "../../src/rmp/collision_leaf_simd.h"
#include "rmpmarl/common/cpu.h"

namespace rmpmarl::rmp {
namespace {

bool SameBits(double a, double b) { return std::memcmp(&a, &b, sizeof(double)) == 0; }

// on an AVX2/FMA machine with glibc the kernel must be on: off, the layer still gives the same results, only slower
TEST(CollisionLeafSimdTest, KernelRunsOnAnAvx2MachineWithGlibc) {
#if defined(__GLIBC__)
  if (!CpuHasAvx2Fma()) GTEST_SKIP() << "this CPU has no AVX2/FMA";
  EXPECT_TRUE(internal::CollisionLeafKernelAvailable())
      << "the vectorised exp failed its self-check against this C library's exp (glibc " << __GLIBC__ << "."
      << __GLIBC_MINOR__ << "): the coupled layer runs its scalar loop";
#else
  GTEST_SKIP() << "not glibc";
#endif
}

TEST(CollisionLeafSimdTest, ExpIsTheCLibrarysExpBitForBit) {
  if (!internal::CollisionLeafKernelAvailable()) GTEST_SKIP() << "the kernel is off on this machine";
  std::mt19937_64 rng(3);
  std::vector<double> x;
  // the collision RMP's arguments −d / l_p (d up to r, l_p down to a few mm), every scale around them, and the edges
  std::uniform_real_distribution<double> repulsion(-200.0, 0.0), wide(-800.0, 800.0), unit(-1.0, 1.0);
  for (int i = 0; i < 1'000'000; ++i) x.push_back(repulsion(rng));
  for (int i = 0; i < 300'000; ++i) x.push_back(wide(rng));
  for (int i = 0; i < 300'000; ++i) x.push_back(unit(rng) * std::ldexp(1.0, static_cast<int>(rng() % 70) - 60));
  constexpr double kInf = std::numeric_limits<double>::infinity();
  for (double v : {0.0, -0.0, 1e-300, -1e-300, 0x1p-54, -0x1p-54, 0x1.fffffffffffffp-55, 511.999, 512.0, -512.0,
                   -708.3, -745.2, -745.1, -746.0, 709.7, 709.8, 710.0, kInf, -kInf,
                   std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::denorm_min()}) {
    x.push_back(v);
  }
  std::vector<double> y(x.size());
  internal::ExpAvx2(x.data(), y.data(), static_cast<int>(x.size()));
  int mismatches = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double want = std::exp(x[i]);
    if (!SameBits(y[i], want) && !(std::isnan(want) && std::isnan(y[i]))) {
      if (++mismatches <= 5) ADD_FAILURE() << "exp(" << std::hexfloat << x[i] << ") = " << y[i] << ", want " << want;
    }
  }
  EXPECT_EQ(mismatches, 0);
}

}  // namespace
}  // namespace rmpmarl::rmp
