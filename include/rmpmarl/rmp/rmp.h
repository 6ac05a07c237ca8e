#pragma once
/// RMP algebra (paper §II.A, eqs (2)–(3); Ratliff et al. 2018, Cheng et al. 2018): an RMP in natural form (f, M) or
/// canonical form (a, M) with f = M a, a task map x = φ(q) with Jacobian J and curvature term J̇q̇, and the three
/// operators — pushforward (x, ẋ = J q̇), pullback (f_q = Jᵀ(f − M J̇q̇), M_q = JᵀMJ) and addition — plus the resolve
/// q̈ = M_q⁺ f_q.
///
/// Resolve regulariser: q̈ = (M_q + λI)⁻¹ f_q by LDLT (never a dense SVD pseudo-inverse), with
///   λ = relative_regularizer · (1 + trace(M_q)/n),   relative_regularizer = 1e-6 by default.
/// λ follows the scale of the metric (RMPflow metrics span 1 to 1e4), caps the condition number near 1e6 and, where
/// M_q is rank deficient, gives the damped least-squares solution (→ the pseudo-inverse solution as λ → 0).
///
/// The value types here (NaturalRmp, CanonicalRmp, TaskMapValue) allocate and are meant for tests, tools and small
/// experiments; the hot path (rmp::Tree, the RMPflow policy) uses the allocation-free PullbackAccumulate and
/// RmpResolver below.
#include <Eigen/Core>
#include <Eigen/Cholesky>

namespace rmpmarl::rmp {

/// An RMP in natural form (f, M): desired force f and metric M (symmetric positive semi-definite), both in one space.
struct NaturalRmp {
  Eigen::VectorXd f;
  Eigen::MatrixXd M;
};

/// An RMP in canonical form (a, M): desired acceleration a with its metric M; f = M a.
struct CanonicalRmp {
  Eigen::VectorXd a;
  Eigen::MatrixXd M;
};

/// A task map evaluated at (q, q̇): x = φ(q), J = ∂φ/∂q (eq 2), and the curvature term J̇q̇ (eq 3).
struct TaskMapValue {
  Eigen::VectorXd x;
  Eigen::MatrixXd J;
  Eigen::VectorXd Jdot_qd;
};

/// Options of the resolve q̈ = (M + λI)⁻¹ f.
struct ResolveOptions {
  /// λ = relative_regularizer · (1 + trace(M)/n); must be > 0 (see the file comment).
  double relative_regularizer = 1e-6;
};

/// natural form of a canonical RMP: f = M a.
NaturalRmp ToNatural(const CanonicalRmp& rmp);

/// canonical form of a natural RMP: a = (M + λI)⁻¹ f (regularised as in Resolve).
CanonicalRmp ToCanonical(const NaturalRmp& rmp, const ResolveOptions& options = {});

/// pushforward of the configuration-space state through a task map: ẋ = J q̇ (x is map.x).
Eigen::VectorXd PushForwardVelocity(const TaskMapValue& map, const Eigen::Ref<const Eigen::VectorXd>& qd);

/// pullback of a task-space RMP through a task map: f_q = Jᵀ(f − M J̇q̇), M_q = JᵀMJ.
NaturalRmp Pullback(const TaskMapValue& map, const NaturalRmp& rmp);

/// sum of two RMPs in the same space: (f₁ + f₂, M₁ + M₂). Throws InputError on mismatched sizes.
NaturalRmp Add(const NaturalRmp& a, const NaturalRmp& b);

/// the regulariser λ of the resolve for metric M (see the file comment).
double ResolveRegularizer(const Eigen::Ref<const Eigen::MatrixXd>& M, const ResolveOptions& options = {});

/// resolve: q̈ = (M + λI)⁻¹ f by LDLT.
Eigen::VectorXd Resolve(const NaturalRmp& rmp, const ResolveOptions& options = {});

/// allocation-free pullback-and-add: f_parent += Jᵀ(f − M J̇q̇), M_parent += JᵀMJ.
/// \pre sizes agree: J is dim × n, f and Jdot_qd have dim entries, M is dim × dim, f_parent n, M_parent n × n.
void PullbackAccumulate(const Eigen::Ref<const Eigen::MatrixXd>& J, const Eigen::Ref<const Eigen::VectorXd>& Jdot_qd,
                        const Eigen::Ref<const Eigen::VectorXd>& f, const Eigen::Ref<const Eigen::MatrixXd>& M,
                        Eigen::Ref<Eigen::VectorXd> f_parent, Eigen::Ref<Eigen::MatrixXd> M_parent);

/// Resolves n-dimensional natural RMPs without heap allocation (buffers sized at construction).
class RmpResolver {
 public:
  explicit RmpResolver(int n, const ResolveOptions& options = {});
  int size() const { return static_cast<int>(M_reg_.rows()); }
  const ResolveOptions& options() const { return options_; }
  /// a = (M + λI)⁻¹ f; returns λ.  \pre f.size() == M.rows() == M.cols() == a.size() == size().
  double Solve(const Eigen::Ref<const Eigen::MatrixXd>& M, const Eigen::Ref<const Eigen::VectorXd>& f,
               Eigen::Ref<Eigen::VectorXd> a);

 private:
  ResolveOptions options_;
  Eigen::MatrixXd M_reg_;
  Eigen::LDLT<Eigen::MatrixXd> ldlt_;
};

}  // namespace rmpmarl::rmp
