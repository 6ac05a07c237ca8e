#pragma once
/// The configuration-space RMPs of the RMPflow baseline (Cheng et al. 2018; Isaac Sim / Lula `rmpflow` config):
/// C-space target to a home posture, C-space damping, joint-position limits and joint-velocity cap. Field names are
/// the Lula config names; comments give the symbol used in docs/rmp.md.
#include <Eigen/Core>
#include <string_view>

#include "rmpmarl/rmp/paper_rmps.h"

namespace rmpmarl::rmp {

/// C-space target (`cspace_target_rmp`): a = k_p r(q₀ − q) − k_d q̇ with metric μ I, plus a separate zero-acceleration
/// RMP (a = 0, M = m I) of `inertia` m. r(p) = p for ‖p‖ < θ, θ p/‖p‖ beyond (the robust capping function).
struct CSpaceTargetRmpParams {
  double metric_scalar = 50.0;               ///< μ ≥ 0, `metric_scalar`
  double position_gain = 100.0;              ///< k_p [1/s²] ≥ 0, `position_gain`
  double damping_gain = 50.0;                ///< k_d [1/s] ≥ 0, `damping_gain`
  double robust_position_term_thresh = 0.5;  ///< θ [rad] > 0, `robust_position_term_thresh`
  double inertia = 1.0;                      ///< m ≥ 0, `inertia`
};

/// C-space damping (no Lula counterpart of this name; Lula's `damping_rmp` acts on the end effector): a = −k_d q̇
/// with metric μ I.
struct CSpaceDampingRmpParams {
  double accel_d_gain = 10.0;   ///< k_d [1/s] ≥ 0
  double metric_scalar = 1.0;   ///< μ ≥ 0
};

/// Joint-limit barrier (`joint_limit_rmp`), one 1-D RMP per joint boundary in the normalised coordinate
/// x = (q − q_lower)/(q_upper − q_lower) (lower boundary) or (q_upper − q)/(q_upper − q_lower) (upper boundary):
///   a = k_p/(x²/l_p² + ε_p) − k_d ẋ,   m = [1 − 1/(1 + exp(−ẋ/v_m))] μ/(x/l_m + ε_m).
struct JointLimitRmpParams {
  double metric_scalar = 1000.0;                     ///< μ ≥ 0, `metric_scalar`
  double metric_length_scale = 0.01;                 ///< l_m > 0, `metric_length_scale`
  double metric_exploder_eps = 1e-3;                 ///< ε_m > 0, `metric_exploder_eps`
  double metric_velocity_gate_length_scale = 0.01;   ///< v_m [1/s] > 0, `metric_velocity_gate_length_scale`
  double accel_damper_gain = 200.0;                  ///< k_d [1/s] ≥ 0, `accel_damper_gain`
  double accel_potential_gain = 1.0;                 ///< k_p [1/s²] ≥ 0, `accel_potential_gain`
  double accel_potential_exploder_length_scale = 0.1;  ///< l_p > 0, `accel_potential_exploder_length_scale`
  double accel_potential_exploder_eps = 1e-2;        ///< ε_p > 0, `accel_potential_exploder_eps`
};

/// Joint-velocity cap (`joint_velocity_cap_rmp`), one 1-D RMP per joint on x = q_i, with v_c = v_max − v_r:
///   a = −k_d sgn(q̇)(|q̇| − v_c),   m = 0 for |q̇| < v_c, else μ/(1 − (|q̇| − v_c)²/v_r²)
/// where (|q̇| − v_c)/v_r is clipped to ≤ 0.99 (so m ≤ 50.25 μ). The policy uses v_max = min(max_velocity, URDF
/// limit) and v_r = min(velocity_damping_region, v_max).
struct JointVelocityCapRmpParams {
  double max_velocity = 1.0;              ///< v_max [rad/s] > 0, `max_velocity`
  double velocity_damping_region = 0.3;   ///< v_r [rad/s] in (0, v_max], `velocity_damping_region`
  double damping_gain = 1000.0;           ///< k_d [1/s] ≥ 0, `damping_gain`
  double metric_weight = 100.0;           ///< μ ≥ 0, `metric_weight`
};

/// throws InputError naming `where` unless every field is finite and in range.
void ValidateCSpaceTargetRmpParams(const CSpaceTargetRmpParams& params, std::string_view where);
/// throws InputError naming `where` unless every field is finite and in range.
void ValidateCSpaceDampingRmpParams(const CSpaceDampingRmpParams& params, std::string_view where);
/// throws InputError naming `where` unless every field is finite and in range.
void ValidateJointLimitRmpParams(const JointLimitRmpParams& params, std::string_view where);
/// throws InputError naming `where` unless every field is finite and in range.
void ValidateJointVelocityCapRmpParams(const JointVelocityCapRmpParams& params, std::string_view where);

/// the robust capping function r(p) of the C-space target, written into `out` (may alias p).
void RobustCap(const Eigen::Ref<const Eigen::VectorXd>& p, double threshold, Eigen::Ref<Eigen::VectorXd> out);

/// C-space target plus its inertia term in natural form: f = μ a, and the scalar s of the metric M = s I
/// (s = μ + m). Writes f, returns s.  \pre q, qd, q0 and f have the same size.
double EvalCSpaceTargetRmp(const CSpaceTargetRmpParams& params, const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Ref<const Eigen::VectorXd>& q0,
                           Eigen::Ref<Eigen::VectorXd> f);
/// the same toward a moving target q0 with velocity qd0: a = k_p r(q0 − q) − k_d (q̇ − q̇0) (qd0 = 0: the above).
double EvalCSpaceTargetRmp(const CSpaceTargetRmpParams& params, const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Ref<const Eigen::VectorXd>& q0,
                           const Eigen::Ref<const Eigen::VectorXd>& qd0, Eigen::Ref<Eigen::VectorXd> f);
/// the same with the target's acceleration q̈0 as a feed-forward: a = k_p r(q0 − q) − k_d (q̇ − q̇0) + q̈0, so that a
/// target that speeds up or slows down is tracked without the lag q̈0 / k_p.
double EvalCSpaceTargetRmp(const CSpaceTargetRmpParams& params, const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Ref<const Eigen::VectorXd>& q0,
                           const Eigen::Ref<const Eigen::VectorXd>& qd0, const Eigen::Ref<const Eigen::VectorXd>& qdd0,
                           Eigen::Ref<Eigen::VectorXd> f);

/// joint-limit RMP at normalised distance x to one boundary and its rate ẋ. x is clamped to ≥ 0 (at or past the
/// boundary the RMP keeps its contact values, no NaN/Inf).
Rmp1 EvalJointLimitRmp(const JointLimitRmpParams& params, double x, double xd);

/// joint-velocity-cap RMP for joint velocity q̇ and cap v_max > 0 (v_r = min(velocity_damping_region, v_max)).
Rmp1 EvalJointVelocityCapRmp(const JointVelocityCapRmpParams& params, double v_max, double qd);

}  // namespace rmpmarl::rmp
