#pragma once
/// What a robot senses of its surroundings at a control step: the contacts within the warning distance of its
/// capsules, each with its witness points. Computed from geometry by the controllers that need them
/// (control::LearnedController) and by the simulator's narrow phase (sim::World::QueryContacts).
#include <Eigen/Core>

namespace rmpmarl::control {

/// What the other side of a robot contact is.
enum class PartnerKind { kObstacle, kLink, kFloor };

/// One contact reported within the warning margin: robot geom (shape 1) vs obstacle, floor or another link
/// (shape 2). Same sign and normal conventions as math::DistanceResult: p_W1 ≈ p_W2 + distance · n_W.
struct WarningContact {
  int robot_geom = -1;                ///< the simulator's geom id of the robot capsule (-1 outside a simulator)
  int other_geom = -1;                ///< the simulator's geom id of the other side (-1 outside a simulator)
  int link = -1;                      ///< robot link of the capsule
  int capsule = -1;                   ///< Robot::capsules index of the capsule
  PartnerKind other_kind = PartnerKind::kObstacle;
  int other_index = -1;               ///< obstacle index, link index, or -1 for the floor
  int other_capsule = -1;             ///< capsule index when other_kind == kLink
  double distance = 0.0;              ///< signed distance, negative in penetration [m]
  Eigen::Vector3d p_W1 = Eigen::Vector3d::Zero();  ///< witness point on the robot capsule
  Eigen::Vector3d p_W2 = Eigen::Vector3d::Zero();  ///< witness point on the other shape
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< unit normal from shape 2 to shape 1
};

}  // namespace rmpmarl::control
