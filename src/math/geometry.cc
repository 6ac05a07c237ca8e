// Signed distances with witness points between capsules, spheres and oriented boxes (see geometry.h).
#include "rmpmarl/math/geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"

namespace rmpmarl::math {
namespace {

using Eigen::Vector3d;

// segments whose direction cross product is this small relative to |d1||d2| are treated as parallel (sin θ < 1e-12)
constexpr double kParallelSin2 = 1e-24;

// clamps x to [0, 1]
inline double Clamp01(double x) { return std::min(std::max(x, 0.0), 1.0); }

// unit vector perpendicular to u (Eigen's deterministic choice), or +z when u is zero
inline Vector3d PerpendicularOrUnitZ(const Vector3d& u) {
  return u.squaredNorm() > 0.0 ? u.unitOrthogonal() : Vector3d::UnitZ();
}

// fills the result of two swept spheres (capsules/spheres) from their closest axis points q1, q2 and the normal n_W
inline DistanceResult SweptSphereResult(const Vector3d& q1, double r1, const Vector3d& q2, double r2,
                                        double axis_distance, const Vector3d& n_W) {
  DistanceResult result;
  result.distance = axis_distance - r1 - r2;
  result.n_W = n_W;
  result.p_W1 = q1 - r1 * n_W;
  result.p_W2 = q2 + r2 * n_W;
  result.gradient_norm = 1.0;
  return result;
}

// minimiser over s ∈ [0,1] of g(s) = |p(s) − clamp(p(s), −h, h)|², p(s) = p_BA + s d_B, the squared distance of the
// segment point to the box. g is convex, C¹ and piecewise quadratic with breakpoints where p_i(s) = ±h_i, so g' is
// continuous, nondecreasing and linear between breakpoints: bracketing its sign change among {0, 1, breakpoints}
// and interpolating linearly between the bracket ends is exact. Branch-free over the 8 candidates (breakpoints
// outside (0,1), or missing because d_i = 0, are clamped onto an end point, duplicating it).
inline double OutsideMinimiser(const Vector3d& p_BA, const Vector3d& d_B, const Vector3d& h) {
  using Array6d = Eigen::Array<double, 6, 1>;
  using Array8d = Eigen::Array<double, 8, 1>;
  // candidates: 0, 1 and the 6 face crossings c = (±h_i − a_i)/d_i clamped into [0,1] (an axis with d_i = 0 gives
  // candidate 0 again). Everything below is fixed-size array arithmetic without data-dependent branches, which
  // would mispredict on random inputs.
  const Vector3d inv = (d_B.array() != 0.0).select(d_B.array().inverse(), 0.0);
  const Array6d face = (Array6d() << h[0], -h[0], h[1], -h[1], h[2], -h[2]).finished();
  const Array6d crossing =
      (face - (Array6d() << p_BA[0], p_BA[0], p_BA[1], p_BA[1], p_BA[2], p_BA[2]).finished()) *
      (Array6d() << inv[0], inv[0], inv[1], inv[1], inv[2], inv[2]).finished();
  Array8d s;
  s << 0.0, 1.0, crossing.max(0.0).min(1.0);
  // half-derivative (p − clamp(p))·d at each candidate. On axis i's own crossings its coordinate is written
  // face + (s − crossing) d_i, which is the face value exactly when the crossing was not clamped, so that rounding
  // noise of that coordinate cannot flip the sign of a tiny g'.
  Array8d slope = Array8d::Zero();
  for (int k = 0; k < 3; ++k) {
    Array8d p = p_BA[k] + s * d_B[k];
    p.segment<2>(2 + 2 * k) =
        face.segment<2>(2 * k) + (s.segment<2>(2 + 2 * k) - crossing.segment<2>(2 * k)) * d_B[k];
    slope += (p - p.max(-h[k]).min(h[k])) * d_B[k];
  }
  // bracket: largest candidate with g' < 0 and smallest with g' ≥ 0, with their slopes (by monotonicity of g' the
  // largest negative and the smallest non-negative slope); masks as 0/1 factors
  constexpr double kBig = 1e300;
  const Array8d below = (slope < 0.0).cast<double>();
  const double s_lo = (s - 2.0 * (1.0 - below)).maxCoeff();  // none if < 0
  const double s_hi = (s + 2.0 * below).minCoeff();          // none if > 1
  if (s_lo < 0.0) return 0.0;
  if (s_hi > 1.0) return 1.0;
  const double slope_lo = (slope - kBig * (1.0 - below)).maxCoeff();
  const double slope_hi = (slope + kBig * below).minCoeff();
  return std::min(s_hi, std::max(s_lo, s_lo + (s_hi - s_lo) * (-slope_lo / (slope_hi - slope_lo))));
}

// the deepest point of a segment that meets the box and the gradient of its depth
struct InteriorMinimum {
  double s = 0.0;                               // segment parameter of the deepest point
  double value = 0.0;                           // box SDF there (≤ 0 up to rounding)
  Vector3d grad_B = Vector3d::Zero();           // ∂value/∂(translation of the segment), box frame
  int flat_axis = 0;                            // when grad_B = 0: the axis whose two faces are equidistant
};

// minimiser over s ∈ [0,1] of G(s) = max_i |p_i(s)| − h_i, which equals the box SDF wherever the segment is inside
// the box (and is > 0 elsewhere), so for a segment meeting the box it is the deepest point. G is the upper envelope
// of the 6 lines u_i(s) = U_i + |d_i| s and w_i(s) = W_i − |d_i| s with U_i = σ_i a_i − h_i, W_i = −σ_i a_i − h_i,
// σ_i = sign(d_i). By LP duality (min over s of a max of lines; e.g. Boyd & Vandenberghe, Convex Optimization §5.2)
// its unconstrained minimum is t* = max over the 9 (increasing i, decreasing j) pairs of their crossing value
// (U_i |d_j| + W_j |d_i|)/(|d_i| + |d_j|); the maximal pair's crossing is a minimiser unless a line is flat, and the
// constrained minimum over [0,1] is G at the clamped minimiser (convexity). The derivative of t* in the translation
// δ (∂U_i/∂δ = σ_i e_i, ∂W_j/∂δ = −σ_j e_j) is the distance's gradient when the minimum is unconstrained; at a
// clamped end point it is the outward normal of the face active there.
inline InteriorMinimum InteriorMinimiser(const Vector3d& p_BA, const Vector3d& d_B, const Vector3d& h) {
  auto envelope = [&](double s) { return ((p_BA + s * d_B).cwiseAbs() - h).maxCoeff(); };
  InteriorMinimum result;
  if (d_B.squaredNorm() == 0.0) {
    // a point: its nearest face
    int k = 0;
    result.value = (p_BA.cwiseAbs() - h).maxCoeff(&k);
    result.grad_B[k] = p_BA[k] < 0.0 ? -1.0 : 1.0;
    return result;
  }
  const Eigen::Array3d sigma = (d_B.array() < 0.0).select(-1.0, Eigen::Array3d::Ones());
  const Eigen::Array3d abs_d = d_B.array().abs();
  const Eigen::Array3d U = sigma * p_BA.array() - h.array();
  const Eigen::Array3d W = -sigma * p_BA.array() - h.array();
  // the 9 pairs (increasing line of axis i, decreasing line of axis j), pair index 3 i + j; a pair of two flat lines
  // (|d_i| = |d_j| = 0) gets a NaN value and never wins
  using Array9d = Eigen::Array<double, 9, 1>;
  const Array9d U_i = (Array9d() << U[0], U[0], U[0], U[1], U[1], U[1], U[2], U[2], U[2]).finished();
  const Array9d W_j = (Array9d() << W[0], W[1], W[2], W[0], W[1], W[2], W[0], W[1], W[2]).finished();
  const Array9d abs_i = (Array9d() << abs_d[0], abs_d[0], abs_d[0], abs_d[1], abs_d[1], abs_d[1], abs_d[2], abs_d[2],
                         abs_d[2]).finished();
  const Array9d abs_j = (Array9d() << abs_d[0], abs_d[1], abs_d[2], abs_d[0], abs_d[1], abs_d[2], abs_d[0], abs_d[1],
                         abs_d[2]).finished();
  const Array9d inv_sum = (abs_i + abs_j).inverse();
  const Array9d pair_value = (U_i * abs_j + W_j * abs_i) * inv_sum;
  double dual_value = -std::numeric_limits<double>::infinity();
  int pair = 0;
  for (int c = 0; c < 9; ++c) {
    pair = pair_value[c] > dual_value ? c : pair;
    dual_value = std::max(dual_value, pair_value[c]);
  }
  const int inc = pair / 3, dec = pair % 3;
  // fast path: the maximal pair's crossing, if it minimises G
  const double crossing = (W[dec] - U[inc]) * inv_sum[pair];
  if (envelope(crossing) <= dual_value + kGeometryTouchTolerance) {
    result.s = Clamp01(crossing);
    result.value = envelope(result.s);
  } else {
    // a flat line made the maximal pair's crossing non-optimal: minimum of G over 0, 1 and all pair crossings
    result.s = 0.0;
    result.value = envelope(0.0);
    if (const double value1 = envelope(1.0); value1 < result.value) result.s = 1.0, result.value = value1;
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        const double s = (W[j] - U[i]) * inv_sum[3 * i + j];
        if (s > 0.0 && s < 1.0) {
          if (const double g = envelope(s); g < result.value) result.s = s, result.value = g;
        }
      }
    }
  }
  if (result.value <= dual_value + kGeometryTouchTolerance) {
    // the constrained minimum is the unconstrained one: derivative of the maximal pair value, perpendicular to the
    // axis (also when a flat minimum reaches an end point); zero when inc == dec
    result.grad_B[inc] += abs_d[dec] * sigma[inc] * inv_sum[pair];
    result.grad_B[dec] -= abs_d[inc] * sigma[dec] * inv_sum[pair];
    result.flat_axis = inc;
  } else {
    // minimum at an end point: the line active just inside the segment (among lines tied at the end point, the one
    // G follows into the segment), i.e. the outward normal of the nearest face
    const Vector3d p_Bprobe = p_BA + (result.s == 0.0 ? 1e-9 : 1.0 - 1e-9) * d_B;
    int k = 0;
    (p_Bprobe.cwiseAbs() - h).maxCoeff(&k);
    result.grad_B[k] = p_Bprobe[k] < 0.0 ? -1.0 : 1.0;
  }
  return result;
}

}  // namespace

