// Configuration-space RMPs of the RMPflow baseline: C-space target, damping, joint limits, velocity cap.
#include "rmpmarl/rmp/joint_rmps.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {
namespace {

// largest (|q̇| − v_c)/v_r used in the velocity-cap metric (keeps the metric finite)
constexpr double kVelocityCapMaxRatio = 0.99;

// throws InputError unless value is finite and satisfies the named bound.
void Check(std::string_view where, std::string_view key, double value, bool ok, std::string_view expected) {
  if (!std::isfinite(value) || !ok) {
    throw InputError(fmt::format("{}.{}: expected a finite number {}, got {}", where, key, expected, value));
  }
}

}  // namespace

void ValidateCSpaceTargetRmpParams(const CSpaceTargetRmpParams& p, std::string_view where) {
  Check(where, "metric_scalar", p.metric_scalar, p.metric_scalar >= 0.0, ">= 0");
  Check(where, "position_gain", p.position_gain, p.position_gain >= 0.0, ">= 0");
  Check(where, "damping_gain", p.damping_gain, p.damping_gain >= 0.0, ">= 0");
  Check(where, "robust_position_term_thresh", p.robust_position_term_thresh, p.robust_position_term_thresh > 0.0,
        "> 0");
  Check(where, "inertia", p.inertia, p.inertia >= 0.0, ">= 0");
}

void ValidateCSpaceDampingRmpParams(const CSpaceDampingRmpParams& p, std::string_view where) {
  Check(where, "accel_d_gain", p.accel_d_gain, p.accel_d_gain >= 0.0, ">= 0");
  Check(where, "metric_scalar", p.metric_scalar, p.metric_scalar >= 0.0, ">= 0");
}

void ValidateJointLimitRmpParams(const JointLimitRmpParams& p, std::string_view where) {
  Check(where, "metric_scalar", p.metric_scalar, p.metric_scalar >= 0.0, ">= 0");
  Check(where, "metric_length_scale", p.metric_length_scale, p.metric_length_scale > 0.0, "> 0");
  Check(where, "metric_exploder_eps", p.metric_exploder_eps, p.metric_exploder_eps > 0.0, "> 0");
  Check(where, "metric_velocity_gate_length_scale", p.metric_velocity_gate_length_scale,
        p.metric_velocity_gate_length_scale > 0.0, "> 0");
  Check(where, "accel_damper_gain", p.accel_damper_gain, p.accel_damper_gain >= 0.0, ">= 0");
  Check(where, "accel_potential_gain", p.accel_potential_gain, p.accel_potential_gain >= 0.0, ">= 0");
  Check(where, "accel_potential_exploder_length_scale", p.accel_potential_exploder_length_scale,
        p.accel_potential_exploder_length_scale > 0.0, "> 0");
  Check(where, "accel_potential_exploder_eps", p.accel_potential_exploder_eps, p.accel_potential_exploder_eps > 0.0,
        "> 0");
}

void ValidateJointVelocityCapRmpParams(const JointVelocityCapRmpParams& p, std::string_view where) {
  Check(where, "max_velocity", p.max_velocity, p.max_velocity > 0.0, "> 0");
  Check(where, "velocity_damping_region", p.velocity_damping_region,
        p.velocity_damping_region > 0.0 && p.velocity_damping_region <= p.max_velocity, "in (0, max_velocity]");
  Check(where, "damping_gain", p.damping_gain, p.damping_gain >= 0.0, ">= 0");
  Check(where, "metric_weight", p.metric_weight, p.metric_weight >= 0.0, ">= 0");
}

void RobustCap(const Eigen::Ref<const Eigen::VectorXd>& p, double threshold, Eigen::Ref<Eigen::VectorXd> out) {
  const double norm = p.norm();
  if (norm < threshold) {
    out = p;
  } else {
    out = (threshold / norm) * p;
  }
}

double EvalCSpaceTargetRmp(const CSpaceTargetRmpParams& p, const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Ref<const Eigen::VectorXd>& q0,
                           Eigen::Ref<Eigen::VectorXd> f) {
  f = q0 - q;
  RobustCap(f, p.robust_position_term_thresh, f);
  f = p.metric_scalar * (p.position_gain * f - p.damping_gain * qd);
  return p.metric_scalar + p.inertia;
}

double EvalCSpaceTargetRmp(const CSpaceTargetRmpParams& p, const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Ref<const Eigen::VectorXd>& q0,
                           const Eigen::Ref<const Eigen::VectorXd>& qd0, Eigen::Ref<Eigen::VectorXd> f) {
  const double s = EvalCSpaceTargetRmp(p, q, qd, q0, f);
  f.noalias() += (p.metric_scalar * p.damping_gain) * qd0;
  return s;
}

double EvalCSpaceTargetRmp(const CSpaceTargetRmpParams& p, const Eigen::Ref<const Eigen::VectorXd>& q,
                           const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Ref<const Eigen::VectorXd>& q0,
                           const Eigen::Ref<const Eigen::VectorXd>& qd0, const Eigen::Ref<const Eigen::VectorXd>& qdd0,
                           Eigen::Ref<Eigen::VectorXd> f) {
  const double s = EvalCSpaceTargetRmp(p, q, qd, q0, qd0, f);
  f.noalias() += p.metric_scalar * qdd0;
  return s;
}

Rmp1 EvalJointLimitRmp(const JointLimitRmpParams& p, double x, double xd) {
  const double xc = std::max(x, 0.0);
  const double lp = p.accel_potential_exploder_length_scale;
  Rmp1 rmp;
  rmp.a = p.accel_potential_gain / (xc * xc / (lp * lp) + p.accel_potential_exploder_eps) - p.accel_damper_gain * xd;
  // 1 − 1/(1 + exp(−ẋ/v_m)) = 1/(1 + exp(ẋ/v_m)): the metric turns on when moving towards the boundary
  const double gate = 1.0 / (1.0 + std::exp(xd / p.metric_velocity_gate_length_scale));
  rmp.m = gate * p.metric_scalar / (xc / p.metric_length_scale + p.metric_exploder_eps);
  return rmp;
}

Rmp1 EvalJointVelocityCapRmp(const JointVelocityCapRmpParams& p, double v_max, double qd) {
  const double v_r = std::min(p.velocity_damping_region, v_max);
  const double v_c = v_max - v_r;
  const double excess = std::abs(qd) - v_c;
  Rmp1 rmp;
  if (excess < 0.0) return rmp;
  rmp.a = -p.damping_gain * (qd > 0.0 ? 1.0 : -1.0) * excess;
  const double ratio = std::min(excess / v_r, kVelocityCapMaxRatio);
  rmp.m = p.metric_weight / (1.0 - ratio * ratio);
  return rmp;
}

}  // namespace rmpmarl::rmp
