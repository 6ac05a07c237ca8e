// The coupled layer's collision leaves, four joints or leaves at a time (see collision_leaf_simd.h), with an exp of
// our own (Exp4).
#include "collision_leaf_simd.h"

#include <cmath>
#include <cstdint>

#if defined(__x86_64__)
#include <immintrin.h>
#define RMPMARL_LEAF_X86 1
#endif

#include "rmpmarl/common/cpu.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp::internal {

#ifdef RMPMARL_LEAF_X86
namespace {

// exp(x) = 2^n · e^r with n = round(x / ln 2) and r = x − n ln 2, |r| ≤ ln 2 / 2: ln 2 in two parts (Cody and
// Waite) so that r keeps its low bits, and e^r by its Taylor polynomial to degree 13 (the first term left out,
// r^14 / 14!, is below 2^-60 of e^r on the interval), evaluated with fused multiply-adds.
// Measured against a long double reference: within 1 ulp over the range the collision RMP uses
// (CollisionLeafSimdTest.ExpIsWithinTwoUlp holds it to 2).
constexpr double kLog2e = 0x1.71547652b82fep0;         // 1 / ln 2
constexpr double kLn2Hi = 0x1.62e42fefa3800p-1;        // ln 2, its leading 43 bits: n · kLn2Hi is exact for |n| < 2^10
constexpr double kLn2Lo = 0x1.ef35793c7673p-45;        // ln 2 − kLn2Hi
// e^r = Σ_k r^k / k!, k = 0..13
constexpr double kInvFactorial[14] = {1.0,
                                      1.0,
                                      1.0 / 2.0,
                                      1.0 / 6.0,
                                      1.0 / 24.0,
                                      1.0 / 120.0,
                                      1.0 / 720.0,
                                      1.0 / 5040.0,
                                      1.0 / 40320.0,
                                      1.0 / 362880.0,
                                      1.0 / 3628800.0,
                                      1.0 / 39916800.0,
                                      1.0 / 479001600.0,
                                      1.0 / 6227020800.0};

__attribute__((target("avx2,fma"))) inline __m256d Set(double v) { return _mm256_set1_pd(v); }

// exp of four lanes; lanes outside [−708, 709] (where 2^n is no normal double: underflow, overflow) and NaN go to
// std::exp
__attribute__((target("avx2,fma"), always_inline)) inline __m256d Exp4(__m256d x) {
  const __m256d inside = _mm256_and_pd(_mm256_cmp_pd(x, Set(-708.0), _CMP_GE_OQ), _mm256_cmp_pd(x, Set(709.0),
                                                                                                  _CMP_LE_OQ));
  const __m256d n = _mm256_round_pd(_mm256_mul_pd(x, Set(kLog2e)), _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC);
  const __m256d r = _mm256_fnmadd_pd(n, Set(kLn2Lo), _mm256_fnmadd_pd(n, Set(kLn2Hi), x));
  // the terms from r⁴ on by Estrin's scheme (pairs c_k + c_{k+1} r, then in r², r⁴, r⁸), the first four by Horner's,
  // which keeps the rounding errors of the small terms small: within 1 ulp
  const double* c = kInvFactorial;
  const __m256d r2 = _mm256_mul_pd(r, r), r4 = _mm256_mul_pd(r2, r2), r8 = _mm256_mul_pd(r4, r4);
  const __m256d p45 = _mm256_fmadd_pd(Set(c[5]), r, Set(c[4])), p67 = _mm256_fmadd_pd(Set(c[7]), r, Set(c[6]));
  const __m256d p89 = _mm256_fmadd_pd(Set(c[9]), r, Set(c[8])), p1011 = _mm256_fmadd_pd(Set(c[11]), r, Set(c[10]));
  const __m256d p1213 = _mm256_fmadd_pd(Set(c[13]), r, Set(c[12]));
  const __m256d p4_7 = _mm256_fmadd_pd(p67, r2, p45), p8_11 = _mm256_fmadd_pd(p1011, r2, p89);
  const __m256d p4_11 = _mm256_fmadd_pd(p8_11, r4, p4_7);
  const __m256d p4_13 = _mm256_fmadd_pd(p1213, r8, p4_11);
  __m256d p = _mm256_fmadd_pd(p4_13, r, Set(c[3]));
  p = _mm256_fmadd_pd(p, r, Set(c[2]));
  p = _mm256_fmadd_pd(p, r, Set(c[1]));
  p = _mm256_fmadd_pd(p, r, Set(c[0]));
  // 2^n from its exponent bits (n is an integer in [−1022, 1023] inside the range)
  const __m256i exponent = _mm256_slli_epi64(
      _mm256_add_epi64(_mm256_cvtepi32_epi64(_mm256_cvtpd_epi32(_mm256_and_pd(n, inside))), _mm256_set1_epi64x(1023)),
      52);
  __m256d y = _mm256_mul_pd(p, _mm256_castsi256_pd(exponent));
  if (_mm256_movemask_pd(inside) != 0xf) {
    alignas(32) double xs[4], ys[4];
    _mm256_store_pd(xs, x);
    _mm256_store_pd(ys, y);
    const int in = _mm256_movemask_pd(inside);
    for (int i = 0; i < 4; ++i) {
      if ((in & (1 << i)) == 0) ys[i] = std::exp(xs[i]);
    }
    y = _mm256_load_pd(ys);
  }
  return y;
}

}  // namespace

