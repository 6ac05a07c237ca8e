#pragma once
// Internal to the rmp module: the coupled layer's collision leaves four joints (or leaves) at a time with AVX2, the
// same terms as the scalar loop of EvaluateCoupledLayer (joint_layer.cc, AddCollisionLeaves) up to rounding. The
// scalar loop evaluates one exponential per joint and leaf (the repulsion at the joint's length scale) and one per
// leaf (its velocity gate), the bulk of the layer's extra cost over RMPflow; here they run four at a time with an exp
// of our own (within 2 ulp of the exact value; collision_leaf_simd_test.cc).
//
// Available on a CPU with AVX2 and FMA; elsewhere the scalar loop runs.

namespace rmpmarl::rmp::internal {

/// the joints' inputs, one array per quantity, lane i = dof i, each padded to a multiple of 4 entries
struct CollisionLeafLanes {
  const double* repulsion_std_dev;  ///< l_p at the joint's length scale
  const double* damping_std_dev;    ///< l_d at the joint's length scale
  const double* metric_scale;       ///< s_m
  const double* accel_scale;        ///< s_a
  const double* sqrt_metric_scale;  ///< √s_m (0 where inactive)
  const double* active;             ///< all bits set where the joint takes the leaf, 0 where not
  const double* axis[3];            ///< the joint axis in the world frame, x, y, z
  const double* origin[3];          ///< the joint origin in the world frame, x, y, z
};

/// the collision RMP's constants (eqs 8–9), shared by every leaf
struct CollisionLeafConstants {
  double repulsion_gain;       ///< repulsion_gain
  double damping_gain;         ///< damping_gain
  double damping_eps;          ///< damping_robustness_eps
  double velocity_gate;        ///< damping_velocity_gate_length_scale
  double radius;               ///< metric_modulation_radius r
  double metric_scalar;        ///< metric_scalar
  double exploder_std_dev;     ///< metric_exploder_std_dev
  double exploder_eps;         ///< metric_exploder_eps
};

/// up to kCapacity collision leaves, one array per quantity (what does not depend on the joint)
struct CollisionLeafBatch {
  static constexpr int kCapacity = 32;
  int count = 0;
  int k[kCapacity];        ///< leaf l moves dofs 0..k-1
  double xc[kCapacity];    ///< max(d, 0)
  double xd[kCapacity];    ///< ḋ relative to the obstacle
  double jdqd[kCapacity];  ///< J̇q̇ of the distance
  double n[3][kCapacity];  ///< ∂d/∂p_W1
  double p[3][kCapacity];  ///< the witness point p_W1
  // written by CollisionLeavesAvx2
  double m[kCapacity];              ///< the metric (CollisionRmpMetric)
  double damping_force[kCapacity];  ///< (damping gain · σ(ḋ)) · ḋ
};

/// true where the kernel runs: AVX2 and FMA present
bool CollisionLeafKernelAvailable();

/// The coupled layer's update for the batch's leaves, in order, as the scalar loop does it leaf by leaf (up to
/// rounding): each leaf's
/// velocity gate σ and metric m (CollisionVelocityGate, CollisionRmpMetric); then for leaf l and each of its dofs
/// i < k, g_i = √s_m j_i (0 where inactive), mg_i = m g_i, b_i += s_m j_i m (s_a a_i − J̇q̇) where active, with
/// j_i = n · (axis_i × (p − origin_i)) and a_i the collision acceleration at dof i's length scales; then
/// A(i, j) += g_j mg_i for i, j < k. The lanes, b and A's columns (column-major, leading dimension lda) have `stride`
/// entries, k rounded up to a multiple of 4 or more (the entries past k keep their bits); scratch has
/// 3 · kCapacity · stride. \pre CollisionLeafKernelAvailable().
void CollisionLeavesAvx2(CollisionLeafBatch* batch, const CollisionLeafConstants& constants,
                         const CollisionLeafLanes& lanes, int stride, double* scratch, double* b, double* A, int lda);

/// A(i, j) += g0_i m0_j + g1_i m1_j + g2_i m2_j for i, j < n (the target leaf's Gᵀ (M G) in EvaluateCoupledLayer),
/// where g0..g2 are the rows of G (3 × n) laid out as lanes and
/// m0..m2 the rows of M (3 × n, column-major). The lanes and A's columns (leading dimension lda) have room
/// for n rounded up to a multiple of 4; rows of A past n get unspecified values. \pre CollisionLeafKernelAvailable().
void AddGramAvx2(const double* const g[3], const double* M, int n, double* A, int lda);

/// exp of n values with the vectorised exp (lanes outside [−708, 709] and NaN by std::exp); for tests.
/// \pre CollisionLeafKernelAvailable().
void ExpAvx2(const double* x, double* y, int n);

}  // namespace rmpmarl::rmp::internal
