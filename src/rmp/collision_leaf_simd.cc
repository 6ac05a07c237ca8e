// The coupled layer's collision leaves, four joints or leaves at a time (see collision_leaf_simd.h).
// Compiled with -ffp-contract=off (CMakeLists.txt): every multiply and add below stays one rounded operation, as in
// the scalar loop; the exp's fused multiply-adds are written out as such, where the C library's exp has them.
#include "collision_leaf_simd.h"

#include <cmath>
#include <cstdint>
#include <cstring>
#include <random>

#if defined(__x86_64__)
#include <immintrin.h>
#define RMPMARL_LEAF_X86 1
#endif

#include "rmpmarl/common/cpu.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp::internal {

#ifdef RMPMARL_LEAF_X86
namespace {

// exp(x) = 2^(n + k/128) · 2^(r/ln2) with x = (128 n + k) ln2/128 + r, |r| ≤ ln2/256: the table gives 2^(k/128) as
// H_k (1 + tail_k), a degree-5 polynomial gives the rest. The algorithm, its constants and the fused operations are
// those of the C library's exp on an FMA machine (glibc's __exp_fma), so that the result is its result bit for bit;
// the self-check below holds the kernel to that.
constexpr double kInvLn2N = 0x1.71547652b82fep7;             // 128 / ln 2
constexpr double kNegLn2HiN = -0x1.62e42fefa0000p-8;         // −ln 2 / 128, leading bits
constexpr double kNegLn2LoN = -0x1.cf79abc9e3b3ap-47;        // −ln 2 / 128, the rest
constexpr double kShift = 0x1.8p52;                          // rounds to an integer in the low bits
constexpr double kC2 = 0x1.ffffffffffdbdp-2, kC3 = 0x1.555555555543cp-3;
constexpr double kC4 = 0x1.55555cf172b91p-5, kC5 = 0x1.1111167a4d017p-7;

// pairs (bits of tail_k, bits of H_k − k·2^45) for k = 0..127, printed by scripts/exp_table.py (which checks this
// copy: ctest rmp.exp_table_matches_its_script)
alignas(32) constexpr std::uint64_t kExpTable[256] = {
    0x0000000000000000, 0x3ff0000000000000, 0x3c9b3b4f1a88bf6e, 0x3feff63da9fb3335,
    0xbc7160139cd8dc5d, 0x3fefec9a3e778061, 0xbc905e7a108766d1, 0x3fefe315e86e7f85,
    0x3c8cd2523567f613, 0x3fefd9b0d3158574, 0xbc8bce8023f98efa, 0x3fefd06b29ddf6de,
    0x3c60f74e61e6c861, 0x3fefc74518759bc8, 0x3c90a3e45b33d399, 0x3fefbe3ecac6f383,
    0x3c979aa65d837b6d, 0x3fefb5586cf9890f, 0x3c8eb51a92fdeffc, 0x3fefac922b7247f7,
    0x3c3ebe3d702f9cd1, 0x3fefa3ec32d3d1a2, 0xbc6a033489906e0b, 0x3fef9b66affed31b,
    0xbc9556522a2fbd0e, 0x3fef9301d0125b51, 0xbc5080ef8c4eea55, 0x3fef8abdc06c31cc,
    0xbc91c923b9d5f416, 0x3fef829aaea92de0, 0x3c80d3e3e95c55af, 0x3fef7a98c8a58e51,
    0xbc801b15eaa59348, 0x3fef72b83c7d517b, 0xbc8f1ff055de323d, 0x3fef6af9388c8dea,
    0x3c8b898c3f1353bf, 0x3fef635beb6fcb75, 0xbc96d99c7611eb26, 0x3fef5be084045cd4,
    0x3c9aecf73e3a2f60, 0x3fef54873168b9aa, 0xbc8fe782cb86389d, 0x3fef4d5022fcd91d,
    0x3c8a6f4144a6c38d, 0x3fef463b88628cd6, 0x3c807a05b0e4047d, 0x3fef3f49917ddc96,
    0x3c968efde3a8a894, 0x3fef387a6e756238, 0x3c875e18f274487d, 0x3fef31ce4fb2a63f,
    0x3c80472b981fe7f2, 0x3fef2b4565e27cdd, 0xbc96b87b3f71085e, 0x3fef24dfe1f56381,
    0x3c82f7e16d09ab31, 0x3fef1e9df51fdee1, 0xbc3d219b1a6fbffa, 0x3fef187fd0dad990,
    0x3c8b3782720c0ab4, 0x3fef1285a6e4030b, 0x3c6e149289cecb8f, 0x3fef0cafa93e2f56,
    0x3c834d754db0abb6, 0x3fef06fe0a31b715, 0x3c864201e2ac744c, 0x3fef0170fc4cd831,
    0x3c8fdd395dd3f84a, 0x3feefc08b26416ff, 0xbc86a3803b8e5b04, 0x3feef6c55f929ff1,
    0xbc924aedcc4b5068, 0x3feef1a7373aa9cb, 0xbc9907f81b512d8e, 0x3feeecae6d05d866,
    0xbc71d1e83e9436d2, 0x3feee7db34e59ff7, 0xbc991919b3ce1b15, 0x3feee32dc313a8e5,
    0x3c859f48a72a4c6d, 0x3feedea64c123422, 0xbc9312607a28698a, 0x3feeda4504ac801c,
    0xbc58a78f4817895b, 0x3feed60a21f72e2a, 0xbc7c2c9b67499a1b, 0x3feed1f5d950a897,
    0x3c4363ed60c2ac11, 0x3feece086061892d, 0x3c9666093b0664ef, 0x3feeca41ed1d0057,
    0x3c6ecce1daa10379, 0x3feec6a2b5c13cd0, 0x3c93ff8e3f0f1230, 0x3feec32af0d7d3de,
    0x3c7690cebb7aafb0, 0x3feebfdad5362a27, 0x3c931dbdeb54e077, 0x3feebcb299fddd0d,
    0xbc8f94340071a38e, 0x3feeb9b2769d2ca7, 0xbc87deccdc93a349, 0x3feeb6daa2cf6642,
    0xbc78dec6bd0f385f, 0x3feeb42b569d4f82, 0xbc861246ec7b5cf6, 0x3feeb1a4ca5d920f,
    0x3c93350518fdd78e, 0x3feeaf4736b527da, 0x3c7b98b72f8a9b05, 0x3feead12d497c7fd,
    0x3c9063e1e21c5409, 0x3feeab07dd485429, 0x3c34c7855019c6ea, 0x3feea9268a5946b7,
    0x3c9432e62b64c035, 0x3feea76f15ad2148, 0xbc8ce44a6199769f, 0x3feea5e1b976dc09,
    0xbc8c33c53bef4da8, 0x3feea47eb03a5585, 0xbc845378892be9ae, 0x3feea34634ccc320,
    0xbc93cedd78565858, 0x3feea23882552225, 0x3c5710aa807e1964, 0x3feea155d44ca973,
    0xbc93b3efbf5e2228, 0x3feea09e667f3bcd, 0xbc6a12ad8734b982, 0x3feea012750bdabf,
    0xbc6367efb86da9ee, 0x3fee9fb23c651a2f, 0xbc80dc3d54e08851, 0x3fee9f7df9519484,
    0xbc781f647e5a3ecf, 0x3fee9f75e8ec5f74, 0xbc86ee4ac08b7db0, 0x3fee9f9a48a58174,
    0xbc8619321e55e68a, 0x3fee9feb564267c9, 0x3c909ccb5e09d4d3, 0x3feea0694fde5d3f,
    0xbc7b32dcb94da51d, 0x3feea11473eb0187, 0x3c94ecfd5467c06b, 0x3feea1ed0130c132,
    0x3c65ebe1abd66c55, 0x3feea2f336cf4e62, 0xbc88a1c52fb3cf42, 0x3feea427543e1a12,
    0xbc9369b6f13b3734, 0x3feea589994cce13, 0xbc805e843a19ff1e, 0x3feea71a4623c7ad,
    0xbc94d450d872576e, 0x3feea8d99b4492ed, 0x3c90ad675b0e8a00, 0x3feeaac7d98a6699,
    0x3c8db72fc1f0eab4, 0x3feeace5422aa0db, 0xbc65b6609cc5e7ff, 0x3feeaf3216b5448c,
    0x3c7bf68359f35f44, 0x3feeb1ae99157736, 0xbc93091fa71e3d83, 0x3feeb45b0b91ffc6,
    0xbc5da9b88b6c1e29, 0x3feeb737b0cdc5e5, 0xbc6c23f97c90b959, 0x3feeba44cbc8520f,
    0xbc92434322f4f9aa, 0x3feebd829fde4e50, 0xbc85ca6cd7668e4b, 0x3feec0f170ca07ba,
    0x3c71affc2b91ce27, 0x3feec49182a3f090, 0x3c6dd235e10a73bb, 0x3feec86319e32323,
    0xbc87c50422622263, 0x3feecc667b5de565, 0x3c8b1c86e3e231d5, 0x3feed09bec4a2d33,
    0xbc91bbd1d3bcbb15, 0x3feed503b23e255d, 0x3c90cc319cee31d2, 0x3feed99e1330b358,
    0x3c8469846e735ab3, 0x3feede6b5579fdbf, 0xbc82dfcd978e9db4, 0x3feee36bbfd3f37a,
    0x3c8c1a7792cb3387, 0x3feee89f995ad3ad, 0xbc907b8f4ad1d9fa, 0x3feeee07298db666,
    0xbc55c3d956dcaeba, 0x3feef3a2b84f15fb, 0xbc90a40e3da6f640, 0x3feef9728de5593a,
    0xbc68d6f438ad9334, 0x3feeff76f2fb5e47, 0xbc91eee26b588a35, 0x3fef05b030a1064a,
    0x3c74ffd70a5fddcd, 0x3fef0c1e904bc1d2, 0xbc91bdfbfa9298ac, 0x3fef12c25bd71e09,
    0x3c736eae30af0cb3, 0x3fef199bdd85529c, 0x3c8ee3325c9ffd94, 0x3fef20ab5fffd07a,
    0x3c84e08fd10959ac, 0x3fef27f12e57d14b, 0x3c63cdaf384e1a67, 0x3fef2f6d9406e7b5,
    0x3c676b2c6c921968, 0x3fef3720dcef9069, 0xbc808a1883ccb5d2, 0x3fef3f0b555dc3fa,
    0xbc8fad5d3ffffa6f, 0x3fef472d4a07897c, 0xbc900dae3875a949, 0x3fef4f87080d89f2,
    0x3c74a385a63d07a7, 0x3fef5818dcfba487, 0xbc82919e2040220f, 0x3fef60e316c98398,
    0x3c8e5a50d5c192ac, 0x3fef69e603db3285, 0x3c843a59ac016b4b, 0x3fef7321f301b460,
    0xbc82d52107b43e1f, 0x3fef7c97337b9b5f, 0xbc892ab93b470dc9, 0x3fef864614f5a129,
    0x3c74b604603a88d3, 0x3fef902ee78b3ff6, 0x3c83c5ec519d7271, 0x3fef9a51fbc74c83,
    0xbc8ff7128fd391f0, 0x3fefa4afa2a490da, 0xbc8dae98e223747d, 0x3fefaf482d8e67f1,
    0x3c8ec3bc41aa2008, 0x3fefba1bee615a27, 0x3c842b94c3a9eb32, 0x3fefc52b376bba97,
    0x3c8a64a931d185ee, 0x3fefd0765b6e4540, 0xbc8e37bae43be3ed, 0x3fefdbfdad9cbe14,
    0x3c77893b4d91cd9d, 0x3fefe7c1819e90d8, 0x3c5305c14160cc89, 0x3feff3c22b8f71f1,
};

__attribute__((target("avx2,fma"))) inline __m256d Set(double v) { return _mm256_set1_pd(v); }

// exp of four lanes; lanes with |x| outside [2^-54, 512) (zero, tiny, huge, inf, NaN) go to std::exp
__attribute__((target("avx2,fma"), always_inline)) inline __m256d Exp4(__m256d x) {
  const __m256i ix = _mm256_castpd_si256(x);
  // the exponent field minus that of 2^-54: in [0, 62] on the table's range
  const __m256i top = _mm256_sub_epi64(_mm256_and_si256(_mm256_srli_epi64(ix, 52), _mm256_set1_epi64x(0x7ff)),
                                       _mm256_set1_epi64x(0x3c9));
  const __m256i outside = _mm256_or_si256(_mm256_cmpgt_epi64(top, _mm256_set1_epi64x(0x3e)),
                                          _mm256_cmpgt_epi64(_mm256_setzero_si256(), top));
  __m256d kd = _mm256_fmadd_pd(x, Set(kInvLn2N), Set(kShift));
  const __m256i ki = _mm256_castpd_si256(kd);
  kd = _mm256_sub_pd(kd, Set(kShift));
  __m256d r = _mm256_fmadd_pd(kd, Set(kNegLn2HiN), x);
  r = _mm256_fmadd_pd(kd, Set(kNegLn2LoN), r);
  const __m256i idx = _mm256_slli_epi64(_mm256_and_si256(ki, _mm256_set1_epi64x(127)), 1);
  const __m256i shifted = _mm256_slli_epi64(ki, 45);
  const auto* table = reinterpret_cast<const long long*>(kExpTable);
  const __m256d tail = _mm256_castsi256_pd(_mm256_i64gather_epi64(table, idx, 8));
  const __m256i sbits = _mm256_add_epi64(_mm256_i64gather_epi64(table + 1, idx, 8), shifted);
  const __m256d p23 = _mm256_fmadd_pd(r, Set(kC3), Set(kC2));
  const __m256d tail_r = _mm256_add_pd(r, tail);
  const __m256d r2 = _mm256_mul_pd(r, r);
  const __m256d p45 = _mm256_fmadd_pd(r, Set(kC5), Set(kC4));
  const __m256d t = _mm256_fmadd_pd(p23, r2, tail_r);
  const __m256d tmp = _mm256_fmadd_pd(_mm256_mul_pd(r2, r2), p45, t);
  const __m256d scale = _mm256_castsi256_pd(sbits);
  __m256d y = _mm256_fmadd_pd(scale, tmp, scale);
  if (!_mm256_testz_si256(outside, outside)) {
    alignas(32) double xs[4], ys[4];
    alignas(32) std::int64_t out[4];
    _mm256_store_pd(xs, x);
    _mm256_store_pd(ys, y);
    _mm256_store_si256(reinterpret_cast<__m256i*>(out), outside);
    for (int i = 0; i < 4; ++i) {
      if (out[i] != 0) ys[i] = std::exp(xs[i]);
    }
    y = _mm256_load_pd(ys);
  }
  return y;
}

// the vectorised exp against std::exp on 32768 random arguments: the range the collision RMP uses (which reaches
// every table entry), small ones, and the whole range with its edges
__attribute__((target("avx2,fma"))) bool ExpMatchesLibm() {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> wide(-750.0, 720.0), narrow(-60.0, 1.0), unit(-1.0, 1.0);
  alignas(32) double x[4], y[4];
  for (int n = 0; n < 8192; ++n) {
    for (int i = 0; i < 4; ++i) {
      const int pick = (n + i) % 4;
      x[i] = pick == 0 ? wide(rng) : pick == 1 ? narrow(rng) : pick == 2 ? unit(rng) : unit(rng) * 1e-3;
    }
    _mm256_store_pd(y, Exp4(_mm256_load_pd(x)));
    for (int i = 0; i < 4; ++i) {
      const double want = std::exp(x[i]);
      if (std::memcmp(&want, &y[i], sizeof(double)) != 0) return false;
    }
  }
  return true;
}

}  // namespace

bool CollisionLeafKernelAvailable() {
  static const bool available = CpuHasAvx2Fma() && ExpMatchesLibm();
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
