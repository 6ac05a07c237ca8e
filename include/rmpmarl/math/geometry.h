#pragma once
/// Signed distances with witness points between the primitives the paper uses: link capsules, sphere and
/// oriented-box (cube) obstacles. Frame W is whatever common frame the inputs are expressed in (usually world).
/// Convention: `distance` < 0 means penetration (its magnitude is the penetration depth); `p_W1` lies on the first
/// shape's surface, `p_W2` on the second's; `n_W` is the unit normal pointing from shape 2 towards shape 1, i.e. the
/// gradient of the distance with respect to a translation of shape 1 (so p_W1 ≈ p_W2 + distance · n_W).
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

/// Result of a signed-distance query (see the file comment for conventions).
struct DistanceResult {
  double distance = 0.0;                            ///< signed distance, negative in penetration
  Eigen::Vector3d p_W1 = Eigen::Vector3d::Zero();  ///< witness point on shape 1
  Eigen::Vector3d p_W2 = Eigen::Vector3d::Zero();  ///< witness point on shape 2
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< unit normal from shape 2 to shape 1
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

/// signed distance capsule (shape 1) – sphere (shape 2).
DistanceResult CapsuleSphereDistance(const Capsule& capsule, const Sphere& sphere);

/// signed distance capsule (shape 1) – capsule (shape 2).
DistanceResult CapsuleCapsuleDistance(const Capsule& capsule1, const Capsule& capsule2);

/// signed distance capsule (shape 1) – oriented box (shape 2); exact also when the segment passes through a face.
DistanceResult CapsuleBoxDistance(const Capsule& capsule, const Box& box);

}  // namespace rmpmarl::math
