// Capsule–cylinder signed distance: a convex minimisation of the cylinder's signed distance function along the
// capsule's axis (golden-section search), with the gradient and closest surface point there.
#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/math/golden_section.h"

namespace rmpmarl::math {
namespace {

using Eigen::Vector3d;

// the signed distance function of the cylinder of radius R and half length h about C's z axis, at p_C (square roots
// of sums of squares, not std::hypot: 5× faster, and no overflow at the scale of a robot cell)
double Sdf(const Vector3d& p_C, double R, double h) {
  const double radial = std::sqrt(p_C.x() * p_C.x() + p_C.y() * p_C.y()) - R;
  const double axial = std::abs(p_C.z()) - h;
  const double ro = std::max(radial, 0.0), ao = std::max(axial, 0.0);
  const double outside = std::sqrt(ro * ro + ao * ao);
  return outside > 0.0 ? outside : std::max(radial, axial);
}

// the closest surface point q_C of the cylinder to p_C and the unit gradient n_C of the signed distance there
void SurfacePoint(const Vector3d& p_C, double R, double h, Vector3d* q_C, Vector3d* n_C) {
  const double rho = std::sqrt(p_C.x() * p_C.x() + p_C.y() * p_C.y());
  // the radial unit vector (+x on the axis, where every direction is as near)
  const Vector3d u = rho > 1e-300 ? Vector3d(p_C.x() / rho, p_C.y() / rho, 0.0) : Vector3d::UnitX();
  const double z_sign = p_C.z() < 0.0 ? -1.0 : 1.0;
  const double radial = rho - R, axial = std::abs(p_C.z()) - h;
  if (radial > 0.0 || axial > 0.0) {  // outside: clamp into the solid
    *q_C = std::min(rho, R) * u + Vector3d(0.0, 0.0, std::clamp(p_C.z(), -h, h));
    const Vector3d diff = p_C - *q_C;
    const double norm = diff.norm();
    *n_C = norm > 0.0 ? Vector3d(diff / norm) : (radial >= axial ? u : Vector3d(0.0, 0.0, z_sign));
    return;
  }
  if (radial >= axial) {  // nearer the side
    *q_C = R * u + Vector3d(0.0, 0.0, p_C.z());
    *n_C = u;
  } else {  // nearer a cap
    *q_C = Vector3d(p_C.x(), p_C.y(), z_sign * h);
    *n_C = Vector3d(0.0, 0.0, z_sign);
  }
}

}  // namespace

double CylinderSignedDistance(const Cylinder& cylinder, const Vector3d& p_W) {
  RMPMARL_DASSERT(cylinder.radius >= 0.0 && cylinder.half_length >= 0.0, "cylinder sizes must be non-negative");
  return Sdf(cylinder.X_WC.inverse() * p_W, cylinder.radius, cylinder.half_length);
}

DistanceResult CapsuleCylinderDistance(const Capsule& capsule, const Cylinder& cylinder) {
  RMPMARL_DASSERT(capsule.radius >= 0.0 && cylinder.radius >= 0.0 && cylinder.half_length >= 0.0,
                  "the radii and the half length must be non-negative");
  const double R = cylinder.radius, h = cylinder.half_length;
  const Eigen::Isometry3d X_CW = cylinder.X_WC.inverse();
  const Vector3d p_CA = X_CW * capsule.p_WA;
  const Vector3d d_C = X_CW.linear() * (capsule.p_WB - capsule.p_WA);
  auto f = [&](double s) { return Sdf(p_CA + s * d_C, R, h); };
  // golden-section search on [0, 1]: the restriction of a convex function to a segment is convex, so unimodal;
  // 80 steps shrink the bracket below 2^-55. Then the best of the bracket's points and the end points (a minimum at
  // an end point is common).
  const GoldenBracket g = GoldenSectionSearch(f, 0.0, 1.0, 80);
  double s = g.f1 <= g.f2 ? g.x1 : g.x2, best = std::min(g.f1, g.f2);
  for (const double end : {0.0, 1.0}) {
    if (const double v = f(end); v < best) {
      best = v;
      s = end;
    }
  }
  const Vector3d p_C = p_CA + s * d_C;
  Vector3d q_C, n_C;
  SurfacePoint(p_C, R, h, &q_C, &n_C);
  DistanceResult result;
  result.distance = best - capsule.radius;
  result.n_W = cylinder.X_WC.linear() * n_C;
  const Vector3d p_Waxis = capsule.p_WA + s * (capsule.p_WB - capsule.p_WA);
  result.p_W1 = p_Waxis - capsule.radius * result.n_W;
  result.p_W2 = cylinder.X_WC * q_C;
  return result;
}

}  // namespace rmpmarl::math
