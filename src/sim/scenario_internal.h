#pragma once
// Helpers shared by the scenario implementations (scenario.cc and the scene files beside it); not installed.
#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <string_view>
#include <utility>

#include "rmpmarl/collision/checker.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::sim {
struct SceneSpec;
}  // namespace rmpmarl::sim

namespace rmpmarl::sim::internal {

/// throws InputError naming `where` unless q is a finite configuration of `robot` within its joint limits.
void CheckStart(const kinematics::Robot& robot, const Eigen::VectorXd& q, std::string_view where);
/// n cubes of side `side` and a target.
SceneSpec CubeScene(int n, double side);

// throws InputError "<where>: expected <expected>, got <got>" unless ok (and value finite).
inline void Require(bool ok, std::string_view where, std::string_view expected, double got) {
  if (!ok || std::isnan(got)) throw InputError(fmt::format("{}: expected {}, got {}", where, expected, got));
}

inline double Uniform(std::mt19937_64& rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(rng);
}

// lower/upper bound of dof i for sampling (continuous joints: [-pi, pi]).
inline std::pair<double, double> SamplingRange(const kinematics::DofLimits& l) {
  return {std::isfinite(l.lower) ? l.lower : -M_PI, std::isfinite(l.upper) ? l.upper : M_PI};
}

inline Eigen::Vector3d EndEffector(const kinematics::Robot& robot, const kinematics::Data& data) {
  return kinematics::CalcPointPosition(data, robot.end_effector.link, robot.end_effector.X_LE.translation());
}

// smallest distance between capsules of checked link pairs (different links, not excluded) at the FK in data.
inline double MinSelfClearance(const collision::RobotCollisionModel& checker, const kinematics::Data& data) {
  collision::RobotCollisionData placed(checker);
  collision::PlaceRobot(checker, data, &placed);
  return collision::CalcSelfCapsuleClearance(checker, placed);
}

// lowest point of the capsules on links moved by two or more dofs (an arm's first joint only spins its column).
inline double LowestMovingPoint(const kinematics::Robot& robot, const kinematics::Data& data) {
  double z = std::numeric_limits<double>::infinity();
  for (const auto& c : robot.capsules) {
    if (robot.model.link_dofs(c.link).size() < 2) continue;
    const math::Capsule w = kinematics::WorldCapsule(c, data);
    z = std::min({z, w.p_WA.z() - c.radius, w.p_WB.z() - c.radius});
  }
  return z;
}

// A horizontal line through P with direction d, cut to the disc of radius r_spawn around the base z axis.
struct HorizontalPath {
  Eigen::Vector3d p_start;
  double length;
};
inline HorizontalPath CutToSpawnDisc(const Eigen::Vector3d& P, const Eigen::Vector3d& d, double r_spawn) {
  const Eigen::Vector2d p(P.x(), P.y());
  const Eigen::Vector2d u(d.x(), d.y());
  const double along = p.dot(u);
  const double b2 = std::max(0.0, p.squaredNorm() - along * along);
  const double half = std::sqrt(std::max(0.0, r_spawn * r_spawn - b2));
  return {P + (-along - half) * d, 2.0 * half};
}

// horizontal distance of the line through P along d (horizontal unit vector) from the base z axis.
inline double BaseDistance(const Eigen::Vector3d& P, const Eigen::Vector3d& d) {
  return std::abs(P.x() * d.y() - P.y() * d.x());
}

}  // namespace rmpmarl::sim::internal
