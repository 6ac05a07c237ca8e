#pragma once
/// What the RMPs see of the world, as plain data filled by callers (a simulator, a test, a perception stack): sphere,
/// box, cylinder and point-cloud obstacles with linear velocities, and the end-effector target with its velocity. The rmp module
/// never reads the simulator itself.
#include <Eigen/Geometry>
#include <string_view>
#include <vector>

#include "rmpmarl/math/geometry.h"
#include "rmpmarl/math/point_cloud.h"

namespace rmpmarl::rmp {

enum class ObstacleShape { kSphere, kBox, kPoints, kCylinder };

/// One obstacle: a sphere, an oriented box, a solid cylinder of any orientation or a set of points (spheres of `point_radius`, e.g. one cluster of a depth
/// camera's cloud) moving with linear velocity v_WO (no rotation). Every capsule sees a point set through its nearest
/// point (math::CapsulePointCloudDistance), so the collision RMPs (eq 8–9) and the agents' warnings use it unchanged.
struct Obstacle {
  ObstacleShape shape = ObstacleShape::kSphere;
  math::Sphere sphere;                            ///< used when shape == kSphere
  math::Box box;                                  ///< used when shape == kBox
  math::Cylinder cylinder;                        ///< used when shape == kCylinder
  /// used when shape == kPoints: the points' index, not owned — it must outlive every use of the Scene holding it
  /// (control::CloudObstacles owns its clusters' indices until its next update).
  const math::PointCloudIndex* points = nullptr;
  double point_radius = 0.0;                       ///< kPoints: each point is a sphere of this radius [m], ≥ 0
  Eigen::Vector3d v_WO = Eigen::Vector3d::Zero();  ///< linear velocity [m/s] in W

  /// a sphere of centre p_WC and radius r moving with v_WO.
  static Obstacle MakeSphere(const Eigen::Vector3d& p_WC, double radius,
                             const Eigen::Vector3d& v_WO = Eigen::Vector3d::Zero());
  /// a box with centre pose X_WB and half side lengths moving with v_WO.
  static Obstacle MakeBox(const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& half_size,
                          const Eigen::Vector3d& v_WO = Eigen::Vector3d::Zero());
  /// a solid cylinder with centre pose X_WC (its axis along C's z), radius and half length, moving with v_WO.
  static Obstacle MakeCylinder(const Eigen::Isometry3d& X_WC, double radius, double half_length,
                               const Eigen::Vector3d& v_WO = Eigen::Vector3d::Zero());
  /// the points of a non-empty `index`, each a sphere of `point_radius`, moving with v_WO; `index` must outlive the
  /// obstacle's use.
  static Obstacle MakePoints(const math::PointCloudIndex& index, double point_radius,
                             const Eigen::Vector3d& v_WO = Eigen::Vector3d::Zero());
};

/// The world as the RMPs see it at one instant.
struct Scene {
  std::vector<Obstacle> obstacles;
  bool has_target = true;                          ///< false: no end-effector target RMP this step
  Eigen::Vector3d p_WT = Eigen::Vector3d::Zero();  ///< end-effector target position [m]
  Eigen::Vector3d v_WT = Eigen::Vector3d::Zero();  ///< end-effector target velocity [m/s]
  /// C-space target posture (a joint-space goal, or the posture of a plan being followed), one value per joint, for
  /// the controllers that pull toward a posture (RMPflow's C-space target RMP; the learned layer's RMPflow structure);
  /// empty: their configured home.
  Eigen::VectorXd q_T;
  /// the C-space target's velocity (a plan's reference moving along its path), one value per joint: the C-space
  /// target RMP damps the velocity relative to it, so that a moving reference is tracked without lag; empty: zero.
  /// Only with q_T.
  Eigen::VectorXd qd_T;
  /// the C-space target's acceleration (a plan's reference speeding up or slowing down), one value per joint: a
  /// feed-forward of the C-space target RMP, so that the reference is not trailed by q̈_T / k_p; empty: zero. Only with
  /// qd_T.
  Eigen::VectorXd qdd_T;
  /// > 0: the metric scalar of the C-space target RMP toward q_T instead of the controller's own (a plan being
  /// followed weighs as much as the end-effector target; RMPflow's own posture prior weighs 50); 0: the controller's.
  double q_T_metric = 0.0;
};

/// throws InputError naming `what` unless every obstacle has finite data, radius/half sizes/half length > 0 and a
/// rotation matrix (a point set: a non-empty index and a point radius ≥ 0), and the target and q_T are finite.
void ValidateScene(const Scene& scene, std::string_view what);

/// signed distance (with witness points and normal, capsule = shape 1) between a capsule and an obstacle.
math::DistanceResult CapsuleObstacleDistance(const math::Capsule& capsule, const Obstacle& obstacle);

/// radius of a sphere around the obstacle's centre that contains it (a point set: half its bounding box's diagonal
/// plus the point radius).
double BoundingRadius(const Obstacle& obstacle);

/// centre of the obstacle (sphere, box or cylinder centre, a point set's bounding-box centre).
Eigen::Vector3d Centre(const Obstacle& obstacle);

/// (Centre, BoundingRadius) of the obstacle in one vector: its bounding sphere, for the broad phases.
inline Eigen::Vector4d BoundingSphere(const Obstacle& obstacle) {
  Eigen::Vector4d sphere;
  sphere << Centre(obstacle), BoundingRadius(obstacle);
  return sphere;
}

}  // namespace rmpmarl::rmp
