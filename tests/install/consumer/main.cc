// Loads the installed planar2 arm and prints its end effector at q = 0 (expects x = 1).
#include <cstdio>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"

int main() {
  const auto robot = rmpmarl::kinematics::MakePlanar2();
  rmpmarl::kinematics::Data data(robot.model);
  rmpmarl::kinematics::CalcForwardKinematics(robot.model, Eigen::VectorXd::Zero(2), &data);
  const Eigen::Vector3d p_WE = data.X_WL[robot.end_effector.link] * robot.end_effector.X_LE.translation();
  std::printf("end effector x = %.3f, shipped robots = %zu\n", p_WE.x(), rmpmarl::kinematics::ShippedRobotNames().size());
  return (p_WE.x() > 0.999 && p_WE.x() < 1.001) ? 0 : 1;
}
