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
#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <span>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/joint_rmps.h"
#include "rmpmarl/rmp/paper_rmps.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::rmp {

/// What a joint's target accel scale s_a multiplies.
enum class TargetScale {
  /// `acceleration`: the target RMP's whole acceleration, attraction and damping alike (the paper). The overdamped
  /// tracking pole k_p / (ε k_d) and the cruise speed k_p / k_d are then out of the agent's reach.
  kAcceleration,
  /// `stiffness`: the attraction term of eq (5) only, k_p → s_a k_p, the damping unscaled: the agent sets how fast the
  /// arm closes on the target.
  kStiffness,
};

/// The two RMPs of the basic layer.
struct BasicRmpParams {
  TargetRmpParams target;
  CollisionRmpParams collision;
  TargetScale target_scale = TargetScale::kAcceleration;  ///< `rmp.target_scale`
};

/// the target RMP's acceleration with a joint's accel scale s_a applied as `params.target_scale` says: s_a · a, or
/// a + (s_a − 1) · attraction, with `attraction` = TargetAttraction(...) (only eq (5)'s attraction term scaled). Linear
/// in (a, attraction), so it also scales forces M a with M · attraction.
Eigen::Vector3d ScaledTargetAccel(const BasicRmpParams& params, const Eigen::Vector3d& a,
                                  const Eigen::Vector3d& attraction, double accel_scale);

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

/// How the joints' pulled-back RMPs become q̈.
enum class LayerResolve {
  kPerJoint,  ///< `per-joint`: each joint resolves alone through its own column (EvaluateJointLayer; the paper)
  kCoupled,   ///< `coupled`: one n × n resolve of every joint's terms with their coupling (EvaluateCoupledLayer)
};

/// Buffers of EvaluateCoupledLayer for an nq-joint robot (sized once; the evaluation allocates nothing).
struct CoupledLayerWorkspace {
  explicit CoupledLayerWorkspace(int nq);
  Eigen::MatrixXd A;                  ///< the resolved metric, nq × nq
  Eigen::VectorXd b;                  ///< the resolved force, nq
  Eigen::VectorXd g;                  ///< one collision leaf's weighted row, nq (the scalar loop's)
  Eigen::Matrix3Xd G;                 ///< the target leaf's weighted Jacobian, 3 × nq
  Eigen::Matrix3Xd MG;                ///< M · G, 3 × nq
  Eigen::LDLT<Eigen::MatrixXd> ldlt;  ///< factorisation of A + λI
  std::vector<char> collision_active;              ///< per joint: it takes collision leaves (use_collision, s_m > 0)
  Eigen::VectorXd sqrt_collision_metric;           ///< per joint: √s_m of its collision leaves
  std::vector<CollisionRmpParams> scaled_collision;  ///< per joint: the collision RMP with its length scale
  Eigen::VectorXd mg;                              ///< one collision leaf's m · g, per dof (the scalar loop's)
  /// evaluate the collision leaves four joints at a time with AVX2 where the CPU has it (the same bits as the scalar
  /// loop; serial chains of revolute joints); false: always the scalar loop
  bool vectorised = true;
  int lane_stride = 0;          ///< nq rounded up to a multiple of 4
  std::vector<double> lanes;    ///< the vectorised leaves' per-joint arrays (and b), lane_stride entries each
  std::vector<double> lane_A;   ///< A while the vectorised leaves add to it, columns of lane_stride entries
  static constexpr int kLeafBatch = 32;  ///< vectorised leaves evaluated together
  std::vector<double> leaf_scratch;      ///< their per-dof terms, 3 · kLeafBatch · lane_stride entries
  /// true where the vectorised leaves apply to `robot`: every dof a revolute joint of its own and every capsule
  /// moved by dofs 0..k-1 (a serial chain); remembered for the robot last asked about (robots are immutable)
  bool robot_vectorisable(const kinematics::Robot& robot);

 private:
  const kinematics::Robot* checked_robot_ = nullptr;
  bool robot_vectorisable_ = false;
};

/// The basic layer with the joints coupled: the same RMPs, selections and scalings as EvaluateJointLayers, resolved
/// together instead of joint by joint, on top of a structure (f₀, M₀) — the pulled-back C-space RMPs that hold a
/// redundant arm together (RMPflow's C-space target and damping, joint limits, velocity cap and self-collision,
/// RmpflowPolicy::EvaluateStructure). With w_ki = √(s_m) of joint i's scaling of leaf k (0 when joint i does not
/// select the leaf or does not move it), j_ki the leaf's Jacobian column i and f_ki = M_k (s_a a_k) − M_k J̇_k q̇ with
/// joint i's s_a:
///
///   A_ij = M₀_ij + Σ_k w_ki w_kj j_kiᵀ M_k j_kj,   b_i = f₀_i + Σ_k w_ki² j_kiᵀ f_ki,
///   q̈ = (A + λI)⁻¹ b,   λ = relative_regularizer · (1 + trace(A)/n)   (rmp.h's rule).
///
/// Without the structure and A's off-diagonal terms this is exactly the per-joint layer, so an agent's action means
/// the same under both resolves; with every weight 1 it is RMPflow (Cheng et al. 2018, eqs 2–3: pullback and
/// resolve of every leaf). Allocates nothing.
/// \pre as EvaluateJointLayers; workspace built for robot.model.nq();
/// f0, qdd have nq entries, M0 is nq × nq.
void EvaluateCoupledLayer(const kinematics::Robot& robot, const kinematics::Data& kin, const Scene& scene,
                          const BasicRmpParams& params, std::span<const JointLayerWeights> weights,
                          const Eigen::Ref<const Eigen::VectorXd>& f0, const Eigen::Ref<const Eigen::MatrixXd>& M0,
                          double relative_regularizer,
                          CoupledLayerWorkspace* workspace, Eigen::Ref<Eigen::VectorXd> qdd);

}  // namespace rmpmarl::rmp