SegmentClosestPoints ClosestPointsSegmentSegment(const Vector3d& p_WA1, const Vector3d& p_WB1, const Vector3d& p_WA2,
                                                 const Vector3d& p_WB2) {
  // Ericson, Real-Time Collision Detection (2005), §5.1.9 ClosestPtSegmentSegment: minimise |r + s d1 − t d2|² over
  // [0,1]², clamping s, then t, then re-solving s. The unconstrained s uses the Lagrange identity
  // b f − c e = (d1 × d2)·(d2 × r) and a e − b² = |d1 × d2|², which avoids the cancellation of a e − b² for nearly
  // parallel segments (error ~ε|d1| instead of ~ε|d1|/sin θ).
  const Vector3d d1 = p_WB1 - p_WA1;
  const Vector3d d2 = p_WB2 - p_WA2;
  const Vector3d r = p_WA1 - p_WA2;
  const double a = d1.squaredNorm();
  const double e = d2.squaredNorm();
  const double f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a == 0.0 && e == 0.0) {
    // both segments are points
  } else if (a == 0.0) {
    t = Clamp01(f / e);
  } else {
    const double c = d1.dot(r);
    if (e == 0.0) {
      s = Clamp01(-c / a);
    } else {
      const double b = d1.dot(d2);
      const Vector3d n = d1.cross(d2);
      const double denom = n.squaredNorm();
      // parallel segments: any s is a valid start, Ericson picks 0; the clamping below then finds the optimum
      s = denom > kParallelSin2 * a * e ? Clamp01(n.dot(d2.cross(r)) / denom) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = Clamp01(-c / a);
      } else if (t > 1.0) {
        t = 1.0;
        s = Clamp01((b - c) / a);
      }
    }
  }
  SegmentClosestPoints result;
  result.s = s;
  result.t = t;
  result.p_W1 = p_WA1 + s * d1;
  result.p_W2 = p_WA2 + t * d2;
  result.distance = (result.p_W1 - result.p_W2).norm();
  return result;
}

