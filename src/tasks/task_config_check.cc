// Task configuration validation: every value in range, every combination of keys consistent; messages name the
// file (or the code that built the config) and the dotted key.
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <string>

#include "rmpmarl/common/config_check.h"
#include "rmpmarl/control/agent_config_yaml.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::tasks {
namespace {

using Checker = internal::ConfigChecker;

void CheckWorkspace(const Checker& c, const sim::WorkspaceOptions& w, const std::string& key) {
  c(std::isfinite(w.near) && w.near >= 0.0 && w.near < w.far, key + ".near", "0 <= near < far", w.near);
  c(std::isfinite(w.far) && w.far <= 1.0, key + ".far", "far <= 1 (a fraction of the reach)", w.far);
  c(std::isfinite(w.half_width) && w.half_width >= 0.0, key + ".half_width", ">= 0", w.half_width);
  c(std::isfinite(w.half_height) && w.half_height >= 0.0, key + ".half_height", ">= 0", w.half_height);
  c(std::isfinite(w.min_height), key + ".min_height", "a finite height", w.min_height);
  c(w.samples >= 1 && w.samples <= 1000000, key + ".samples", "an integer in [1, 1000000]", w.samples);
}

int ScenarioObstacleCount(const TaskConfig& c) {
  switch (c.task) {
    case TaskKind::kPretrain2Link: return 1;
    case TaskKind::kReachAvoid: return c.scenario.crossing.num_obstacles;
    case TaskKind::kLineCrossing: return c.scenario.line_crossing.num_obstacles;
    case TaskKind::kCluttered: return c.scenario.cluttered.num_obstacles;
    case TaskKind::kCells: return c.scenario.cells.obstacle_count();
  }
  return 0;
}

// the task's own scene's options (scenario.*)
void CheckScenario(const Checker& check, const TaskConfig& c) {
  switch (c.task) {
    case TaskKind::kPretrain2Link: {
      const PretrainScenarioOptions& s = c.scenario.pretrain;
      check.Range(s.target_speed, "scenario.target_speed", 0.0, 10.0);
      check(std::isfinite(s.obstacle_side) && s.obstacle_side > 0.0, "scenario.obstacle_side", "a side > 0 m",
            s.obstacle_side);
      check.Range(s.obstacle_lead_time, "scenario.obstacle_lead_time", 0.0, 1000.0);
      check.Range(s.obstacle_path_offset, "scenario.obstacle_path_offset", 0.0, 10.0);
      check.Range(s.obstacle_speed, "scenario.obstacle_speed", 0.0, 10.0);
      check(std::isfinite(s.start_clearance), "scenario.start_clearance", "a finite distance", s.start_clearance);
      check(std::isfinite(s.target_clearance), "scenario.target_clearance", "a finite distance", s.target_clearance);
      check(s.max_attempts >= 1, "scenario.max_attempts", "an integer >= 1", s.max_attempts);
      CheckWorkspace(check, s.workspace, "scenario.workspace");
      break;
    }
    case TaskKind::kReachAvoid: {
      const sim::CrossingOptions& s = c.scenario.crossing;
      check(s.num_obstacles >= 0 && s.num_obstacles <= 4, "scenario.num_obstacles",
            "an integer in [0, 4] (the paper's up to four cubes)", s.num_obstacles);
      check(std::isfinite(s.obstacle_side) && s.obstacle_side > 0.0, "scenario.obstacle_side", "a side > 0 m",
            s.obstacle_side);
      check(std::isfinite(s.obstacle_speed) && s.obstacle_speed >= 0.0 && s.obstacle_speed <= 10.0,
            "scenario.obstacle_speed", "a speed in [0, 10] m/s", s.obstacle_speed);
      check(std::isfinite(s.obstacle_speed_max) &&
                (s.obstacle_speed_max == 0.0 || (s.obstacle_speed_max > s.obstacle_speed && s.obstacle_speed_max <= 10.0)),
            "scenario.obstacle_speed_max", "0 (fixed speed) or a top speed in (obstacle_speed, 10] m/s",
            s.obstacle_speed_max);
      check(std::isfinite(s.target_speed) && s.target_speed >= 0.0, "scenario.target_speed", "a speed >= 0",
            s.target_speed);
      check(std::isfinite(s.min_base_distance) && s.min_base_distance >= 0.0, "scenario.min_base_distance", ">= 0",
            s.min_base_distance);
      check(std::isfinite(s.spawn_margin) && s.spawn_margin >= 0.0, "scenario.spawn_margin", ">= 0", s.spawn_margin);
      CheckWorkspace(check, s.workspace, "scenario.workspace");
      break;
    }
    case TaskKind::kLineCrossing: {
      const sim::LineCrossingOptions& s = c.scenario.line_crossing;
      check(s.num_obstacles >= 1 && s.num_obstacles <= 64, "scenario.num_obstacles", "an integer in [1, 64]",
            s.num_obstacles);
      check(std::isfinite(s.obstacle_side) && s.obstacle_side > 0.0, "scenario.obstacle_side", "a side > 0 m",
            s.obstacle_side);
      check(std::isfinite(s.spacing) && s.spacing > 0.0, "scenario.spacing", "a spacing > 0 m", s.spacing);
      check(!c.scenario.line_speeds.empty(), "scenario.speeds", "a non-empty list", "an empty one");
      for (size_t i = 0; i < c.scenario.line_speeds.size(); ++i) {
        const double v = c.scenario.line_speeds[i];
        check(std::isfinite(v) && v > 0.0 && v <= 20.0, fmt::format("scenario.speeds[{}]", i),
              "a speed in (0, 20] m/s", v);
      }
      check(std::isfinite(s.target_speed) && s.target_speed >= 0.0, "scenario.target_speed", "a speed >= 0",
            s.target_speed);
      check(std::isfinite(s.max_yaw_deg) && s.max_yaw_deg >= 0.0 && s.max_yaw_deg <= 90.0, "scenario.max_yaw_deg",
            "an angle in [0, 90] deg", s.max_yaw_deg);
      check(std::isfinite(s.min_base_distance) && s.min_base_distance >= 0.0, "scenario.min_base_distance", ">= 0",
            s.min_base_distance);
      check(std::isfinite(s.spawn_margin) && s.spawn_margin >= 0.0, "scenario.spawn_margin", ">= 0", s.spawn_margin);
      CheckWorkspace(check, s.workspace, "scenario.workspace");
      break;
    }
    case TaskKind::kCluttered: {
      const sim::ClutteredOptions& s = c.scenario.cluttered;
      check(s.num_obstacles >= 0 && s.num_obstacles <= 64, "scenario.num_obstacles", "an integer in [0, 64]",
            s.num_obstacles);
      check(std::isfinite(s.obstacle_side) && s.obstacle_side > 0.0, "scenario.obstacle_side", "a side > 0 m",
            s.obstacle_side);
      check(std::isfinite(s.min_distance) && s.min_distance >= 0.0, "scenario.min_distance", "a distance >= 0 m",
            s.min_distance);
      check(std::isfinite(s.max_distance) && s.max_distance >= s.min_distance, "scenario.max_distance",
            "a distance >= scenario.min_distance", s.max_distance);
      check(std::isfinite(s.target_speed) && s.target_speed >= 0.0, "scenario.target_speed", "a speed >= 0",
            s.target_speed);
      check(std::isfinite(s.start_clearance), "scenario.start_clearance", "a finite distance", s.start_clearance);
      check(std::isfinite(s.target_clearance), "scenario.target_clearance", "a finite distance", s.target_clearance);
      check(s.max_attempts >= 1, "scenario.max_attempts", "an integer >= 1", s.max_attempts);
      CheckWorkspace(check, s.workspace, "scenario.workspace");
      break;
    }
    case TaskKind::kCells: {
      // the scene checks its own options (sim::CellsScenario, InputError naming CellsOptions.<key>); here the counts
      // the env sizes its observation from
      const sim::CellsOptions& s = c.scenario.cells;
      check(s.num_panels >= 6 && s.num_panels <= 16, "scenario.num_panels", "an integer in [6, 16]", s.num_panels);
      check(s.num_objects >= 0 && s.num_objects <= 16, "scenario.num_objects", "an integer in [0, 16]", s.num_objects);
      check(s.num_crossing >= 0 && s.num_crossing <= 16, "scenario.num_crossing", "an integer in [0, 16]",
            s.num_crossing);
      CheckWorkspace(check, s.workspace, "scenario.workspace");
      break;
    }
  }
}

}  // namespace

