// The vectorised exp of the coupled layer's leaf kernel against an extended-precision reference (a white-box test of
// an internal kernel; EvaluateCoupledLayer's own comparison with its scalar loop is in coupled_layer_test.cc).
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "../../src/rmp/collision_leaf_simd.h"
#include "rmpmarl/common/cpu.h"

namespace rmpmarl::rmp {
namespace {

// on an AVX2/FMA machine the kernel is on, whatever the C library
TEST(CollisionLeafSimdTest, KernelRunsOnEveryAvx2Machine) {
  if (!CpuHasAvx2Fma()) GTEST_SKIP() << "this CPU has no AVX2/FMA";
  EXPECT_TRUE(internal::CollisionLeafKernelAvailable());
}

// |y − e^x| in units in the last place of e^x (the spacing of doubles at e^x, that of the smallest normal below it),
// with e^x from long double's expl (64-bit significand: its own error is 2^-11 ulp of a double)
double UlpError(double x, double y) {
  const long double exact = std::exp(static_cast<long double>(x));
  const double rounded = static_cast<double>(exact);
  int exponent = 0;
  std::frexp(std::max(rounded, std::numeric_limits<double>::min()), &exponent);
  const long double ulp = std::ldexp(1.0L, std::max(exponent - 53, -1074));
  return static_cast<double>(std::fabs(static_cast<long double>(y) - exact) / ulp);
}

TEST(CollisionLeafSimdTest, ExpIsWithinTwoUlp) {
  if (!internal::CollisionLeafKernelAvailable()) GTEST_SKIP() << "the kernel is off on this machine";
  std::mt19937_64 rng(3);
  std::vector<double> x;
  // the collision RMP's arguments: −d / l_p (d up to r, l_p down to a few mm) and the velocity gate's ḋ / v_d; every
  // scale around them, and the edges of the range
  std::uniform_real_distribution<double> repulsion(-200.0, 0.0), gate(-60.0, 60.0), wide(-708.0, 709.0),
      unit(-1.0, 1.0);
  for (int i = 0; i < 1'000'000; ++i) x.push_back(repulsion(rng));
  for (int i = 0; i < 300'000; ++i) x.push_back(gate(rng));
  for (int i = 0; i < 300'000; ++i) x.push_back(wide(rng));
  for (int i = 0; i < 300'000; ++i) x.push_back(unit(rng) * std::ldexp(1.0, static_cast<int>(rng() % 70) - 60));
  for (double v : {0.0, -0.0, 1e-300, -1e-300, 0x1p-54, -0x1p-54, 0.5 * M_LN2, -0.5 * M_LN2, 1.5 * M_LN2, 511.999,
                   -708.0, -707.9999, 708.9999, 709.0}) {
    x.push_back(v);
  }
  std::vector<double> y(x.size());
  internal::ExpAvx2(x.data(), y.data(), static_cast<int>(x.size()));
  double worst = 0.0, worst_x = 0.0;
  for (size_t i = 0; i < x.size(); ++i) {
    const double e = UlpError(x[i], y[i]);
    if (!(e <= worst)) {
      worst = e;
      worst_x = x[i];
    }
  }
  std::printf("[ exp      ] %zu arguments: worst error %.3f ulp at x = %a\n", x.size(), worst, worst_x);
  EXPECT_LE(worst, 2.0) << "at x = " << std::hexfloat << worst_x;

  // outside the polynomial's range the lanes are std::exp's: underflow to subnormals and 0, overflow to inf, NaN
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const std::vector<double> edges = {-708.5, -745.1, -745.2, -746.0, -kInf, 709.5, 709.8, 710.0, kInf,
                                     std::numeric_limits<double>::quiet_NaN()};
  std::vector<double> out(edges.size());
  internal::ExpAvx2(edges.data(), out.data(), static_cast<int>(edges.size()));
  for (size_t i = 0; i < edges.size(); ++i) {
    const double want = std::exp(edges[i]);
    if (std::isnan(want)) {
      EXPECT_TRUE(std::isnan(out[i]));
    } else {
      EXPECT_EQ(out[i], want) << "x = " << edges[i];
    }
  }
}

}  // namespace
}  // namespace rmpmarl::rmp
