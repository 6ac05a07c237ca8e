#pragma once
/// The paper's two RMPs (§III.B): the target RMP, eqs (5)–(7), and the collision-avoidance RMP, eqs (8)–(9).
/// Both return the canonical form (a, M); the natural form is f = M a. Field names are those of the RMPflow
/// configuration files of Isaac Sim / Lula (`target_rmp`, `collision_rmp`), the comment gives the paper's symbol.
#include <Eigen/Core>
#include <string_view>

namespace rmpmarl::rmp {

/// Damping term of the target RMP.
enum class TargetDamping {
  kQuadratic,  ///< −k_d ‖ẋ‖ ẋ, the paper's eq (5) (k_d in 1/m); the default of TargetRmpParams{}
  kLinear,     ///< −k_d ẋ, RMPflow / Lula `target_rmp` (k_d in 1/s); the default of the RMPflow baseline
};

/// "quadratic" or "linear".
std::string_view TargetDampingName(TargetDamping damping);

/// Parameters of the target RMP, eqs (5)–(7). Defaults: Lula's Franka `target_rmp` values with the paper's quadratic
/// damping (k_d = 30 1/m, so the far-field speed sqrt(k_p/k_d) is 1 m/s, Lula's `damping_rmp` gain).
struct TargetRmpParams {
  double accel_p_gain = 30.0;                        ///< k_p [m/s²], `accel_p_gain`
  double accel_d_gain = 30.0;                        ///< k_d [1/m quadratic, 1/s linear], `accel_d_gain`
  TargetDamping damping = TargetDamping::kQuadratic; ///< eq (5) term (quadratic) or RMPflow's (linear)
  double accel_norm_eps = 0.075;                     ///< ε [m] > 0, `accel_norm_eps`
  double metric_alpha_length_scale = 0.05;           ///< σ_a [m] > 0, `metric_alpha_length_scale`
  double min_metric_alpha = 0.01;                    ///< α_min in [0, 1], `min_metric_alpha`
  double max_metric_scalar = 10000.0;                ///< μ_near ≥ 0, `max_metric_scalar`
  double min_metric_scalar = 2500.0;                 ///< μ_far ≥ 0, `min_metric_scalar`
  double proximity_metric_boost_scalar = 20.0;       ///< b ≥ 0, `proximity_metric_boost_scalar`
  double proximity_metric_boost_length_scale = 0.02; ///< σ_b [m] > 0, `proximity_metric_boost_length_scale`
};

/// Parameters of the collision-avoidance RMP, eqs (8)–(9). Defaults: Lula's Franka `collision_rmp` values except
/// μ = 1 (`metric_scalar`), which the paper fixes because the next layer learns the weights.
struct CollisionRmpParams {
  double repulsion_gain = 800.0;                     ///< k_p [m/s²] ≥ 0, `repulsion_gain`
  double repulsion_std_dev = 0.01;                   ///< l_p [m] > 0, `repulsion_std_dev`
  double damping_gain = 50.0;                        ///< k_d [1/s] ≥ 0, `damping_gain`
  double damping_std_dev = 0.04;                     ///< l_d [m] > 0, `damping_std_dev`
  double damping_robustness_eps = 0.01;              ///< ε_d > 0, `damping_robustness_eps`
  double damping_velocity_gate_length_scale = 0.01;  ///< v_d [m/s] > 0, `damping_velocity_gate_length_scale`
  double metric_scalar = 1.0;                        ///< μ ≥ 0, `metric_scalar`
  double metric_exploder_std_dev = 0.02;             ///< l_m [m] > 0, `metric_exploder_std_dev`
  double metric_exploder_eps = 0.001;                ///< ε_m > 0, `metric_exploder_eps`
  double metric_modulation_radius = 0.5;             ///< r [m] > 0, `metric_modulation_radius` (deactivation distance)
};

/// Canonical form of a 3-D RMP.
struct Rmp3 {
  Eigen::Vector3d a = Eigen::Vector3d::Zero();  ///< desired acceleration
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();  ///< metric (symmetric positive semi-definite)
};

/// Canonical form of a 1-D RMP.
struct Rmp1 {
  double a = 0.0;  ///< desired acceleration
  double m = 0.0;  ///< metric (≥ 0)
};

/// throws InputError naming `where` (e.g. "file.yaml: rmp_params.target_rmp") unless every field is finite and in
/// its documented range.
void ValidateTargetRmpParams(const TargetRmpParams& params, std::string_view where);

/// throws InputError naming `where` unless every field is finite and in its documented range.
void ValidateCollisionRmpParams(const CollisionRmpParams& params, std::string_view where);

/// the attraction term of eq (5), k_p (x_0 − x) / (‖x_0 − x‖ + ε): EvalTargetRmp's acceleration without damping.
Eigen::Vector3d TargetAttraction(const TargetRmpParams& params, const Eigen::Vector3d& x, const Eigen::Vector3d& x0);

/// Target RMP at position x with velocity ẋ (relative to the target's) and target x₀:
///   a = k_p (x₀ − x)/(‖x₀ − x‖ + ε) − k_d ‖ẋ‖ ẋ   (eq 5; −k_d ẋ with TargetDamping::kLinear),
///   M = [β b + (1 − β)] [α μ_near I + (1 − α) μ_far S],  S = (x₀ − x)(x₀ − x)ᵀ/‖x₀ − x‖²   (eqs 6–7),
///   α = (1 − α_min) exp(−‖x₀ − x‖²/(2σ_a²)) + α_min,   β = exp(−‖x₀ − x‖²/(2σ_b²)).
/// On the target (‖x₀ − x‖ ≤ 1e-12 m) S is taken as 0: there α = 1 so (1 − α) S vanishes anyway, and no NaN arises.
Rmp3 EvalTargetRmp(const TargetRmpParams& params, const Eigen::Vector3d& x, const Eigen::Vector3d& xd,
                   const Eigen::Vector3d& x0);

/// σ(ẋ) = 1 − 1/(1 + exp(−ẋ/v_d)) of eq (9), evaluated as 1/(1 + exp(ẋ/v_d)) so that it never overflows to NaN.
double CollisionVelocityGate(double xd, double v_d);

/// g(x) = x²/r² − 2x/r + 1 = (1 − x/r)² for x ≤ r, 0 beyond (eq 9).
double CollisionDistanceGate(double x, double r);

/// Collision-avoidance RMP in the 1-D distance space, at signed distance x and its rate ẋ (eq 8):
///   a = k_p exp(−x/l_p) − k_d σ(ẋ) ẋ/(x/l_d + ε_d),   m = σ(ẋ) g(x) μ/(x/l_m + ε_m).
/// Penetration guard: x is clamped to ≥ 0 in every term, so a penetrating witness pair sees the contact values
/// (a ≤ k_p + k_d |ẋ|/ε_d, m ≤ μ/ε_m) and nothing is NaN or Inf.
Rmp1 EvalCollisionRmp(const CollisionRmpParams& params, double x, double xd);

/// eq (8)'s acceleration alone, for a velocity gate σ = CollisionVelocityGate(ẋ, damping_velocity_gate_length_scale)
/// already evaluated: the same bits as EvalCollisionRmp(params, x, xd).a, one exponential fewer.
double CollisionRmpAccel(const CollisionRmpParams& params, double x, double xd, double sigma);

/// eq (9)'s metric alone, for the same σ: the same bits as EvalCollisionRmp(params, x, xd).m.
double CollisionRmpMetric(const CollisionRmpParams& params, double x, double sigma);

}  // namespace rmpmarl::rmp