void ValidateTaskConfig(const TaskConfig& c, std::string_view where) {
  const Checker check(where);
  // robot
  if (IsUrdfPath(c.robot)) {
    check(std::filesystem::is_regular_file(c.robot), "robot",
          "a shipped robot's name or an existing .urdf file (a user's robot)", fmt::format("'{}' (no such file)", c.robot));
  } else if (c.robot != "planar2") {
    const std::vector<std::string> names = kinematics::ShippedRobotNames();
    if (std::find(names.begin(), names.end(), c.robot) == names.end()) {
      std::string list = "planar2";
      for (const std::string& n : names) list += ", " + n;
      check(false, "robot", fmt::format("one of {}, or a path to a .urdf file", list), fmt::format("'{}'", c.robot));
    }
  }
  if (!c.collision.empty()) {
    check(IsUrdfPath(c.robot), "collision", "set only with a .urdf robot (a shipped robot has its own)",
          fmt::format("'{}' with robot '{}'", c.collision, c.robot));
    check(std::filesystem::is_regular_file(c.collision), "collision", "an existing collision YAML",
          fmt::format("'{}' (no such file)", c.collision));
  }
  check(c.task != TaskKind::kPretrain2Link || c.robot == "planar2", "robot",
        "'planar2' for task pretrain-2link (the paper's two-link pre-training arm)", fmt::format("'{}'", c.robot));

  // the agents' sections (interface, episode clock, controller, options, direct, observation, basic layer)
  const control::AgentConfig agent = AgentConfigOf(c);
  control::ValidateAgentConfig(agent, where);
  const EpisodeConfig& e = c.episode;
  check(std::isfinite(e.discount) && e.discount > 0.0 && e.discount <= 1.0, "episode.discount", "a value in (0, 1]",
        e.discount);
  check(!std::isnan(e.success_max_final_error) && e.success_max_final_error > 0.0, "episode.success_max_final_error",
        "a distance > 0 m (.inf: not required)", e.success_max_final_error);

  // reward
  const RewardConfig& w = c.reward;
  check(!w.joint_reach_weights.empty(), "reward.joint_reach_weights", "one weight or one per joint", "an empty list");
  for (size_t i = 0; i < w.joint_reach_weights.size(); ++i) {
    check(std::isfinite(w.joint_reach_weights[i]) && w.joint_reach_weights[i] >= 0.0,
          fmt::format("reward.joint_reach_weights[{}]", i), "a weight >= 0", w.joint_reach_weights[i]);
  }
  check(std::isfinite(w.joint_reach_tolerance) && w.joint_reach_tolerance >= 0.0, "reward.joint_reach_tolerance",
        "a distance >= 0 m", w.joint_reach_tolerance);
  check(std::isfinite(w.distance_weight) && w.distance_weight >= 0.0, "reward.distance_weight", "a weight >= 0",
        w.distance_weight);
  check(std::isfinite(w.distance_unit) && w.distance_unit > 0.0, "reward.distance_unit", "a length > 0 m",
        w.distance_unit);
  check(std::isfinite(w.time_reward) && w.time_reward >= 0.0, "reward.time_reward", "a reward >= 0", w.time_reward);
  check(std::isfinite(w.reach_tolerance) && w.reach_tolerance > 0.0, "reward.reach_tolerance", "a distance > 0 m",
        w.reach_tolerance);
  check(std::isfinite(w.reach_release) && w.reach_release > w.reach_tolerance, "reward.reach_release",
        fmt::format("a distance > reward.reach_tolerance ({} m)", w.reach_tolerance), w.reach_release);
  check(std::isfinite(w.collision_penalty) && w.collision_penalty >= 0.0, "reward.collision_penalty",
        "a penalty >= 0", w.collision_penalty);
  check(std::isfinite(w.tracking_weight) && w.tracking_weight >= 0.0, "reward.tracking_weight",
        "a weight >= 0 [reward per metre per step]", w.tracking_weight);
  check(std::isfinite(w.precision_weight) && w.precision_weight >= 0.0, "reward.precision_weight",
        "a weight >= 0 [reward per step]", w.precision_weight);
  check(std::isfinite(w.precision_length) && w.precision_length > 0.0, "reward.precision_length", "a length > 0 m",
        w.precision_length);
  control::CheckPassClearance(check, agent, w.precision_pass_clearance, "reward.precision_pass_clearance",
                                       "every step", c.interface != InterfaceMode::kDirect, "a per-joint");
  // domain randomisation
  const RandomizationConfig& d = c.randomization;
  check(d.variants >= 1 && d.variants <= 1024, "randomization.variants", "an integer in [1, 1024]", d.variants);
  check.Range(d.link_scale, "randomization.link_scale", 0.25, 4.0);
  check(std::isfinite(d.initial_q_spread) && d.initial_q_spread >= 0.0, "randomization.initial_q_spread",
        "an angle >= 0 rad", d.initial_q_spread);
  check(c.task == TaskKind::kPretrain2Link || d.initial_q_spread == 0.0, "randomization.initial_q_spread",
        "0 outside pre-training (paper III.F: joint positions are randomised for pre-training only)",
        d.initial_q_spread);
  check(std::isfinite(d.initial_qd_fraction) && d.initial_qd_fraction >= 0.0 && d.initial_qd_fraction <= 1.0,
        "randomization.initial_qd_fraction", "a fraction in [0, 1]", d.initial_qd_fraction);
  const Planar2Config& p = c.planar2;
  check.Range(p.link1_length, "planar2.link1_length", 0.01, 5.0);
  check.Range(p.link2_length, "planar2.link2_length", 0.01, 5.0);
  check(std::isfinite(p.link_radius) && p.link_radius > 0.0, "planar2.link_radius", "a radius > 0 m", p.link_radius);
  check(std::isfinite(p.joint_limit) && p.joint_limit > 0.0, "planar2.joint_limit", "a limit > 0 rad", p.joint_limit);
  check(std::isfinite(p.velocity_limit) && p.velocity_limit > 0.0, "planar2.velocity_limit", "a limit > 0 rad/s",
        p.velocity_limit);

  CheckScenario(check, c);

  const int scenario_obstacles = ScenarioObstacleCount(c);
  const ObservationConfig& o = c.observation;
  check(o.max_obstacles >= scenario_obstacles && o.max_obstacles <= 64, "observation.max_obstacles",
        fmt::format("an integer in [{} (the scenario's obstacles), 64]", scenario_obstacles), o.max_obstacles);

}

}  // namespace rmpmarl::tasks
