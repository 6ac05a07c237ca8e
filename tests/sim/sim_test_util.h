#pragma once
// Robots and random draws the sim tests share: every shipped manipulator, planar2 and the hand-written tree robot.
#include <Eigen/Core>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::sim::testing {

// the hand-written branching robot of the test data (revolute, continuous, prismatic and fixed joints).
inline kinematics::Robot LoadTreeRobot() {
  const std::string dir = std::string(RMPMARL_TEST_DATA_DIR) + "/robots/tree/";
  return kinematics::LoadRobot(dir + "tree.urdf", dir + "collision.yaml");
}

// every robot the FK comparison runs on.
inline std::vector<kinematics::Robot> AllSimTestRobots() {
  std::vector<kinematics::Robot> robots;
  for (const std::string& name : kinematics::ShippedRobotNames()) robots.push_back(kinematics::LoadShippedRobot(name));
  robots.push_back(kinematics::MakePlanar2());
  robots.push_back(kinematics::MakePlanar2({.link1_length = 0.37, .link2_length = 0.61}));
  robots.push_back(LoadTreeRobot());
  return robots;
}

// a uniformly random configuration within the joint limits (continuous joints in [-pi, pi]).
inline Eigen::VectorXd RandomConfiguration(const kinematics::Model& model, std::mt19937_64& rng) {
  Eigen::VectorXd q(model.nq());
  for (int i = 0; i < model.nq(); ++i) {
    const auto& l = model.limits()[i];
    const double lo = std::isfinite(l.lower) ? l.lower : -M_PI;
    const double hi = std::isfinite(l.upper) ? l.upper : M_PI;
    q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
  }
  return q;
}

// a uniformly random rotation (unit quaternion from four normals).
inline Eigen::Matrix3d RandomRotation(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Quaterniond q(n(rng), n(rng), n(rng), n(rng));
  return q.normalized().toRotationMatrix();
}

}  // namespace rmpmarl::sim::testing