DistanceResult CapsuleSphereDistance(const Capsule& capsule, const Sphere& sphere) {
  RMPMARL_DASSERT(capsule.radius >= 0.0 && sphere.radius >= 0.0, "radii must be non-negative");
  // closest point on the segment to the centre (Ericson §5.1.2), then offset both by the radii
  const Vector3d d = capsule.p_WB - capsule.p_WA;
  const double dd = d.squaredNorm();
  const double s = dd > 0.0 ? Clamp01((sphere.p_WC - capsule.p_WA).dot(d) / dd) : 0.0;
  const Vector3d q1 = capsule.p_WA + s * d;
  const Vector3d diff = q1 - sphere.p_WC;
  const double axis_distance = diff.norm();
  const Vector3d n_W = axis_distance > kGeometryTouchTolerance ? Vector3d(diff / axis_distance)
                                                                : PerpendicularOrUnitZ(d);
  return SweptSphereResult(q1, capsule.radius, sphere.p_WC, sphere.radius, axis_distance, n_W);
}

DistanceResult CapsuleCapsuleDistance(const Capsule& capsule1, const Capsule& capsule2) {
  RMPMARL_DASSERT(capsule1.radius >= 0.0 && capsule2.radius >= 0.0, "radii must be non-negative");
  const SegmentClosestPoints closest =
      ClosestPointsSegmentSegment(capsule1.p_WA, capsule1.p_WB, capsule2.p_WA, capsule2.p_WB);
  Vector3d n_W;
  if (closest.distance > kGeometryTouchTolerance) {
    n_W = (closest.p_W1 - closest.p_W2) / closest.distance;
  } else {
    // intersecting axes: a normal perpendicular to both keeps both witness points on their surfaces
    const Vector3d d1 = capsule1.p_WB - capsule1.p_WA;
    const Vector3d d2 = capsule2.p_WB - capsule2.p_WA;
    const Vector3d cross = d1.cross(d2);
    const double sin2_scale = d1.squaredNorm() * d2.squaredNorm();
    if (cross.squaredNorm() > kParallelSin2 * sin2_scale && sin2_scale > 0.0) {
      n_W = cross.normalized();
    } else {
      n_W = PerpendicularOrUnitZ(d1.squaredNorm() > 0.0 ? d1 : d2);
    }
  }
  return SweptSphereResult(closest.p_W1, capsule1.radius, closest.p_W2, capsule2.radius, closest.distance, n_W);
}

