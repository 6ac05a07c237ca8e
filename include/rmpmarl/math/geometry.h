#pragma once
/// Signed distances with witness points between the primitives the paper uses — link capsules, sphere and
/// oriented-box (cube) obstacles — and cylinders, as the field's benchmark scenes write them. Frame W is whatever common frame the inputs are expressed in (usually world).
/// Convention: `distance` < 0 means penetration (its magnitude is the penetration depth); `p_W1` lies on the first
/// shape's surface, `p_W2` on the second's; `n_W` is the unit normal pointing from shape 2 towards shape 1, i.e. the
/// gradient of the distance with respect to a translation of shape 1 (so p_W1 ≈ p_W2 + distance · n_W).
/// Exception: in capsule–box penetration the gradient can be shorter than 1 (`gradient_norm`), and p_W2 then lies
/// inside the box; see CapsuleBoxDistance. All radii and half sizes must be ≥ 0 (checked in debug builds).
#include <Eigen/Geometry>

namespace rmpmarl::math {

/// A capsule: the set of points within `radius` of the segment [p_WA, p_WB] (A == B gives a sphere).
struct Capsule {
  Eigen::Vector3d p_WA = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_WB = Eigen::Vector3d::Zero();
  double radius = 0.0;
};

/// A sphere of centre p_WC.
struct Sphere {
  Eigen::Vector3d p_WC = Eigen::Vector3d::Zero();
  double radius = 0.0;
};

/// An oriented box: pose X_WB of its centre frame B and half side lengths along B's axes.
struct Box {
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  Eigen::Vector3d half_size = Eigen::Vector3d::Zero();
};

/// A solid cylinder: pose X_WC of its centre frame C, whose z axis is the cylinder's axis; `radius` and the half
/// length along z.
struct Cylinder {
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  double radius = 0.0;
  double half_length = 0.0;
};

/// Result of a signed-distance query (see the file comment for conventions).
struct DistanceResult {
  double distance = 0.0;                            ///< signed distance, negative in penetration
  Eigen::Vector3d p_W1 = Eigen::Vector3d::Zero();  ///< witness point on shape 1
  Eigen::Vector3d p_W2 = Eigen::Vector3d::Zero();  ///< witness point on shape 2
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< unit normal from shape 2 to shape 1
  /// |∂distance/∂(translation of shape 1)|, so the gradient is `gradient_norm · n_W`. It is 1 everywhere except in
  /// capsule–box penetration where the deepest axis point is equidistant from two box faces (see CapsuleBoxDistance).
  double gradient_norm = 1.0;
};

/// Closest points between segments [p_WA1, p_WB1] and [p_WA2, p_WB2]: parameters s, t in [0, 1].
struct SegmentClosestPoints {
  double s = 0.0;                                   ///< point on segment 1 = A1 + s (B1 − A1)
  double t = 0.0;                                   ///< point on segment 2 = A2 + t (B2 − A2)
  Eigen::Vector3d p_W1 = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_W2 = Eigen::Vector3d::Zero();
  double distance = 0.0;                            ///< |p_W1 − p_W2|
};

/// closest points of two segments; handles parallel and zero-length segments (Ericson, RTCD §5.1.9).
SegmentClosestPoints ClosestPointsSegmentSegment(const Eigen::Vector3d& p_WA1, const Eigen::Vector3d& p_WB1,
                                                 const Eigen::Vector3d& p_WA2, const Eigen::Vector3d& p_WB2);

/// Axis points closer than this (in the inputs' length unit, metres) count as touching: the normal then comes from the
/// degenerate-case rules below instead of from the (noise-dominated) difference of the axis points.
inline constexpr double kGeometryTouchTolerance = 1e-12;

/// signed distance capsule (shape 1) – sphere (shape 2): |closest axis point − centre| − r1 − r2.
/// Degenerate case: when the centre lies on the capsule axis the normal is `(B − A).unitOrthogonal()` (Eigen's
/// deterministic choice), or +z when the capsule is itself a sphere at the same centre.
DistanceResult CapsuleSphereDistance(const Capsule& capsule, const Sphere& sphere);

/// signed distance capsule (shape 1) – capsule (shape 2): segment–segment distance − r1 − r2.
/// Degenerate case (axes intersect): normal = normalised d1 × d2 for non-parallel axes (d = B − A); for parallel
/// (collinear) axes `d1.unitOrthogonal()` (or `d2.unitOrthogonal()` when segment 1 is a point); +z for two points.
/// All these normals are perpendicular to both axes, so both witness points stay on their surfaces.
DistanceResult CapsuleCapsuleDistance(const Capsule& capsule1, const Capsule& capsule2);

/// signed distance capsule (shape 1) – oriented box (shape 2), defined as the minimum over the capsule's axis segment
/// of the box's signed distance function, minus the radius; exact also in penetration and when the axis passes
/// through a face with both end points outside.
/// - Axis outside the box: the Euclidean segment–box distance minus the radius; n_W points from the box's closest
///   point p_W2 (on its surface) to the axis's closest point. When the closest set is not unique (axis parallel to a
///   face) the smallest segment parameter of it is reported.
/// - Axis meeting the box: inside the box the SDF is max_i(|p_i| − h_i) (minus the distance to the nearest face), so
///   this is the depth of the deepest axis point, NOT the minimum-translation penetration depth. When that point is
///   equidistant from two adjacent faces i ≠ j (the generic case for an axis crossing the box obliquely) the
///   distance is still differentiable but its gradient is the blend (|d_j| n_i + |d_i| n_j)/(|d_i| + |d_j|) of the
///   two outward face normals (d = axis direction in the box frame): n_W is its normalisation (perpendicular to the
///   axis) and gradient_norm ∈ [1/√2, 1) its length. When the two faces are opposite (axis crossing the mid-plane of
///   a slab) the distance is locally constant, gradient_norm = 0, and n_W is the next-nearest face's normal made
///   perpendicular to the axis. Otherwise (deepest point at an end point, or axis parallel to the nearest face) n_W
///   is the nearest face's outward normal and gradient_norm = 1.
/// p_W1 = deepest/closest axis point − radius · n_W always lies on the capsule's surface; p_W2 = p_W1 − distance · n_W
/// lies on the box's surface except when gradient_norm < 1, where it is inside the box.
DistanceResult CapsuleBoxDistance(const Capsule& capsule, const Box& box);

/// the cylinder's signed distance function at p_W: the Euclidean distance to the solid outside it, minus the
/// distance to the nearest of its surfaces (side or cap) inside it.
double CylinderSignedDistance(const Cylinder& cylinder, const Eigen::Vector3d& p_W);

/// signed distance capsule (shape 1) – cylinder (shape 2), defined as CapsuleBoxDistance is: the minimum over the
/// capsule's axis segment of the cylinder's signed distance function, minus the radius. The function is convex along
/// the segment (the cylinder is convex), and its minimum is found by golden-section search to the last bits of the
/// segment parameter (the distance exact to rounding; CylinderDistanceTest holds it to a brute-force minimum over
/// 20001 axis points; where the minimum is flat, e.g. a capsule across a cap, the axis point and so n_W to about
/// 1e-8). n_W is the signed distance function's gradient at the axis point found — from the cylinder's closest
/// surface point outside it, the nearest face's outward normal inside it — and p_W2 = p_W1 − distance · n_W lies
/// on the cylinder's surface. p_W1 = axis point − radius · n_W is on the capsule's surface where the axis point is
/// an end point or n_W is perpendicular to the axis (always when the axis misses the cylinder).
DistanceResult CapsuleCylinderDistance(const Capsule& capsule, const Cylinder& cylinder);

}  // namespace rmpmarl::math
