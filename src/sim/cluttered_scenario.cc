// The cluttered scene: obstacles at rest around the path to a target, moved between episodes.
#include "rmpmarl/sim/scenario.h"

#include <fmt/format.h>

#include <algorithm>

#include "rmpmarl/common/error.h"
#include "scenario_internal.h"

namespace rmpmarl::sim {
namespace {

using internal::CubeScene;
using internal::Require;
using internal::Uniform;

}  // namespace

// ---------------------------------------------------------------------------------------------------- cluttered

ClutteredScenario::ClutteredScenario(const kinematics::Robot& robot, const ClutteredOptions& options)
    : Scenario("cluttered", robot, CubeScene(std::max(0, options.num_obstacles), options.obstacle_side), 10.0,
               options.workspace, options.q_start),
      options_(options) {
  const std::string w = "ClutteredOptions";
  Require(options.num_obstacles >= 0, w + ".num_obstacles", ">= 0", options.num_obstacles);
  Require(std::isfinite(options.obstacle_side) && options.obstacle_side > 0.0, w + ".obstacle_side", "> 0",
          options.obstacle_side);
  Require(std::isfinite(options.min_distance) && options.min_distance >= 0.0, w + ".min_distance", ">= 0",
          options.min_distance);
  Require(std::isfinite(options.max_distance) && options.max_distance >= options.min_distance,
          w + ".max_distance", ">= min_distance", options.max_distance);
  Require(std::isfinite(options.target_speed) && options.target_speed >= 0.0, w + ".target_speed", ">= 0",
          options.target_speed);
  Require(std::isfinite(options.start_clearance), w + ".start_clearance", "a finite distance",
          options.start_clearance);
  Require(std::isfinite(options.target_clearance), w + ".target_clearance", "a finite distance",
          options.target_clearance);
  Require(options.max_attempts >= 1, w + ".max_attempts", ">= 1", options.max_attempts);
}

void ClutteredScenario::Draw(std::mt19937_64& rng) {
  target_ = RandomMovingTarget(options_.target_speed, rng);
  const Eigen::Vector3d p_E0 = EndEffectorAt(q_start_);
  const double half = 0.5 * options_.obstacle_side;
  const double bounding = half * std::sqrt(3.0);
  for (int j = 0; j < num_obstacles(); ++j) {
    bool placed = false;
    for (int attempt = 0; attempt < options_.max_attempts && !placed; ++attempt) {
      const Eigen::Vector3d c =
          p_E0 + Uniform(rng, options_.min_distance, options_.max_distance) * RandomDirection(rng);
      if (!workspace_.planar && c.z() - half < 0.0) continue;  // below the base plane
      if ((c - target_.p_WT).norm() - bounding < options_.target_clearance) continue;
      bool overlaps = false;
      for (int k = 0; k < j && !overlaps; ++k) overlaps = (c - obstacles_[k].p_start).norm() < 2.0 * bounding;
      if (overlaps) continue;
      if (RobotClearance(q_start_, j, c) < options_.start_clearance) continue;
      obstacles_[j].p_start = c;
      placed = true;
    }
    if (!placed) {
      throw InputError(fmt::format("scenario 'cluttered' (robot '{}'): could not place obstacle {} in {} draws; "
                                   "expected fewer or smaller obstacles", robot_.name, j, options_.max_attempts));
    }
  }
}

}  // namespace rmpmarl::sim
