#pragma once
/// The basic movement layer at one joint (paper §III.B–C): the per-joint agents replace RMPflow's pullback through
/// the whole tree. For joint i, the selected RMPs — the target RMP (eqs 5–7) at the end effector and/or the
/// collision RMPs (eqs 8–9) at the witness points of the capsules that joint i moves, against every obstacle — are
/// scaled by the agent's gain/metric factors and pulled back through joint i's OWN Jacobian column j_i only:
///
///   q̈_i = Σ_k j_kᵀ (f_k − M_k J̇_k q̇) / (Σ_k j_kᵀ M_k j_k + λ),   f_k = M_k a_k,
///   λ = relative_regularizer · (1 + Σ_k j_kᵀ M_k j_k)   (rmp.h's rule for n = 1),
///
/// where for the target j_k is column i of J_WE (3 × 1), a_k = s_a · a_target, M_k = s_m · M_target, and for a
/// collision pair j_k = g n_Wᵀ (column i of J_WP1) with a_k = s_a · a, M_k = s_m · m; J̇_k q̇ is the full curvature
/// term of the task given all joint velocities (the same one the tree uses, see tree.h).
#include <Eigen/Core>
#include <span>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/paper_rmps.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::rmp {

/// The two RMPs of the basic layer.
struct BasicRmpParams {
  TargetRmpParams target;
  CollisionRmpParams collision;
};

/// Which RMPs a joint's agent selects, and its scalings (the meta-behaviour layer's action).
struct JointLayerWeights {
  bool use_target = true;                ///< target RMP at the end effector
  bool use_collision = true;             ///< collision RMPs at the witness points of the capsules joint i moves
  double target_accel_scale = 1.0;       ///< s_a of the target RMP (scales its acceleration)
  double target_metric_scale = 1.0;      ///< s_m of the target RMP (scales its metric), ≥ 0
  double collision_accel_scale = 1.0;    ///< s_a of the collision RMPs
  double collision_metric_scale = 1.0;   ///< s_m of the collision RMPs, ≥ 0
  /// s_l: multiplies the length scales l_p and l_d of the collision RMPs' acceleration (eq 8: repulsion_std_dev,
  /// damping_std_dev), i.e. how far ahead repulsion and damping reach; > 0 (1: the configured RMP)
  double collision_length_scale = 1.0;
};

/// the collision RMP (eqs 8–9) with its acceleration length scales l_p, l_d multiplied by `length_scale` (the metric
/// is unchanged).
Rmp1 EvalScaledCollisionRmp(const CollisionRmpParams& params, double x, double xd, double length_scale);

/// Result of the basic layer at one joint.
struct JointLayerResult {
  double qdd = 0.0;          ///< q̈_i
  double force = 0.0;        ///< Σ_k j_kᵀ (f_k − M_k J̇_k q̇)
  double metric = 0.0;       ///< Σ_k j_kᵀ M_k j_k
  double lambda = 0.0;       ///< regulariser used
  int collision_terms = 0;   ///< collision pairs within the deactivation radius r
  /// smallest capsule–obstacle distance among the capsules joint i moves (+inf: none, or use_collision false);
  /// pairs beyond r may report a bounding-sphere lower bound (> r) instead of their distance
  double min_distance = 0.0;
};

/// the basic layer at dof `dof`: selected paper RMPs pulled back through joint i's own Jacobian column and resolved.
/// Allocates nothing.  \pre kinematics::CalcVelocityKinematics(robot.model, q, qd, &kin) for the current state;
/// 0 <= dof < nq; scene valid (ValidateScene); relative_regularizer > 0.
JointLayerResult EvaluateJointLayer(const kinematics::Robot& robot, const kinematics::Data& kin, int dof,
                                    const Scene& scene, const BasicRmpParams& params,
                                    const JointLayerWeights& weights, double relative_regularizer = 1e-6);

/// the basic layer at every joint at once (results[i] equals EvaluateJointLayer at dof i with weights[i], up to
/// rounding), computing each capsule–obstacle distance once instead of once per joint that moves the capsule.
/// Throws InputError unless weights and results have nq entries. Allocates nothing.
/// \pre as EvaluateJointLayer.
void EvaluateJointLayers(const kinematics::Robot& robot, const kinematics::Data& kin, const Scene& scene,
                         const BasicRmpParams& params, std::span<const JointLayerWeights> weights,
                         std::span<JointLayerResult> results, double relative_regularizer = 1e-6);

}  // namespace rmpmarl::rmp