DistanceResult CapsuleBoxDistance(const Capsule& capsule, const Box& box) {
  // Work in the box frame B; the capsule's end points are called A and E here (E = capsule.p_WB) to keep B for the
  // box. The distance is min over s ∈ [0,1] of sdf(p(s)) − radius with p(s) = p_BA + s d_B (the box SDF is convex,
  // hence so is its restriction to the segment). Two exact 1-D analyses, see OutsideMinimiser and InteriorMinimiser:
  // the first gives the segment–box distance when the segment misses the box, the second the deepest point when it
  // meets it. Neither enumerates box edges, so an axis that passes through a face is handled like any other.
  RMPMARL_DASSERT(capsule.radius >= 0.0 && (box.half_size.array() >= 0.0).all(),
                  "the radius and the box half sizes must be non-negative");
  const auto R_WB = box.X_WB.linear();
  const Vector3d& p_WBo = box.X_WB.translation();
  const Vector3d& h = box.half_size;
  const Vector3d d_W = capsule.p_WB - capsule.p_WA;
  const Vector3d p_BA = R_WB.transpose() * (capsule.p_WA - p_WBo);
  const Vector3d d_B = R_WB.transpose() * d_W;
  const double radius = capsule.radius;
  DistanceResult result;

  const double s_out = OutsideMinimiser(p_BA, d_B, h);
  const Vector3d p_Bout = p_BA + s_out * d_B;
  const Vector3d q_Bout = p_Bout.cwiseMax(-h).cwiseMin(h);
  const Vector3d diff_B = p_Bout - q_Bout;
  const double outside_distance = diff_B.norm();
  if (outside_distance > kGeometryTouchTolerance) {
    result.n_W = R_WB * (diff_B / outside_distance);
    result.distance = outside_distance - radius;
    result.p_W2 = p_WBo + R_WB * q_Bout;
    result.p_W1 = capsule.p_WA + s_out * d_W - radius * result.n_W;
    result.gradient_norm = 1.0;
    return result;
  }

  const InteriorMinimum inside = InteriorMinimiser(p_BA, d_B, h);
  const double grad_norm = inside.grad_B.norm();
  Vector3d n_B;
  if (grad_norm > 0.5) {
    n_B = inside.grad_B / grad_norm;
  } else {
    // the deepest point lies on the mid-plane of axis k between two opposite faces: the distance is locally flat.
    // Use the next-nearest face's normal, made perpendicular to the axis so that p_W1 stays on the capsule surface.
    const Vector3d p_B = p_BA + inside.s * d_B;
    const int k = inside.flat_axis;
    int m = (k + 1) % 3;
    if (const int m2 = (k + 2) % 3; std::abs(p_B[m2]) - h[m2] > std::abs(p_B[m]) - h[m]) m = m2;
    Vector3d face_normal = Vector3d::Zero();
    face_normal[m] = p_B[m] < 0.0 ? -1.0 : 1.0;
    const Vector3d axis = d_B.normalized();
    n_B = face_normal - face_normal.dot(axis) * axis;
    const double norm = n_B.norm();
    n_B = norm > 1e-6 ? Vector3d(n_B / norm) : PerpendicularOrUnitZ(d_B);
  }
  result.n_W = R_WB * n_B;
  result.distance = inside.value - radius;
  result.gradient_norm = grad_norm;
  const Vector3d p_Waxis = capsule.p_WA + inside.s * d_W;
  result.p_W1 = p_Waxis - radius * result.n_W;
  result.p_W2 = p_Waxis - inside.value * result.n_W;
  return result;
}

}  // namespace rmpmarl::math
