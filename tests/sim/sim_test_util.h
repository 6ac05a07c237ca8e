#pragma once
// Robots and random draws the sim tests share: every shipped manipulator, planar2 and the hand-written tree robot.
#include <Eigen/Core>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "../kinematics/test_robots.h"
#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::sim::testing {

using rmpmarl::testing::LoadTreeRobot;
using rmpmarl::testing::RandomConfiguration;

// every robot the FK comparison runs on: the kinematics test robots plus planar2 with its default lengths.
inline std::vector<kinematics::Robot> AllSimTestRobots() {
  std::vector<kinematics::Robot> robots = rmpmarl::testing::AllTestRobots();
  robots.push_back(kinematics::MakePlanar2());
  return robots;
}

// a uniformly random rotation (unit quaternion from four normals).
inline Eigen::Matrix3d RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized().toRotationMatrix();
}

}  // namespace rmpmarl::sim::testing