bool CollisionLeafKernelAvailable() {
  static const bool available = CpuHasAvx2Fma();
  return available;
}

__attribute__((target("avx2,fma"))) void ExpAvx2(const double* x, double* y, int n) {
  RMPMARL_ASSERT(CollisionLeafKernelAvailable(), "ExpAvx2: the kernel is not available on this machine");
  for (int i = 0; i < n; i += 4) {
    alignas(32) double in[4] = {1.0, 1.0, 1.0, 1.0}, out[4];
    for (int l = 0; l < 4 && i + l < n; ++l) in[l] = x[i + l];
    _mm256_store_pd(out, Exp4(_mm256_load_pd(in)));
    for (int l = 0; l < 4 && i + l < n; ++l) y[i + l] = out[l];
  }
}

namespace {

// leaf l's per-dof terms: the increments of b (before the active mask), g and mg, lanes 0..k rounded up to 4
__attribute__((target("avx2,fma"), always_inline)) inline void LeafTerms(const CollisionLeafBatch& batch, int l,
                                                                         const CollisionLeafConstants& c,
                                                                         const CollisionLeafLanes& lanes,
                                                                         double* increment_out, double* g_out,
                                                                         double* mg_out) {
  const double x = batch.xc[l];
  const __m256d xc = Set(x), neg_xc = Set(-x), m = Set(batch.m[l]), jdqd = Set(batch.jdqd[l]);
  const __m256d n0 = Set(batch.n[0][l]), n1 = Set(batch.n[1][l]), n2 = Set(batch.n[2][l]);
  const __m256d p0 = Set(batch.p[0][l]), p1 = Set(batch.p[1][l]), p2 = Set(batch.p[2][l]);
  for (int base = 0; base < batch.k[l]; base += 4) {
    // the collision acceleration at each joint's length scales (CollisionRmpAccel's expression)
    const __m256d repulsion =
        _mm256_mul_pd(Set(c.repulsion_gain),
                      Exp4(_mm256_div_pd(neg_xc, _mm256_loadu_pd(lanes.repulsion_std_dev + base))));
    const __m256d damping = _mm256_div_pd(
        Set(batch.damping_force[l]),
        _mm256_add_pd(_mm256_div_pd(xc, _mm256_loadu_pd(lanes.damping_std_dev + base)), Set(c.damping_eps)));
    const __m256d a = _mm256_sub_pd(repulsion, damping);
    // j = n · (axis × (p − origin)), as Eigen's cross and dot form it
    const __m256d rx = _mm256_sub_pd(p0, _mm256_loadu_pd(lanes.origin[0] + base));
    const __m256d ry = _mm256_sub_pd(p1, _mm256_loadu_pd(lanes.origin[1] + base));
    const __m256d rz = _mm256_sub_pd(p2, _mm256_loadu_pd(lanes.origin[2] + base));
    const __m256d ax = _mm256_loadu_pd(lanes.axis[0] + base), ay = _mm256_loadu_pd(lanes.axis[1] + base),
                  az = _mm256_loadu_pd(lanes.axis[2] + base);
    const __m256d cx = _mm256_sub_pd(_mm256_mul_pd(ay, rz), _mm256_mul_pd(az, ry));
    const __m256d cy = _mm256_sub_pd(_mm256_mul_pd(az, rx), _mm256_mul_pd(ax, rz));
    const __m256d cz = _mm256_sub_pd(_mm256_mul_pd(ax, ry), _mm256_mul_pd(ay, rx));
    const __m256d j =
        _mm256_add_pd(_mm256_add_pd(_mm256_mul_pd(n0, cx), _mm256_mul_pd(n1, cy)), _mm256_mul_pd(n2, cz));
    // s_m j m (s_a a − J̇q̇); g = √s_m j where active, else 0; m g
    _mm256_storeu_pd(increment_out + base,
                     _mm256_mul_pd(_mm256_mul_pd(_mm256_mul_pd(_mm256_loadu_pd(lanes.metric_scale + base), j), m),
                                   _mm256_sub_pd(_mm256_mul_pd(_mm256_loadu_pd(lanes.accel_scale + base), a), jdqd)));
    const __m256d g = _mm256_and_pd(_mm256_mul_pd(_mm256_loadu_pd(lanes.sqrt_metric_scale + base), j),
                                    _mm256_loadu_pd(lanes.active + base));
    _mm256_storeu_pd(g_out + base, g);
    _mm256_storeu_pd(mg_out + base, _mm256_mul_pd(m, g));
  }
}

// lanes base..base+3 of a leaf with k dofs: all bits set where base + i < k
__attribute__((target("avx2,fma"), always_inline)) inline __m256d LaneMask(int base, int k) {
  const __m256i lane = _mm256_add_epi64(_mm256_set1_epi64x(base), _mm256_setr_epi64x(0, 1, 2, 3));
  return _mm256_castsi256_pd(_mm256_cmpgt_epi64(_mm256_set1_epi64x(k), lane));
}

}  // namespace

