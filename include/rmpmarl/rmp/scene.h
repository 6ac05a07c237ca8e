#pragma once
/// What the RMPs see of the world, as plain data filled by callers (a simulator, a test, a perception stack): sphere
/// and box obstacles with linear velocities, and the end-effector target with its velocity. The rmp module never
/// reads the simulator itself.
#include <Eigen/Geometry>
#include <string_view>
#include <vector>

#include "rmpmarl/math/geometry.h"

namespace rmpmarl::rmp {

enum class ObstacleShape { kSphere, kBox };

/// One obstacle: a sphere or an oriented box moving with linear velocity v_WO (no rotation).
struct Obstacle {
  ObstacleShape shape = ObstacleShape::kSphere;
  math::Sphere sphere;                            ///< used when shape == kSphere
  math::Box box;                                  ///< used when shape == kBox
  Eigen::Vector3d v_WO = Eigen::Vector3d::Zero();  ///< linear velocity [m/s] in W

  /// a sphere of centre p_WC and radius r moving with v_WO.
  static Obstacle MakeSphere(const Eigen::Vector3d& p_WC, double radius,
                             const Eigen::Vector3d& v_WO = Eigen::Vector3d::Zero());
  /// a box with centre pose X_WB and half side lengths moving with v_WO.
  static Obstacle MakeBox(const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& half_size,
                          const Eigen::Vector3d& v_WO = Eigen::Vector3d::Zero());
};

/// The world as the RMPs see it at one instant.
struct Scene {
  std::vector<Obstacle> obstacles;
  bool has_target = true;                          ///< false: no end-effector target RMP this step
  Eigen::Vector3d p_WT = Eigen::Vector3d::Zero();  ///< end-effector target position [m]
  Eigen::Vector3d v_WT = Eigen::Vector3d::Zero();  ///< end-effector target velocity [m/s]
};

/// throws InputError naming `what` unless every obstacle has finite data, radius/half sizes > 0 and a rotation
/// matrix, and the target is finite.
void ValidateScene(const Scene& scene, std::string_view what);

/// signed distance (with witness points and normal, capsule = shape 1) between a capsule and an obstacle.
math::DistanceResult CapsuleObstacleDistance(const math::Capsule& capsule, const Obstacle& obstacle);

/// radius of a sphere around the obstacle's centre that contains it.
double BoundingRadius(const Obstacle& obstacle);

/// centre of the obstacle (sphere centre, box centre).
Eigen::Vector3d Centre(const Obstacle& obstacle);

}  // namespace rmpmarl::rmp
