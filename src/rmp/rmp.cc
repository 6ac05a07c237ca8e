// RMP algebra: natural/canonical forms, pushforward, pullback, addition and the regularised LDLT resolve.
#include "rmpmarl/rmp/rmp.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {
namespace {

// throws InputError unless the RMP's force and metric sizes agree.
void CheckRmp(const NaturalRmp& rmp, std::string_view what) {
  if (rmp.M.rows() != rmp.f.size() || rmp.M.cols() != rmp.f.size()) {
    throw InputError(fmt::format("{}: metric must be {}x{} to match the force, got {}x{}", what, rmp.f.size(),
                                 rmp.f.size(), rmp.M.rows(), rmp.M.cols()));
  }
}

// throws InputError unless the task map's Jacobian and curvature term match its value.
void CheckMap(const TaskMapValue& map, std::string_view what) {
  if (map.J.rows() != map.x.size() || map.Jdot_qd.size() != map.x.size()) {
    throw InputError(fmt::format("{}: task map of dimension {} needs a {}-row Jacobian and J̇q̇ of size {}, got {} "
                                 "rows and {}", what, map.x.size(), map.x.size(), map.x.size(), map.J.rows(),
                                 map.Jdot_qd.size()));
  }
}

}  // namespace

NaturalRmp ToNatural(const CanonicalRmp& rmp) {
  if (rmp.M.rows() != rmp.a.size() || rmp.M.cols() != rmp.a.size()) {
    throw InputError(fmt::format("ToNatural: metric must be {}x{}, got {}x{}", rmp.a.size(), rmp.a.size(),
                                 rmp.M.rows(), rmp.M.cols()));
  }
  return {rmp.M * rmp.a, rmp.M};
}

CanonicalRmp ToCanonical(const NaturalRmp& rmp, const ResolveOptions& options) {
  return {Resolve(rmp, options), rmp.M};
}

Eigen::VectorXd PushForwardVelocity(const TaskMapValue& map, const Eigen::Ref<const Eigen::VectorXd>& qd) {
  if (map.J.cols() != qd.size()) {
    throw InputError(fmt::format("PushForwardVelocity: Jacobian has {} columns but q̇ has {} entries", map.J.cols(),
                                 qd.size()));
  }
  return map.J * qd;
}

NaturalRmp Pullback(const TaskMapValue& map, const NaturalRmp& rmp) {
  CheckMap(map, "Pullback");
  CheckRmp(rmp, "Pullback");
  if (rmp.f.size() != map.x.size()) {
    throw InputError(fmt::format("Pullback: RMP of dimension {} on a task map of dimension {}", rmp.f.size(),
                                 map.x.size()));
  }
  NaturalRmp out{Eigen::VectorXd::Zero(map.J.cols()), Eigen::MatrixXd::Zero(map.J.cols(), map.J.cols())};
  PullbackAccumulate(map.J, map.Jdot_qd, rmp.f, rmp.M, out.f, out.M);
  return out;
}

NaturalRmp Add(const NaturalRmp& a, const NaturalRmp& b) {
  CheckRmp(a, "Add");
  CheckRmp(b, "Add");
  if (a.f.size() != b.f.size()) {
    throw InputError(fmt::format("Add: RMPs live in spaces of dimension {} and {}", a.f.size(), b.f.size()));
  }
  return {a.f + b.f, a.M + b.M};
}

double ResolveRegularizer(const Eigen::Ref<const Eigen::MatrixXd>& M, const ResolveOptions& options) {
  const double n = static_cast<double>(std::max<Eigen::Index>(M.rows(), 1));
  return options.relative_regularizer * (1.0 + M.trace() / n);
}

Eigen::VectorXd Resolve(const NaturalRmp& rmp, const ResolveOptions& options) {
  CheckRmp(rmp, "Resolve");
  RmpResolver resolver(static_cast<int>(rmp.f.size()), options);
  Eigen::VectorXd a(rmp.f.size());
  resolver.Solve(rmp.M, rmp.f, a);
  return a;
}

void PullbackAccumulate(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& Jdot_qd,
                        const Eigen::Ref<const Eigen::VectorXd>& f, const Eigen::Ref<const Eigen::MatrixXd>& M,
                        Eigen::Ref<Eigen::VectorXd> f_parent, Eigen::Ref<Eigen::MatrixXd> M_parent) {
  RMPMARL_DASSERT(J.rows() == f.size() && J.rows() == Jdot_qd.size() && M.rows() == f.size() &&
                      M.cols() == f.size() && J.cols() == f_parent.size() && M_parent.rows() == f_parent.size() &&
                      M_parent.cols() == f_parent.size(),
                  "PullbackAccumulate: size mismatch");
  const Eigen::Index dim = J.rows();
  if (dim == 1) {
    const double m = M(0, 0);
    const double g = f[0] - m * Jdot_qd[0];
    f_parent.noalias() += g * J.row(0).transpose();
    M_parent.noalias() += m * J.row(0).transpose() * J.row(0);
    return;
  }
  // f − M J̇q̇, then M_parent += Jᵀ (M J) one column of M J at a time, all without temporaries on the heap
  constexpr Eigen::Index kSmall = 8;
  for (Eigen::Index r = 0; r < dim; ++r) {
    double g = f[r];
    for (Eigen::Index c = 0; c < dim; ++c) g -= M(r, c) * Jdot_qd[c];
    f_parent.noalias() += g * J.row(r).transpose();
  }
  if (dim > kSmall) {
    for (Eigen::Index r = 0; r < dim; ++r) {
      for (Eigen::Index c = 0; c < dim; ++c) {
        const double m = M(r, c);
        if (m != 0.0) M_parent.noalias() += m * J.row(r).transpose() * J.row(c);
      }
    }
    return;
  }
  const Eigen::Index n = J.cols();
  double mj[kSmall];
  for (Eigen::Index c = 0; c < n; ++c) {
    bool any = false;
    for (Eigen::Index k = 0; k < dim; ++k) {
      double v = 0.0;
      for (Eigen::Index l = 0; l < dim; ++l) v += M(k, l) * J(l, c);
      mj[k] = v;
      any = any || v != 0.0;
    }
    if (!any) continue;
    for (Eigen::Index r = 0; r < n; ++r) {
      double v = 0.0;
      for (Eigen::Index k = 0; k < dim; ++k) v += J(k, r) * mj[k];
      M_parent(r, c) += v;
    }
  }
}

RmpResolver::RmpResolver(int n, const ResolveOptions& options) : options_(options), M_reg_(n, n), ldlt_(n) {
  if (n < 0) throw InputError(fmt::format("RmpResolver: dimension must be >= 0, got {}", n));
  if (!(options.relative_regularizer > 0.0) || !std::isfinite(options.relative_regularizer)) {
    throw InputError(fmt::format("resolve: relative_regularizer must be a finite number > 0, got {}",
                                 options.relative_regularizer));
  }
}

double RmpResolver::Solve(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& f,
                          Eigen::Ref<Eigen::VectorXd> a) {
  RMPMARL_DASSERT(M.rows() == size() && M.cols() == size() && f.size() == size() && a.size() == size(),
                  "RmpResolver::Solve: size mismatch");
  const double lambda = ResolveRegularizer(M, options_);
  M_reg_ = M;
  M_reg_.diagonal().array() += lambda;
  ldlt_.compute(M_reg_);
  a = f;
  ldlt_.solveInPlace(a);
  return lambda;
}

}  // namespace rmpmarl::rmp