__attribute__((target("avx2,fma"))) void CollisionLeavesAvx2(CollisionLeafBatch* batch,
                                                            const CollisionLeafConstants& c,
                                                            const CollisionLeafLanes& lanes, int stride,
                                                            double* scratch, double* b, double* A, int lda) {
  CollisionLeafBatch& leaves = *batch;
  const int count = leaves.count;
  RMPMARL_DASSERT(count >= 0 && count <= CollisionLeafBatch::kCapacity, "CollisionLeavesAvx2: batch size");
  // the velocity gate σ = 1 / (1 + exp(ḋ / v_d)) and the metric σ g(x) μ / (x / l_e + ε_e), g(x) = (1 − x/r)² up to
  // r (CollisionVelocityGate, CollisionDistanceGate, CollisionRmpMetric), four leaves at a time; the lanes past
  // count hold ones (their results are not read)
  for (int l = count; l < (count + 3) / 4 * 4; ++l) leaves.xc[l] = leaves.xd[l] = 1.0;
  for (int l = 0; l < count; l += 4) {
    const __m256d xc = _mm256_loadu_pd(leaves.xc + l), xd = _mm256_loadu_pd(leaves.xd + l);
    const __m256d one = Set(1.0);
    const __m256d sigma = _mm256_div_pd(one, _mm256_add_pd(one, Exp4(_mm256_div_pd(xd, Set(c.velocity_gate)))));
    const __m256d s = _mm256_sub_pd(one, _mm256_div_pd(xc, Set(c.radius)));
    const __m256d gate = _mm256_andnot_pd(_mm256_cmp_pd(xc, Set(c.radius), _CMP_GT_OQ), _mm256_mul_pd(s, s));
    _mm256_storeu_pd(leaves.m + l,
                     _mm256_div_pd(_mm256_mul_pd(_mm256_mul_pd(sigma, gate), Set(c.metric_scalar)),
                                   _mm256_add_pd(_mm256_div_pd(xc, Set(c.exploder_std_dev)), Set(c.exploder_eps))));
    _mm256_storeu_pd(leaves.damping_force + l, _mm256_mul_pd(_mm256_mul_pd(Set(c.damping_gain), sigma), xd));
  }
  double* increment = scratch;
  double* g = scratch + static_cast<long>(CollisionLeafBatch::kCapacity) * stride;
  double* mg = g + static_cast<long>(CollisionLeafBatch::kCapacity) * stride;
  // every leaf's terms first (independent of each other, so that their latencies overlap), then the sums in order
  for (int l = 0; l < count; ++l) {
    const long at = static_cast<long>(l) * stride;
    LeafTerms(leaves, l, c, lanes, increment + at, g + at, mg + at);
  }
  for (int l = 0; l < count; ++l) {
    const int k = leaves.k[l];
    const long at = static_cast<long>(l) * stride;
    // b_i += increment_i where active; the other entries keep their bits
    for (int base = 0; base < k; base += 4) {
      const __m256d old = _mm256_loadu_pd(b + base);
      _mm256_storeu_pd(b + base,
                       _mm256_blendv_pd(old, _mm256_add_pd(old, _mm256_loadu_pd(increment + at + base)),
                                        _mm256_and_pd(_mm256_loadu_pd(lanes.active + base), LaneMask(base, k))));
    }
    // A(i, j) += g_j (m g_i) for i, j < k, as the scalar loop forms each entry; the rows past k keep their bits
    for (int base = 0; base < k; base += 4) {
      const __m256d valid = LaneMask(base, k);
      const __m256d mg_i = _mm256_loadu_pd(mg + at + base);
      for (int col = 0; col < k; ++col) {
        double* a = A + static_cast<long>(col) * lda + base;
        const __m256d old = _mm256_loadu_pd(a);
        _mm256_storeu_pd(a,
                         _mm256_blendv_pd(old, _mm256_add_pd(old, _mm256_mul_pd(Set(g[at + col]), mg_i)), valid));
      }
    }
  }
}

