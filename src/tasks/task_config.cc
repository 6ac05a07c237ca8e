// Task configurations: defaults per task, YAML loading with file/key messages (validation: task_config_check.cc).
#include "rmpmarl/tasks/task_config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <initializer_list>
#include <set>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/control/agent_config_yaml.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/agent_interface.h"

namespace rmpmarl::tasks {
namespace {

using internal::FlagField;
using internal::IntegerField;
using internal::NumberField;
using internal::RangeField;
using internal::ReadYamlSection;
using internal::YamlField;
using Reader = internal::YamlReader;
using internal::LoadYamlText;

// the episode section's keys: the agents' horizon and clock (control::AgentEpisode) and the task's own
const std::set<std::string> kAgentEpisodeKeys = {"max_steps", "control_rate", "physics_timestep"};
const std::set<std::string> kTaskEpisodeKeys = {"integrator", "terminate_on_collision", "discount", "scenario_update",
                                                "success_max_final_error"};

YamlField Workspace(const Reader& r, sim::WorkspaceOptions* w) {
  return {"workspace", [&r, w](const YAML::Node& n, const std::string& k) {
            ReadYamlSection(r, n, k,
                        {NumberField(r, "near", &w->near), NumberField(r, "far", &w->far), NumberField(r, "half_width", &w->half_width),
                         NumberField(r, "half_height", &w->half_height), NumberField(r, "min_height", &w->min_height),
                         IntegerField(r, "samples", &w->samples)});
          }};
}

void ReadScenario(const Reader& r, const YAML::Node& node, TaskKind task, ScenarioConfig* s) {
  const std::string key = "scenario";
  switch (task) {
    case TaskKind::kPretrain2Link: {
      PretrainScenarioOptions& p = s->pretrain;
      ReadYamlSection(r, node, key,
                  {RangeField(r, "target_speed", &p.target_speed), NumberField(r, "obstacle_side", &p.obstacle_side),
                   RangeField(r, "obstacle_lead_time", &p.obstacle_lead_time),
                   RangeField(r, "obstacle_path_offset", &p.obstacle_path_offset),
                   FlagField(r, "obstacle_out_of_reach", &p.obstacle_out_of_reach), RangeField(r, "obstacle_speed", &p.obstacle_speed),
                   NumberField(r, "start_clearance", &p.start_clearance), NumberField(r, "target_clearance", &p.target_clearance),
                   IntegerField(r, "max_attempts", &p.max_attempts), Workspace(r, &p.workspace)});
      break;
    }
    case TaskKind::kReachAvoid: {
      sim::CrossingOptions& c = s->crossing;
      ReadYamlSection(r, node, key,
                  {IntegerField(r, "num_obstacles", &c.num_obstacles), NumberField(r, "obstacle_side", &c.obstacle_side),
                   NumberField(r, "obstacle_speed", &c.obstacle_speed), NumberField(r, "obstacle_speed_max", &c.obstacle_speed_max),
                   NumberField(r, "target_speed", &c.target_speed),
                   NumberField(r, "min_base_distance", &c.min_base_distance), NumberField(r, "spawn_margin", &c.spawn_margin),
                   Workspace(r, &c.workspace)});
      break;
    }
    case TaskKind::kLineCrossing: {
      sim::LineCrossingOptions& l = s->line_crossing;
      std::vector<YamlField> fields = {
          IntegerField(r, "num_obstacles", &l.num_obstacles), NumberField(r, "obstacle_side", &l.obstacle_side),
          NumberField(r, "spacing", &l.spacing), NumberField(r, "target_speed", &l.target_speed),
          NumberField(r, "max_yaw_deg", &l.max_yaw_deg), NumberField(r, "min_base_distance", &l.min_base_distance),
          NumberField(r, "spawn_margin", &l.spawn_margin), FlagField(r, "stop_on_impact", &l.stop_on_impact),
          FlagField(r, "repeat", &l.repeat), Workspace(r, &l.workspace)};
      fields.push_back({"speeds", [&r, s](const YAML::Node& n, const std::string& k) { s->line_speeds = r.List(n, k); }});
      fields.push_back({"arrangement", [&r, &l](const YAML::Node& n, const std::string& k) {
                          l.arrangement = r.Choice(n, k, {"along", "across"}) == 0 ? sim::LineArrangement::kAlongMotion
                                                                                   : sim::LineArrangement::kAcrossMotion;
                        }});
      ReadYamlSection(r, node, key, fields);
      break;
    }
    case TaskKind::kCluttered: {
      sim::ClutteredOptions& c = s->cluttered;
      ReadYamlSection(r, node, key,
                  {IntegerField(r, "num_obstacles", &c.num_obstacles), NumberField(r, "obstacle_side", &c.obstacle_side),
                   NumberField(r, "min_distance", &c.min_distance), NumberField(r, "max_distance", &c.max_distance),
                   NumberField(r, "target_speed", &c.target_speed), NumberField(r, "start_clearance", &c.start_clearance),
                   NumberField(r, "target_clearance", &c.target_clearance), IntegerField(r, "max_attempts", &c.max_attempts),
                   Workspace(r, &c.workspace)});
      break;
    }
    case TaskKind::kCells: {
      sim::CellsOptions& c = s->cells;
      ReadYamlSection(r, node, key,
                  {{"kind_weights", [&r, &c](const YAML::Node& n, const std::string& k) {
                      const std::vector<double> w = r.List(n, k);
                      if (w.size() != c.kind_weights.size()) {
                        r.Fail(n, k, fmt::format("expected {} weights (shelf, box, table, under-table), got {}",
                                                 c.kind_weights.size(), w.size()));
                      }
                      std::copy(w.begin(), w.end(), c.kind_weights.begin());
                    }},
                   NumberField(r, "panel_length", &c.panel_length), NumberField(r, "panel_width", &c.panel_width),
                   NumberField(r, "panel_thickness", &c.panel_thickness), IntegerField(r, "num_panels", &c.num_panels),
                   IntegerField(r, "num_objects", &c.num_objects), NumberField(r, "object_side", &c.object_side),
                   RangeField(r, "opening_width", &c.opening_width), RangeField(r, "opening_height", &c.opening_height),
                   RangeField(r, "depth", &c.depth), RangeField(r, "box_size", &c.box_size),
                   RangeField(r, "box_height", &c.box_height), RangeField(r, "table_gap", &c.table_gap),
                   NumberField(r, "grasp_object_probability", &c.grasp_object_probability),
                   NumberField(r, "grasp_object_half_width", &c.grasp_object_half_width),
                   NumberField(r, "grasp_object_half_length", &c.grasp_object_half_length),
                   RangeField(r, "grasp_clearance", &c.grasp_clearance),
                   IntegerField(r, "num_crossing", &c.num_crossing), NumberField(r, "crossing_side", &c.crossing_side),
                   NumberField(r, "crossing_speed", &c.crossing_speed),
                   NumberField(r, "crossing_speed_max", &c.crossing_speed_max),
                   NumberField(r, "min_base_distance", &c.min_base_distance), NumberField(r, "spawn_margin", &c.spawn_margin),
                   NumberField(r, "start_spread", &c.start_spread), NumberField(r, "limit_margin", &c.limit_margin),
                   NumberField(r, "min_target_distance", &c.min_target_distance),
                   NumberField(r, "goal_clearance", &c.goal_clearance), NumberField(r, "start_clearance", &c.start_clearance),
                   FlagField(r, "joint_goal", &c.joint_goal), IntegerField(r, "max_attempts", &c.max_attempts),
                   Workspace(r, &c.workspace)});
      break;
    }
  }
}

// ------------------------------------------------------------------------------------------------- validation
}  // namespace

std::string_view TaskKindName(TaskKind kind) {
  switch (kind) {
    case TaskKind::kPretrain2Link: return "pretrain-2link";
    case TaskKind::kReachAvoid: return "reach-avoid";
    case TaskKind::kLineCrossing: return "line-crossing";
    case TaskKind::kCluttered: return "cluttered";
    case TaskKind::kCells: return "cells";
  }
  return "?";
}

std::string_view TaskSceneName(TaskKind kind) {
  switch (kind) {
    case TaskKind::kPretrain2Link: return "pretrain-2link";
    case TaskKind::kReachAvoid: return "crossing";
    case TaskKind::kLineCrossing: return "line-crossing";
    case TaskKind::kCluttered: return "cluttered";
    case TaskKind::kCells: return "cells";
  }
  return "?";
}

TaskKind TaskOfScene(std::string_view scene) {
  std::string scenes;
  for (TaskKind kind : {TaskKind::kPretrain2Link, TaskKind::kReachAvoid, TaskKind::kLineCrossing,
                        TaskKind::kCluttered, TaskKind::kCells}) {
    if (TaskSceneName(kind) == scene) return kind;
    scenes += fmt::format("{}{} ({})", scenes.empty() ? "" : ", ", TaskSceneName(kind), TaskKindName(kind));
  }
  throw InputError(fmt::format("scene '{}': expected a scene a task runs, one of {}", scene, scenes));
}

bool IsArmTaskScene(std::string_view scene) {
  for (TaskKind kind : {TaskKind::kReachAvoid, TaskKind::kLineCrossing, TaskKind::kCluttered, TaskKind::kCells}) {
    if (TaskSceneName(kind) == scene) return true;
  }
  return false;
}

control::AgentConfig AgentConfigOf(const TaskConfig& config) {
  control::AgentConfig a;
  a.interface = config.interface;
  a.episode = config.episode;
  a.controller = config.controller;
  a.options = config.options;
  a.direct = config.direct;
  a.observation = config.observation;
  a.basic_layer = config.basic_layer;
  return a;
}

void SetAgentConfig(TaskConfig& config, const control::AgentConfig& agent) {
  config.interface = agent.interface;
  static_cast<control::AgentEpisode&>(config.episode) = agent.episode;
  config.controller = agent.controller;
  config.options = agent.options;
  config.direct = agent.direct;
  config.observation = agent.observation;
  config.basic_layer = agent.basic_layer;
}

std::vector<std::string> TaskNames() {
  return {"pretrain-2link", "reach-avoid", "line-crossing", "cluttered", "cells"};
}

TaskKind ParseTaskKind(std::string_view name) {
  for (TaskKind k : {TaskKind::kPretrain2Link, TaskKind::kReachAvoid, TaskKind::kLineCrossing, TaskKind::kCluttered,
                     TaskKind::kCells}) {
    if (TaskKindName(k) == name) return k;
  }
  throw InputError(fmt::format("unknown task '{}': expected one of pretrain-2link, reach-avoid, line-crossing, "
                               "cluttered, cells", name));
}

TaskConfig DefaultTaskConfig(TaskKind task) {
  TaskConfig c;
  c.task = task;
  SetAgentConfig(c, control::DefaultAgentConfig(TaskKindName(task)));
  // slow targets and obstacles move once per env step (≤ 3 mm); the fast line of line-crossing every physics step
  c.episode.scenario_update = task == TaskKind::kLineCrossing ? ScenarioUpdate::kPhysicsStep : ScenarioUpdate::kControlStep;
  switch (task) {
    case TaskKind::kPretrain2Link:
      c.robot = "planar2";
      c.randomization.variants = 16;
      c.planar2.link1_length = {0.3, 0.7};
      c.planar2.link2_length = {0.3, 0.7};
      c.randomization.initial_q_spread = 1.5;
      c.randomization.initial_qd_fraction = 0.2;
      // reachable for every link-length draw: |l1 − l2| ≤ 0.4 R keeps the inner hole below near·R, and
      // far² + half_width² < 1 keeps the box corners inside the reach R
      c.scenario.pretrain.workspace.near = 0.45;
      c.scenario.pretrain.workspace.far = 0.8;
      c.scenario.pretrain.workspace.half_width = 0.55;
      // the cube beside the target's path, inside the 15 cm warning band of an end effector that tracks exactly
      // (surface 1–8 cm from its 4 cm capsule): tracking and avoiding are compatible, so the tracking error
      // measures the policy, not the scene (on the path, every controller leaves the target while it passes the cube)
      c.scenario.pretrain.obstacle_path_offset = {0.05, 0.12};
      break;
    case TaskKind::kReachAvoid:
      c.robot = "panda";
      c.randomization.variants = 8;
      c.randomization.link_scale = {0.85, 1.15};
      c.scenario.crossing.num_obstacles = 1;
      c.scenario.crossing.obstacle_speed = 0.3;
      c.scenario.crossing.target_speed = 0.1;
      break;
    case TaskKind::kLineCrossing:
      c.robot = "panda";
      c.scenario.line_crossing.num_obstacles = 5;
      break;
    case TaskKind::kCluttered:
      c.robot = "panda";
      c.scenario.cluttered.num_obstacles = 6;
      break;
    case TaskKind::kCells:
      c.robot = "panda";
      c.randomization.variants = 8;
      c.randomization.link_scale = {0.85, 1.15};
      break;
  }
  return c;
}

std::filesystem::path TaskConfigDirectory() {
  return kinematics::ModelsDirectory().parent_path() / "configs" / "tasks";
}

std::filesystem::path TaskConfigPath(std::string_view name) {
  return TaskConfigDirectory() / (std::string(name) + ".yaml");
}

TaskConfig LoadShippedTaskConfig(std::string_view name) {
  ParseTaskKind(name);  // a clear message for an unknown task before the missing file
  return LoadTaskConfig(TaskConfigPath(name));
}

namespace {

TaskConfig ParseTaskNode(const YAML::Node& root, const std::string& file);
void ReadTaskNode(const YAML::Node& root, const std::string& file, TaskConfig& c);

}  // namespace

TaskConfig LoadTaskConfig(const std::filesystem::path& path) {
  return ParseTaskNode(internal::LoadYamlFile(path.string(), "task config"), path.string());
}

TaskConfig LoadTaskConfig(const std::filesystem::path& path, const std::string& overrides_yaml) {
  YAML::Node root = internal::LoadYamlFile(path.string(), "task config");
  const std::string source = path.string() + " + overrides";
  const YAML::Node over = LoadYamlText(overrides_yaml, source);
  if (!over.IsNull()) {
    if (!over.IsMap() || !root.IsMap()) {
      throw InputError(fmt::format("{}: expected the file and the overrides to be mappings", source));
    }
    internal::MergeYamlMaps(root, over, source);
  }
  return ParseTaskNode(root, source);
}

TaskConfig ParseTaskConfig(const std::string& yaml_text, const std::string& source) {
  return ParseTaskNode(LoadYamlText(yaml_text, source), source);
}

void ApplyTaskOverrides(TaskConfig& config, const std::string& overrides_yaml, const std::string& source) {
  const YAML::Node over = LoadYamlText(overrides_yaml, source);
  if (over.IsNull()) return;
  if (!over.IsMap()) throw InputError(fmt::format("{}: expected a mapping of task config keys", source));
  if (const YAML::Node t = over["task"]; t && !(t.IsScalar() && t.Scalar() == TaskKindName(config.task))) {
    throw InputError(fmt::format("{}: key 'task': overrides keep the task ({}); got '{}'", source,
                                 TaskKindName(config.task), t.IsScalar() ? t.Scalar() : YAML::Dump(t)));
  }
  TaskConfig c = config;
  ReadTaskNode(over, source, c);
  config = std::move(c);
}

namespace {

TaskConfig ParseTaskNode(const YAML::Node& root, const std::string& file) {
  const Reader r(file);
  r.CheckKeys(root, "",
              {"task", "robot", "collision", "interface", "episode", "controller", "options", "direct", "observation", "reward",
               "randomization", "planar2", "scenario", "rmp"});
  const YAML::Node task_node = root["task"];
  if (!task_node) r.Fail(root, "task", "missing (expected one of pretrain-2link, reach-avoid, line-crossing, cluttered, cells)");
  const std::string task_name = r.String(task_node, "task");
  TaskKind task = TaskKind::kReachAvoid;
  try {
    task = ParseTaskKind(task_name);
  } catch (const InputError& e) {
    r.Fail(task_node, "task", e.what());
  }
  TaskConfig c = DefaultTaskConfig(task);
  c.source = file;
  ReadTaskNode(root, file, c);
  return c;
}

// reads the keys present in `root` onto `c` (the others keep their values) and validates the result
void ReadTaskNode(const YAML::Node& root, const std::string& file, TaskConfig& c) {
  const Reader r(file);
  r.CheckKeys(root, "",
              {"task", "robot", "collision", "interface", "episode", "controller", "options", "direct", "observation", "reward",
               "randomization", "planar2", "scenario", "rmp"});
  const TaskKind task = c.task;
  control::AgentConfig agent = AgentConfigOf(c);
  control::ReadAgentSections(r, root, &agent, &kTaskEpisodeKeys);
  SetAgentConfig(c, agent);
  if (const YAML::Node n = root["robot"]) c.robot = r.String(n, "robot");
  if (const YAML::Node n = root["collision"]) c.collision = r.String(n, "collision");
  if (const YAML::Node n = root["episode"]) {
    EpisodeConfig& e = c.episode;
    ReadYamlSection(r, n, "episode",
                {{"integrator",
                  [&r, &e](const YAML::Node& v, const std::string& k) {
                    e.integrator = r.Choice(v, k, {"euler", "implicit"}) == 0 ? sim::Integrator::kEuler
                                                                              : sim::Integrator::kImplicit;
                  }},
                 FlagField(r, "terminate_on_collision", &e.terminate_on_collision), NumberField(r, "discount", &e.discount),
                 {"scenario_update",
                  [&r, &e](const YAML::Node& v, const std::string& k) {
                    e.scenario_update = r.Choice(v, k, {"physics", "control"}) == 0 ? ScenarioUpdate::kPhysicsStep
                                                                                     : ScenarioUpdate::kControlStep;
                  }},
                 NumberField(r, "success_max_final_error", &e.success_max_final_error, /*allow_inf=*/true)},
                kAgentEpisodeKeys);
  }
  if (const YAML::Node n = root["reward"]) {
    RewardConfig& w = c.reward;
    ReadYamlSection(r, n, "reward",
                {{"joint_reach_weights",
                  [&r, &w](const YAML::Node& v, const std::string& k) { w.joint_reach_weights = r.List(v, k); }},
                 NumberField(r, "joint_reach_tolerance", &w.joint_reach_tolerance),
                 NumberField(r, "distance_weight", &w.distance_weight), NumberField(r, "distance_unit", &w.distance_unit),
                 NumberField(r, "time_reward", &w.time_reward), NumberField(r, "reach_tolerance", &w.reach_tolerance),
                 NumberField(r, "reach_release", &w.reach_release), NumberField(r, "collision_penalty", &w.collision_penalty),
                 NumberField(r, "tracking_weight", &w.tracking_weight), NumberField(r, "precision_weight", &w.precision_weight),
                 NumberField(r, "precision_length", &w.precision_length),
                 NumberField(r, "precision_pass_clearance", &w.precision_pass_clearance, /*allow_inf=*/true)});
  }
  if (const YAML::Node n = root["randomization"]) {
    RandomizationConfig& d = c.randomization;
    ReadYamlSection(r, n, "randomization",
                {IntegerField(r, "variants", &d.variants), FlagField(r, "include_nominal", &d.include_nominal),
                 {"seed",
                  [&r, &d](const YAML::Node& v, const std::string& k) {
                    const int seed = r.Integer(v, k);
                    if (seed < 0) r.Fail(v, k, fmt::format("expected an integer >= 0, got {}", seed));
                    d.seed = static_cast<std::uint64_t>(seed);
                  }},
                 RangeField(r, "link_scale", &d.link_scale), NumberField(r, "initial_q_spread", &d.initial_q_spread),
                 NumberField(r, "initial_qd_fraction", &d.initial_qd_fraction)});
  }
  if (const YAML::Node n = root["planar2"]) {
    Planar2Config& p = c.planar2;
    ReadYamlSection(r, n, "planar2",
                {RangeField(r, "link1_length", &p.link1_length), RangeField(r, "link2_length", &p.link2_length),
                 NumberField(r, "link_radius", &p.link_radius), NumberField(r, "joint_limit", &p.joint_limit),
                 NumberField(r, "velocity_limit", &p.velocity_limit)});
  }
  if (const YAML::Node n = root["scenario"]) ReadScenario(r, n, task, &c.scenario);
  ValidateTaskConfig(c, file);
}

}  // namespace

bool IsUrdfPath(const std::string& robot) {
  return robot.size() > 5 && robot.compare(robot.size() - 5, 5, ".urdf") == 0;
}

}  // namespace rmpmarl::tasks
