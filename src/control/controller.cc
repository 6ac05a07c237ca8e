// ReactiveController: acceleration policy → semi-implicit Euler on the commanded state → position-servo targets.
#include "rmpmarl/control/controller.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"

namespace rmpmarl::control {

AccelerationPolicy::~AccelerationPolicy() = default;

void AccelerationPolicy::Reset(const Eigen::Ref<const Eigen::VectorXd>& /*q0*/) {}

void AccelerationPolicy::BeginControlStep(const Eigen::Ref<const Eigen::VectorXd>& /*q*/,
                                          const Eigen::Ref<const Eigen::VectorXd>& /*qd*/,
                                          const rmp::Scene& /*scene*/) {}

RmpflowAccelerationPolicy::RmpflowAccelerationPolicy(const kinematics::Robot& robot,
                                                     const rmp::RmpflowOptions& options, int max_obstacles)
    : policy_(robot, options, max_obstacles) {}

RmpflowAccelerationPolicy::RmpflowAccelerationPolicy(const kinematics::Robot& robot, int max_obstacles)
    : policy_(robot, rmp::LoadRmpflowOptions(robot), max_obstacles) {}

void RmpflowAccelerationPolicy::Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q,
                                         const Eigen::Ref<const Eigen::VectorXd>& qd, const rmp::Scene& scene,
                                         Eigen::Ref<Eigen::VectorXd> qdd) {
  policy_.Evaluate(q, qd, scene, qdd);
}

int RmpflowAccelerationPolicy::nq() const { return policy_.tree().robot().model.nq(); }

int ControlSubsteps(double period, const ControllerOptions& options) {
  return std::max(1, static_cast<int>(std::ceil(period / options.max_substep - 1e-9)));
}

void ValidateControllerOptions(const ControllerOptions& o, double physics_timestep) {
  if (!std::isfinite(o.control_rate) || !(o.control_rate > 0.0)) {
    throw InputError(fmt::format("ControllerOptions.control_rate: expected a finite rate > 0 Hz, got {}",
                                 o.control_rate));
  }
  if (!std::isfinite(physics_timestep) || !(physics_timestep >= 0.0)) {
    throw InputError(fmt::format("ReactiveController: expected a loop timestep >= 0 s (0: any period), got {}",
                                 physics_timestep));
  }
  if (physics_timestep > 0.0) {
    const double period = 1.0 / o.control_rate;
    const double ratio = period / physics_timestep;
    if (std::round(ratio) < 1.0 || std::abs(ratio - std::round(ratio)) > 1e-6 * ratio) {
      throw InputError(fmt::format("ControllerOptions.control_rate: expected a control period that is a whole number "
                                   "(>= 1) of physics timesteps ({} s, i.e. a rate of {:g} Hz divided by an integer), "
                                   "got {:g} Hz (period / timestep = {:.6g})", physics_timestep,
                                   1.0 / physics_timestep, o.control_rate, ratio));
    }
  }
  if (!std::isfinite(o.max_substep) || !(o.max_substep > 0.0)) {
    throw InputError(fmt::format("ControllerOptions.max_substep: expected a finite step > 0 s, got {}",
                                 o.max_substep));
  }
  if (!std::isfinite(o.velocity_limit_scale) || !(o.velocity_limit_scale > 0.0)) {
    throw InputError(fmt::format("ControllerOptions.velocity_limit_scale: expected a finite number > 0, got {}",
                                 o.velocity_limit_scale));
  }
  if (std::isnan(o.resync_threshold) || !(o.resync_threshold > 0.0)) {
    throw InputError(fmt::format("ControllerOptions.resync_threshold: expected a number > 0 (+inf: never), got {}",
                                 o.resync_threshold));
  }
}

ReactiveController::ReactiveController(const ServoSpec& servos, std::unique_ptr<AccelerationPolicy> policy,
                                       ControllerOptions options)
    : policy_(std::move(policy)), options_(options) {
  if (!policy_) throw InputError("ReactiveController: expected an AccelerationPolicy, got a null pointer");
  const int nq = static_cast<int>(servos.lower.size());
  if (policy_->nq() != nq) {
    throw InputError(fmt::format("ReactiveController: policy '{}' is built for {} joints but robot '{}' has {}",
                                 policy_->name(), policy_->nq(), servos.robot, nq));
  }
  if (servos.upper.size() != nq || servos.velocity.size() != nq ||
      (servos.feedforward.size() != 0 && servos.feedforward.size() != nq)) {
    throw InputError(fmt::format("ReactiveController: expected servos of robot '{}' with {} upper limits, velocity "
                                 "limits and feed-forward ratios (or none), got {}, {} and {}", servos.robot, nq,
                                 servos.upper.size(), servos.velocity.size(), servos.feedforward.size()));
  }
  ValidateControllerOptions(options_, servos.timestep);
  if (servos.timestep > 0.0) {
    physics_steps_ = static_cast<int>(std::lround(1.0 / (options_.control_rate * servos.timestep)));
    period_ = physics_steps_ * servos.timestep;
  } else {
    physics_steps_ = 1;
    period_ = 1.0 / options_.control_rate;
  }
  substeps_ = ControlSubsteps(period_, options_);
  lower_ = servos.lower;
  upper_ = servos.upper;
  v_max_.resize(nq);
  for (int i = 0; i < nq; ++i) {
    const double v = servos.velocity[i];
    v_max_[i] = v > 0.0 ? options_.velocity_limit_scale * v : std::numeric_limits<double>::infinity();
  }
  feedforward_.setZero(nq);
  if (options_.velocity_feedforward && servos.feedforward.size() == nq) feedforward_ = servos.feedforward;
  q_cmd_ = Eigen::VectorXd::Zero(nq).cwiseMax(lower_).cwiseMin(upper_);
  qd_cmd_.setZero(nq);
  qdd_.setZero(nq);
  qdd_cmd_.setZero(nq);
  q_target_ = q_cmd_;
}

