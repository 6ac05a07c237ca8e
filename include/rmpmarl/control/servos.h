#pragma once
/// The joints a ReactiveController commands (control/controller.h), as plain data: limits, the loop's clock and the
/// servos' velocity feed-forward.
#include <Eigen/Core>
#include <string>

#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::control {

/// What a ReactiveController commands: the joints' limits, the clock of the loop that drives it and the servos'
/// velocity feed-forward. ServosOf(robot) describes a robot's joints in a user's loop; sim::WorldModel::servos() the
/// simulated servos.
struct ServoSpec {
  std::string robot;        ///< the robot's name (messages)
  Eigen::VectorXd lower;    ///< position limits per dof [rad or m] (−inf for continuous joints)
  Eigen::VectorXd upper;    ///< (+inf for continuous joints)
  Eigen::VectorXd velocity; ///< velocity limit per dof from the robot description (≤ 0: none)
  /// [s] the time quantum of the loop (the physics timestep of a simulator): the control period must be a whole
  /// number of them. 0: any period (a user's loop).
  double timestep = 0.0;
  /// per dof d_i / kp_i of a position servo with joint damping d_i (ControllerOptions::velocity_feedforward); empty:
  /// servos without damping (no feed-forward).
  Eigen::VectorXd feedforward;
};

/// the joints of `robot` as a ReactiveController commands them in a user's loop: its kinematic model's limits
/// (continuous joints unlimited), no clock, no feed-forward.
ServoSpec ServosOf(const kinematics::Robot& robot);

}  // namespace rmpmarl::control
