#pragma once
/// What a robot senses of its surroundings at a control step: the contacts within the warning distance of its
/// capsules, each with its witness points. `WarningSensor` computes them from geometry — the robot's capsules against
/// the scene's obstacles, the floor and each other — for the learned controller in a user's loop and for the episode
/// loop (sim::EpisodeLoop), once per control step; the simulator's narrow phase (sim::World::QueryContacts) reports
/// its own within a world's margin.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "rmpmarl/collision/checker.h"
#include "rmpmarl/kinematics/model.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::control {

/// What the other side of a robot contact is.
enum class PartnerKind { kObstacle, kLink, kFloor };

/// One contact reported within the warning margin: robot geom (shape 1) vs obstacle, floor or another link
/// (shape 2). Same sign and normal conventions as math::DistanceResult: p_W1 ≈ p_W2 + distance · n_W.
struct WarningContact {
  int robot_geom = -1;                ///< the simulator's geom id of the robot capsule (-1 outside a simulator)
  int other_geom = -1;                ///< the simulator's geom id of the other side (-1 outside a simulator)
  int link = -1;                      ///< robot link of the capsule
  /// index of the capsule: Robot::capsules, then Robot::self_capsules (self contacts of a robot with that set)
  int capsule = -1;
  PartnerKind other_kind = PartnerKind::kObstacle;
  int other_index = -1;               ///< obstacle index, link index, or -1 for the floor
  int other_capsule = -1;             ///< capsule index when other_kind == kLink
  double distance = 0.0;              ///< signed distance, negative in penetration [m]
  Eigen::Vector3d p_W1 = Eigen::Vector3d::Zero();  ///< witness point on the robot capsule
  Eigen::Vector3d p_W2 = Eigen::Vector3d::Zero();  ///< witness point on the other shape
  Eigen::Vector3d n_W = Eigen::Vector3d::UnitZ();  ///< unit normal from shape 2 to shape 1
};

/// Options of a WarningSensor.
struct WarningSensorOptions {
  double margin = 0.15;  ///< contacts are reported up to this signed distance [m], > 0
  /// height of a floor plane z = floor_height checked against the capsules of moving links [m]; NaN: no floor
  double floor_height = std::numeric_limits<double>::quiet_NaN();
  int max_obstacles = 16;  ///< buffers are sized for this many obstacles (more grow them once)
};

/// The warning contacts of a robot at one state: every capsule against every obstacle of the scene (one contact per
/// pair, rmp::CapsuleObstacleDistance), the floor (the lowest end of a moving link's capsule) and the capsule pairs
/// of distinct links the robot does not exclude (the pairs a simulated world checks for self-contact). Preallocated;
/// Sense allocates nothing while the scene holds at most max_obstacles obstacles. The robot is not owned.
class WarningSensor {
 public:
  /// throws InputError for a margin that is not finite and > 0 or max_obstacles < 0.
  WarningSensor(const kinematics::Robot& robot, const WarningSensorOptions& options);

  /// the contacts at the state whose kinematics `kin` holds (\pre kinematics of the sensor's robot).
  void Sense(const kinematics::Data& kin, const rmp::Scene& scene);

  std::span<const WarningContact> contacts() const { return contacts_; }
  /// the smallest signed distance of the last Sense's contacts to obstacles or the floor / between links [m];
  /// +inf when none came within the margin.
  double min_clearance() const { return min_clearance_; }
  double min_self_clearance() const { return min_self_clearance_; }
  const WarningSensorOptions& options() const { return options_; }
  const kinematics::Robot& robot() const { return *robot_; }

 private:
  const kinematics::Robot* robot_;
  WarningSensorOptions options_;
  std::vector<WarningContact> contacts_;
  collision::RobotCollisionModel checker_;     // the capsule pairs checked for self-contact
  collision::RobotCollisionData placed_;       // the capsules at the sensed state and their bounding spheres
  std::vector<std::uint8_t> on_moving_link_;   // per capsule: some joint moves its link (floor contacts)
  double min_clearance_ = std::numeric_limits<double>::infinity();
  double min_self_clearance_ = std::numeric_limits<double>::infinity();
};

}  // namespace rmpmarl::control
