#pragma once
// Robots the kinematics tests run on: every shipped manipulator, planar2 and the hand-written tree robot.
#include <Eigen/Core>
#include <random>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::testing {

inline kinematics::Robot LoadTreeRobot() {
  const std::string dir = std::string(RMPMARL_TEST_DATA_DIR) + "/robots/tree/";
  return kinematics::LoadRobot(dir + "tree.urdf", dir + "collision.yaml");
}

inline std::vector<kinematics::Robot> AllTestRobots() {
  std::vector<kinematics::Robot> robots;
  for (const std::string& name : kinematics::ShippedRobotNames()) robots.push_back(kinematics::LoadShippedRobot(name));
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

inline Eigen::VectorXd RandomVelocity(const kinematics::Model& model, std::mt19937_64& rng) {
  Eigen::VectorXd qd(model.nq());
  for (int i = 0; i < model.nq(); ++i) {
    const double v = model.limits()[i].velocity;
    qd[i] = std::uniform_real_distribution<double>(-v, v)(rng);
  }
  return qd;
}

}  // namespace rmpmarl::testing
