// The crossing scenes: obstacles crossing the workspace on horizontal paths (crossing) and along a line through
// the arm's path to the target (line-crossing).
#include "rmpmarl/sim/scenario.h"

#include <fmt/format.h>

#include <algorithm>

#include "rmpmarl/common/error.h"
#include "scenario_internal.h"

namespace rmpmarl::sim {
namespace {

using internal::BaseDistance;
using internal::CubeScene;
using internal::CutToSpawnDisc;
using internal::HorizontalPath;
using internal::Require;
using internal::Uniform;

}  // namespace

// ----------------------------------------------------------------------------------------------------- crossing

CrossingScenario::CrossingScenario(const kinematics::Robot& robot, const CrossingOptions& options)
    : Scenario("crossing", robot, CubeScene(std::max(0, options.num_obstacles), options.obstacle_side), 10.0,
               options.workspace, options.q_start),
      options_(options) {
  const std::string w = "CrossingOptions";
  Require(options.num_obstacles >= 0, w + ".num_obstacles", ">= 0", options.num_obstacles);
  Require(std::isfinite(options.obstacle_side) && options.obstacle_side > 0.0, w + ".obstacle_side", "> 0",
          options.obstacle_side);
  Require(std::isfinite(options.obstacle_speed) && options.obstacle_speed >= 0.0, w + ".obstacle_speed", ">= 0",
          options.obstacle_speed);
  Require(std::isfinite(options.obstacle_speed_max) && options.obstacle_speed_max >= 0.0,
          w + ".obstacle_speed_max", ">= 0", options.obstacle_speed_max);
  Require(std::isfinite(options.target_speed) && options.target_speed >= 0.0, w + ".target_speed", ">= 0",
          options.target_speed);
  Require(std::isfinite(options.min_base_distance) && options.min_base_distance >= 0.0,
          w + ".min_base_distance", ">= 0", options.min_base_distance);
  Require(std::isfinite(options.spawn_margin) && options.spawn_margin >= 0.0, w + ".spawn_margin", ">= 0",
          options.spawn_margin);
}

void Scenario::DrawHorizontalCrossing(int j, const HorizontalCrossing& c, std::mt19937_64& rng) {
  ObstacleState& o = obstacles_[j];
  const double r_spawn = workspace_.horizontal_reach + c.spawn_margin;
  for (int attempt = 0; attempt < 10000; ++attempt) {
    const Eigen::Vector3d P = RandomWorkspacePoint(rng);
    const double yaw = Uniform(rng, 0.0, 2.0 * M_PI);
    const Eigen::Vector3d d(std::cos(yaw), std::sin(yaw), 0.0);
    if (BaseDistance(P, d) < c.min_base_distance) continue;
    const HorizontalPath path = CutToSpawnDisc(P, d, r_spawn);
    o.p_start = path.p_start;
    o.direction = d;
    o.path_length = path.length;
    // a speed is drawn only for a range, so fixed-speed scenes keep their random streams
    o.speed = c.speed_max > c.speed ? Uniform(rng, c.speed, c.speed_max) : c.speed;
    o.s = 0.0;
    o.wrap = 0.0;
    return;
  }
  throw InputError(fmt::format("scenario '{}' (robot '{}'): no path passes {} m from the base through the workspace; "
                               "expected a smaller {}", name_, robot_.name, c.min_base_distance,
                               c.min_base_distance_key));
}

void CrossingScenario::DrawPath(int j, std::mt19937_64& rng) {
  DrawHorizontalCrossing(j,
                         {options_.min_base_distance, options_.spawn_margin, options_.obstacle_speed,
                          options_.obstacle_speed_max, "CrossingOptions.min_base_distance"},
                         rng);
}

void CrossingScenario::Draw(std::mt19937_64& rng) {
  target_ = RandomMovingTarget(options_.target_speed, rng);
  for (int j = 0; j < num_obstacles(); ++j) {
    DrawPath(j, rng);
    // staggered arrivals: start up to half a path length before the spawn circle
    obstacles_[j].s = -Uniform(rng, 0.0, 0.5) * obstacles_[j].path_length;
  }
}

void CrossingScenario::OnPathEnd(int j, std::mt19937_64& rng) {
  const int paths = obstacles_[j].paths;
  DrawPath(j, rng);
  obstacles_[j].paths = paths + 1;
}

// ------------------------------------------------------------------------------------------------ line-crossing

namespace {
double LineDuration(const Workspace& w, const LineCrossingOptions& o) {
  const double path = 2.0 * (w.horizontal_reach + o.spawn_margin);
  const bool along = o.arrangement == LineArrangement::kAlongMotion;
  const double train = along ? std::max(0, o.num_obstacles - 1) * o.spacing : 0.0;
  const double pass = (path + train) / std::max(o.speed, 1e-3);
  return std::clamp(pass, 5.0, 60.0);
}
}  // namespace

LineCrossingScenario::LineCrossingScenario(const kinematics::Robot& robot, const LineCrossingOptions& options)
    : Scenario("line-crossing", robot, CubeScene(std::max(0, options.num_obstacles), options.obstacle_side), 10.0,
               options.workspace, options.q_start),
      options_(options) {
  const std::string w = "LineCrossingOptions";
  Require(options.num_obstacles >= 1, w + ".num_obstacles", ">= 1", options.num_obstacles);
  Require(std::isfinite(options.obstacle_side) && options.obstacle_side > 0.0, w + ".obstacle_side", "> 0",
          options.obstacle_side);
  Require(std::isfinite(options.spacing) && options.spacing > 0.0, w + ".spacing", "> 0", options.spacing);
  Require(std::isfinite(options.speed) && options.speed > 0.0, w + ".speed", "> 0 m/s", options.speed);
  Require(std::isfinite(options.target_speed) && options.target_speed >= 0.0, w + ".target_speed", ">= 0",
          options.target_speed);
  Require(std::isfinite(options.max_yaw_deg) && options.max_yaw_deg >= 0.0 && options.max_yaw_deg <= 90.0,
          w + ".max_yaw_deg", "a value in [0, 90]", options.max_yaw_deg);
  Require(std::isfinite(options.min_base_distance) && options.min_base_distance >= 0.0,
          w + ".min_base_distance", ">= 0", options.min_base_distance);
  Require(std::isfinite(options.spawn_margin) && options.spawn_margin >= 0.0, w + ".spawn_margin", ">= 0",
          options.spawn_margin);
  if (options.through && !options.through->allFinite()) {
    throw InputError("LineCrossingOptions.through: expected a finite point, got non-finite entries");
  }
  default_duration_ = LineDuration(workspace_, options);
}

void LineCrossingScenario::Draw(std::mt19937_64& rng) {
  target_ = RandomMovingTarget(options_.target_speed, rng);
  const double r_spawn = workspace_.horizontal_reach + options_.spawn_margin;
  const double max_yaw = options_.max_yaw_deg * M_PI / 180.0;
  for (int attempt = 0; attempt < 10000; ++attempt) {
    const Eigen::Vector3d P = options_.through ? *options_.through : RandomWorkspacePoint(rng);
    const double sign = std::bernoulli_distribution(0.5)(rng) ? 1.0 : -1.0;
    const double yaw = Uniform(rng, -max_yaw, max_yaw);
    // sideways (± lateral) turned by yaw about z
    const Eigen::Vector3d d = sign * (std::cos(yaw) * workspace_.lateral() + std::sin(yaw) * workspace_.front);
    if (BaseDistance(P, d) < options_.min_base_distance) continue;
    const HorizontalPath path = CutToSpawnDisc(P, d, std::max(r_spawn, P.head<2>().norm() + options_.spawn_margin));
    const int n = num_obstacles();
    const bool along = options_.arrangement == LineArrangement::kAlongMotion;
    const Eigen::Vector3d across(-d.y(), d.x(), 0.0);
    for (int j = 0; j < n; ++j) {
      ObstacleState& o = obstacles_[j];
      o.direction = d;
      o.path_length = path.length;
      o.speed = options_.speed;
      if (along) {
        o.p_start = path.p_start;
        o.s = -j * options_.spacing;  // one behind the other, the first at the start of the path
        o.wrap = options_.repeat ? std::max(n * options_.spacing, path.length + options_.spacing) : 0.0;
      } else {
        // side by side, centred on the line; the shifted starts lie even further from the base axis
        o.p_start = path.p_start + (j - 0.5 * (n - 1)) * options_.spacing * across;
        o.s = 0.0;
        o.wrap = options_.repeat ? path.length + options_.spacing : 0.0;
      }
      o.stop_on_impact = options_.stop_on_impact;
    }
    return;
  }
  throw InputError(fmt::format("scenario 'line-crossing' (robot '{}'): no line passes {} m from the base; expected a "
                               "smaller LineCrossingOptions.min_base_distance or another `through` point",
                               robot_.name, options_.min_base_distance));
}

}  // namespace rmpmarl::sim