__attribute__((target("avx2,fma"))) void AddGramAvx2(const double* const g[3], const double* M, int n, double* A,
                                                    int lda) {
  for (int col = 0; col < n; ++col) {
    const __m256d m0 = Set(M[3 * col]), m1 = Set(M[3 * col + 1]), m2 = Set(M[3 * col + 2]);
    double* a = A + static_cast<long>(col) * lda;
    for (int base = 0; base < n; base += 4) {
      const __m256d g0m0 = _mm256_mul_pd(_mm256_loadu_pd(g[0] + base), m0);
      const __m256d g1m1 = _mm256_mul_pd(_mm256_loadu_pd(g[1] + base), m1);
      const __m256d sum = _mm256_add_pd(_mm256_add_pd(g0m0, g1m1), _mm256_mul_pd(_mm256_loadu_pd(g[2] + base), m2));
      _mm256_storeu_pd(a + base, _mm256_add_pd(_mm256_loadu_pd(a + base), sum));
    }
  }
}

#else  // not x86-64: the scalar loop runs

bool CollisionLeafKernelAvailable() { return false; }

void ExpAvx2(const double*, double*, int) { RMPMARL_ASSERT(false, "ExpAvx2: x86-64 only"); }

void AddGramAvx2(const double* const*, const double*, int, double*, int) {
  RMPMARL_ASSERT(false, "AddGramAvx2: x86-64 only");
}

void CollisionLeavesAvx2(CollisionLeafBatch*, const CollisionLeafConstants&, const CollisionLeafLanes&, int, double*,
                         double*, double*, int) {
  RMPMARL_ASSERT(false, "CollisionLeavesAvx2: x86-64 only");
}

#endif  // RMPMARL_LEAF_X86

}  // namespace rmpmarl::rmp::internal
