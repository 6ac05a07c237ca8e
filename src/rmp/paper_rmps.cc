// The paper's target RMP (eqs 5–7) and collision-avoidance RMP (eqs 8–9).
#include "rmpmarl/rmp/paper_rmps.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {
namespace {

// below this target distance [m] the direction to the target is undefined and S is taken as 0
constexpr double kOnTargetDistance = 1e-12;

// throws InputError unless value is finite and satisfies the named bound.
void Check(std::string_view where, std::string_view key, double value, bool ok, std::string_view expected) {
  if (!std::isfinite(value) || !ok) {
    throw InputError(fmt::format("{}.{}: expected a finite number {}, got {}", where, key, expected, value));
  }
}

}  // namespace

std::string_view TargetDampingName(TargetDamping damping) {
  return damping == TargetDamping::kQuadratic ? "quadratic" : "linear";
}

void ValidateTargetRmpParams(const TargetRmpParams& p, std::string_view where) {
  Check(where, "accel_p_gain", p.accel_p_gain, p.accel_p_gain >= 0.0, ">= 0");
  Check(where, "accel_d_gain", p.accel_d_gain, p.accel_d_gain >= 0.0, ">= 0");
  Check(where, "accel_norm_eps", p.accel_norm_eps, p.accel_norm_eps > 0.0, "> 0");
  Check(where, "metric_alpha_length_scale", p.metric_alpha_length_scale, p.metric_alpha_length_scale > 0.0, "> 0");
  Check(where, "min_metric_alpha", p.min_metric_alpha, p.min_metric_alpha >= 0.0 && p.min_metric_alpha <= 1.0,
        "in [0, 1]");
  Check(where, "max_metric_scalar", p.max_metric_scalar, p.max_metric_scalar >= 0.0, ">= 0");
  Check(where, "min_metric_scalar", p.min_metric_scalar, p.min_metric_scalar >= 0.0, ">= 0");
  Check(where, "proximity_metric_boost_scalar", p.proximity_metric_boost_scalar,
        p.proximity_metric_boost_scalar >= 0.0, ">= 0");
  Check(where, "proximity_metric_boost_length_scale", p.proximity_metric_boost_length_scale,
        p.proximity_metric_boost_length_scale > 0.0, "> 0");
}

void ValidateCollisionRmpParams(const CollisionRmpParams& p, std::string_view where) {
  Check(where, "repulsion_gain", p.repulsion_gain, p.repulsion_gain >= 0.0, ">= 0");
  Check(where, "repulsion_std_dev", p.repulsion_std_dev, p.repulsion_std_dev > 0.0, "> 0");
  Check(where, "damping_gain", p.damping_gain, p.damping_gain >= 0.0, ">= 0");
  Check(where, "damping_std_dev", p.damping_std_dev, p.damping_std_dev > 0.0, "> 0");
  Check(where, "damping_robustness_eps", p.damping_robustness_eps, p.damping_robustness_eps > 0.0, "> 0");
  Check(where, "damping_velocity_gate_length_scale", p.damping_velocity_gate_length_scale,
        p.damping_velocity_gate_length_scale > 0.0, "> 0");
  Check(where, "metric_scalar", p.metric_scalar, p.metric_scalar >= 0.0, ">= 0");
  Check(where, "metric_exploder_std_dev", p.metric_exploder_std_dev, p.metric_exploder_std_dev > 0.0, "> 0");
  Check(where, "metric_exploder_eps", p.metric_exploder_eps, p.metric_exploder_eps > 0.0, "> 0");
  Check(where, "metric_modulation_radius", p.metric_modulation_radius, p.metric_modulation_radius > 0.0, "> 0");
}

Eigen::Vector3d TargetAttraction(const TargetRmpParams& p, const Eigen::Vector3d& x, const Eigen::Vector3d& x0) {
  const Eigen::Vector3d e = x0 - x;  // towards the target
  return p.accel_p_gain / (e.norm() + p.accel_norm_eps) * e;
}

Rmp3 EvalTargetRmp(const TargetRmpParams& p, const Eigen::Vector3d& x, const Eigen::Vector3d& xd,
                   const Eigen::Vector3d& x0) {
  const Eigen::Vector3d e = x0 - x;  // towards the target
  const double d2 = e.squaredNorm();
  const double d = std::sqrt(d2);
  Rmp3 rmp;
  // eq (5): saturated attraction plus damping
  rmp.a = TargetAttraction(p, x, x0);
  if (p.damping == TargetDamping::kQuadratic) {
    rmp.a -= p.accel_d_gain * xd.norm() * xd;
  } else {
    rmp.a -= p.accel_d_gain * xd;
  }
  // eqs (6)–(7): directional far metric blended into the isotropic near metric, boosted near the target
  const double sa = p.metric_alpha_length_scale, sb = p.proximity_metric_boost_length_scale;
  const double alpha = (1.0 - p.min_metric_alpha) * std::exp(-d2 / (2.0 * sa * sa)) + p.min_metric_alpha;
  const double beta = std::exp(-d2 / (2.0 * sb * sb));
  const double boost = beta * p.proximity_metric_boost_scalar + (1.0 - beta);
  const double near = boost * alpha * p.max_metric_scalar;
  const double far = d > kOnTargetDistance ? boost * (1.0 - alpha) * p.min_metric_scalar : 0.0;
  const Eigen::Vector3d u = d > kOnTargetDistance ? Eigen::Vector3d(e / d) : Eigen::Vector3d::Zero();
  // element by element so that M(r, c) and M(c, r) are the same floating-point expression (exactly symmetric)
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) rmp.M(r, c) = far * (u[r] * u[c]) + (r == c ? near : 0.0);
  }
  return rmp;
}

double CollisionVelocityGate(double xd, double v_d) { return 1.0 / (1.0 + std::exp(xd / v_d)); }

double CollisionDistanceGate(double x, double r) {
  if (x > r) return 0.0;
  const double s = 1.0 - x / r;
  return s * s;
}

double CollisionRmpAccel(const CollisionRmpParams& p, double x, double xd, double sigma) {
  const double xc = std::max(x, 0.0);  // penetration guard (see the header)
  return p.repulsion_gain * std::exp(-xc / p.repulsion_std_dev) -
         p.damping_gain * sigma * xd / (xc / p.damping_std_dev + p.damping_robustness_eps);
}

double CollisionRmpMetric(const CollisionRmpParams& p, double x, double sigma) {
  const double xc = std::max(x, 0.0);
  return sigma * CollisionDistanceGate(xc, p.metric_modulation_radius) * p.metric_scalar /
         (xc / p.metric_exploder_std_dev + p.metric_exploder_eps);
}

Rmp1 EvalCollisionRmp(const CollisionRmpParams& p, double x, double xd) {
  const double sigma = CollisionVelocityGate(xd, p.damping_velocity_gate_length_scale);
  return Rmp1{CollisionRmpAccel(p, x, xd, sigma), CollisionRmpMetric(p, x, sigma)};
}

}  // namespace rmpmarl::rmp