void ReactiveController::CheckMeasuredState(const Eigen::Ref<const Eigen::VectorXd>& q,
                                            const Eigen::Ref<const Eigen::VectorXd>& qd, const char* where) const {
  if (q.size() != nq() || qd.size() != nq() || !q.allFinite() || !qd.allFinite()) {
    throw InputError(fmt::format("ReactiveController::{}: expected q and qd with {} finite entries, got sizes {} and "
                                 "{}{}", where, nq(), q.size(), qd.size(),
                                 q.allFinite() && qd.allFinite() ? "" : " with non-finite entries"));
  }
}

void ReactiveController::Reset(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd) {
  CheckMeasuredState(q, qd, "Reset");
  q_cmd_ = q.cwiseMax(lower_).cwiseMin(upper_);
  qd_cmd_ = qd.cwiseMax(-v_max_).cwiseMin(v_max_);
  qdd_.setZero();
  qdd_cmd_.setZero();
  q_target_ = q_cmd_;
  stats_ = ControllerStats{};
  policy_->Reset(q_cmd_);
}

void ReactiveController::Integrate(double h, ControlStepResult* result) {
  for (int i = 0; i < nq(); ++i) {
    double v = qd_cmd_[i] + h * qdd_[i];
    if (v > v_max_[i] || v < -v_max_[i]) {
      v = std::clamp(v, -v_max_[i], v_max_[i]);
      ++result->velocity_clamps;
    }
    double q = q_cmd_[i] + h * v;
    if (q < lower_[i] || q > upper_[i]) {
      q = std::clamp(q, lower_[i], upper_[i]);
      v = 0.0;  // the step pushed outwards, so its velocity points out of the range
      ++result->position_clamps;
    }
    q_cmd_[i] = q;
    qd_cmd_[i] = v;
  }
}

ControlStepResult ReactiveController::Update(const Eigen::Ref<const Eigen::VectorXd>& q,
                                             const Eigen::Ref<const Eigen::VectorXd>& qd, const rmp::Scene& scene) {
  CheckMeasuredState(q, qd, "Update");
  const auto start = std::chrono::steady_clock::now();
  ControlStepResult result;
  if ((q_cmd_ - q).cwiseAbs().maxCoeff() > options_.resync_threshold) {
    q_cmd_ = q.cwiseMax(lower_).cwiseMin(upper_);
    qd_cmd_ = qd.cwiseMax(-v_max_).cwiseMin(v_max_);
    result.resynced = true;
  }
  policy_->BeginControlStep(q, qd, scene);
  qdd_cmd_ = qd_cmd_;  // the period's start (after a resync)
  const double h = substep();
  for (int s = 0; s < substeps_; ++s) {
    if (options_.policy_input == PolicyInput::kCommanded) {
      policy_->Evaluate(q_cmd_, qd_cmd_, scene, qdd_);
    } else if (s == 0) {
      policy_->Evaluate(q, qd, scene, qdd_);
    }
    if (!qdd_.allFinite()) {
      // never let it reach MuJoCo: hold the last commanded position
      qd_cmd_.setZero();
      result.finite = false;
      break;
    }
    Integrate(h, &result);
  }
  q_target_ = q_cmd_ + feedforward_.cwiseProduct(qd_cmd_);
  if (result.finite) {
    qdd_cmd_ = (qd_cmd_ - qdd_cmd_) / period_;
  } else {
    qdd_cmd_.setZero();  // holding position: no feed-forward of the velocity dropped to zero
  }
  const double us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  result.compute_us = us;
  ++stats_.steps;
  stats_.nonfinite_outputs += result.finite ? 0 : 1;
  stats_.resyncs += result.resynced ? 1 : 0;
  stats_.position_clamps += result.position_clamps;
  stats_.velocity_clamps += result.velocity_clamps;
  stats_.total_compute_us += us;
  stats_.max_compute_us = std::max(stats_.max_compute_us, us);
  return result;
}

}  // namespace rmpmarl::control
