#pragma once
// Robots, random states and the allocation counter shared by the rmp tests.
#include <Eigen/Core>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <random>
#include <string>

#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::testing {

// set while counting; g_allocations counts operator new calls (defined in allocation_test.cc)
extern std::atomic<bool> g_count_allocations;
extern std::atomic<long> g_allocations;

// counts heap allocations made during its lifetime.
class AllocationCounter {
 public:
  AllocationCounter() {
    g_allocations = 0;
    g_count_allocations = true;
  }
  ~AllocationCounter() { g_count_allocations = false; }
  long count() const { return g_allocations.load(); }
};

inline kinematics::Robot LoadTreeRobot() {
  const std::string dir = std::string(RMPMARL_TEST_DATA_DIR) + "/robots/tree/";
  return kinematics::LoadRobot(dir + "tree.urdf", dir + "collision.yaml");
}

// true once the shipped robot `name` has its collision.yaml (the models are being written concurrently).
inline bool ShippedRobotAvailable(const std::string& name) {
  return std::filesystem::exists(kinematics::ModelsDirectory() / "robots" / name / "collision.yaml");
}

// the 7-DoF Panda when shipped, else the hand-written tree robot.
inline kinematics::Robot LoadArm() {
  return ShippedRobotAvailable("panda") ? kinematics::LoadShippedRobot("panda") : LoadTreeRobot();
}

// uniform configuration within the joint limits shrunk by `margin` (continuous joints in [-pi, pi]).
inline Eigen::VectorXd RandomConfiguration(const kinematics::Model& model, std::mt19937_64& rng, double margin = 0.0) {
  Eigen::VectorXd q(model.nq());
  for (int i = 0; i < model.nq(); ++i) {
    const auto& l = model.limits()[i];
    const double lo = std::isfinite(l.lower) ? l.lower : -M_PI;
    const double hi = std::isfinite(l.upper) ? l.upper : M_PI;
    const double m = std::min(margin, 0.25 * (hi - lo));
    q[i] = std::uniform_real_distribution<double>(lo + m, hi - m)(rng);
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

inline double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

inline Eigen::Vector3d RandomVector3(std::mt19937_64& rng, double lo, double hi) {
  return {Uniform(rng, lo, hi), Uniform(rng, lo, hi), Uniform(rng, lo, hi)};
}

// a random symmetric positive definite n × n matrix with eigenvalues in about [0.1, 3].
inline Eigen::MatrixXd RandomSpd(int n, std::mt19937_64& rng) {
  Eigen::MatrixXd B(n, n);
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) B(i, j) = Uniform(rng, -1.0, 1.0);
  }
  Eigen::MatrixXd M = B * B.transpose() / n;
  M.diagonal().array() += 0.1;
  return M;
}

inline Eigen::VectorXd RandomVector(int n, std::mt19937_64& rng, double lo = -1.0, double hi = 1.0) {
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i) v[i] = Uniform(rng, lo, hi);
  return v;
}

}  // namespace rmpmarl::testing
