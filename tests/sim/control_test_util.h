#pragma once
// Acceleration policies with known output for the controller and closed-loop tests.
#include <Eigen/Core>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "rmpmarl/control/controller.h"

namespace rmpmarl::sim::testing {

// q̈ = a, a constant vector (NaN entries allowed: the controller must catch them).
class ConstantPolicy final : public control::AccelerationPolicy {
 public:
  explicit ConstantPolicy(Eigen::VectorXd a) : a_(std::move(a)) {}
  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const Eigen::VectorXd>&,
                const rmp::Scene&, Eigen::Ref<Eigen::VectorXd> qdd) override {
    ++calls;
    qdd = a_;
  }
  std::string name() const override { return "constant"; }
  int nq() const override { return static_cast<int>(a_.size()); }
  Eigen::VectorXd a_;
  long calls = 0;
};

// q̈ = −k q̇: brakes and then holds still whatever happens around it (a robot that cannot avoid anything).
class HoldPolicy final : public control::AccelerationPolicy {
 public:
  explicit HoldPolicy(int nq, double k = 20.0) : nq_(nq), k_(k) {}
  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>&, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene&, Eigen::Ref<Eigen::VectorXd> qdd) override {
    qdd = -k_ * qd;
  }
  std::string name() const override { return "hold"; }
  int nq() const override { return nq_; }

 private:
  int nq_;
  double k_;
};

// RMPflow for the first `good_calls` evaluations, then NaN (or +inf) in one joint.
class FailingPolicy final : public control::AccelerationPolicy {
 public:
  FailingPolicy(std::unique_ptr<control::AccelerationPolicy> inner, long good_calls, bool infinity = false)
      : inner_(std::move(inner)), good_calls_(good_calls), infinity_(infinity) {}
  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override {
    inner_->Evaluate(q, qd, scene, qdd);
    if (calls_++ >= good_calls_) {
      qdd[qdd.size() - 1] = infinity_ ? std::numeric_limits<double>::infinity()
                                      : std::numeric_limits<double>::quiet_NaN();
    }
  }
  void Reset(const Eigen::Ref<const Eigen::VectorXd>& q0) override {
    calls_ = 0;
    inner_->Reset(q0);
  }
  std::string name() const override { return "failing"; }
  int nq() const override { return inner_->nq(); }

 private:
  std::unique_ptr<control::AccelerationPolicy> inner_;
  long good_calls_;
  bool infinity_;
  long calls_ = 0;
};

}  // namespace rmpmarl::sim::testing
