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

#include "../common/yaml_reader.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/tasks/agent_interface.h"

namespace rmpmarl::tasks {
namespace {

// reads YAML nodes; every message names the file, line and dotted key.
class Reader : public internal::YamlReader {
 public:
  using internal::YamlReader::YamlReader;

  std::array<double, 2> Range(const YAML::Node& node, const std::string& key) const {
    if (node.IsScalar()) {
      const double v = Number(node, key);
      return {v, v};
    }
    if (!node.IsSequence() || node.size() != 2) Fail(node, key, "expected [min, max] or a single number");
    const std::array<double, 2> r = {Number(node[0], key + "[0]"), Number(node[1], key + "[1]")};
    if (r[0] > r[1]) Fail(node, key, fmt::format("expected min <= max, got [{}, {}]", r[0], r[1]));
    return r;
  }

  std::vector<double> List(const YAML::Node& node, const std::string& key) const {
    if (node.IsScalar()) return {Number(node, key)};
    if (!node.IsSequence() || node.size() == 0) Fail(node, key, "expected a number or a non-empty list of numbers");
    std::vector<double> values;
    for (size_t i = 0; i < node.size(); ++i) values.push_back(Number(node[i], fmt::format("{}[{}]", key, i)));
    return values;
  }

  // an enumeration value among `names`.
  int Choice(const YAML::Node& node, const std::string& key, std::initializer_list<std::string_view> names) const {
    const std::string value = String(node, key);
    int i = 0;
    std::string list;
    for (std::string_view n : names) {
      if (value == n) return i;
      list += fmt::format("{}'{}'", i == 0 ? "" : ", ", n);
      ++i;
    }
    Fail(node, key, fmt::format("expected one of {}, got '{}'", list, value));
  }

};

// a numeric/bool field of a section: key and setter.
struct Field {
  std::string key;
  std::function<void(const YAML::Node&, const std::string&)> read;
};

// reads a mapping whose allowed keys are exactly `fields`.
void ReadSection(const Reader& r, const YAML::Node& node, const std::string& key, const std::vector<Field>& fields) {
  std::set<std::string> allowed;
  for (const Field& f : fields) allowed.insert(f.key);
  r.CheckKeys(node, key, allowed);
  for (const Field& f : fields) {
    if (const YAML::Node value = node[f.key]) f.read(value, key + "." + f.key);
  }
}

Field Num(const Reader& r, std::string key, double* target, bool allow_inf = false) {
  return {key, [&r, target, allow_inf](const YAML::Node& n, const std::string& k) { *target = r.Number(n, k, allow_inf); }};
}
Field Int(const Reader& r, std::string key, int* target) {
  return {key, [&r, target](const YAML::Node& n, const std::string& k) { *target = r.Integer(n, k); }};
}
Field Flag(const Reader& r, std::string key, bool* target) {
  return {key, [&r, target](const YAML::Node& n, const std::string& k) { *target = r.Bool(n, k); }};
}
Field Rng(const Reader& r, std::string key, std::array<double, 2>* target) {
  return {key, [&r, target](const YAML::Node& n, const std::string& k) { *target = r.Range(n, k); }};
}

Field Workspace(const Reader& r, sim::WorkspaceOptions* w) {
  return {"workspace", [&r, w](const YAML::Node& n, const std::string& k) {
            ReadSection(r, n, k,
                        {Num(r, "near", &w->near), Num(r, "far", &w->far), Num(r, "half_width", &w->half_width),
                         Num(r, "half_height", &w->half_height), Num(r, "min_height", &w->min_height),
                         Int(r, "samples", &w->samples)});
          }};
}

void ReadTargetRmp(const Reader& r, const YAML::Node& node, const std::string& key, rmp::TargetRmpParams* p) {
  std::vector<Field> fields = {Num(r, "accel_p_gain", &p->accel_p_gain),
                               Num(r, "accel_d_gain", &p->accel_d_gain),
                               Num(r, "accel_norm_eps", &p->accel_norm_eps),
                               Num(r, "metric_alpha_length_scale", &p->metric_alpha_length_scale),
                               Num(r, "min_metric_alpha", &p->min_metric_alpha),
                               Num(r, "max_metric_scalar", &p->max_metric_scalar),
                               Num(r, "min_metric_scalar", &p->min_metric_scalar),
                               Num(r, "proximity_metric_boost_scalar", &p->proximity_metric_boost_scalar),
                               Num(r, "proximity_metric_boost_length_scale", &p->proximity_metric_boost_length_scale)};
  fields.push_back({"damping", [&r, p](const YAML::Node& n, const std::string& k) {
                      p->damping = r.Choice(n, k, {"quadratic", "linear"}) == 0 ? rmp::TargetDamping::kQuadratic
                                                                                : rmp::TargetDamping::kLinear;
                    }});
  ReadSection(r, node, key, fields);
}

void ReadCollisionRmp(const Reader& r, const YAML::Node& node, const std::string& key, rmp::CollisionRmpParams* p) {
  ReadSection(r, node, key,
              {Num(r, "repulsion_gain", &p->repulsion_gain), Num(r, "repulsion_std_dev", &p->repulsion_std_dev),
               Num(r, "damping_gain", &p->damping_gain), Num(r, "damping_std_dev", &p->damping_std_dev),
               Num(r, "damping_robustness_eps", &p->damping_robustness_eps),
               Num(r, "damping_velocity_gate_length_scale", &p->damping_velocity_gate_length_scale),
               Num(r, "metric_scalar", &p->metric_scalar),
               Num(r, "metric_exploder_std_dev", &p->metric_exploder_std_dev),
               Num(r, "metric_exploder_eps", &p->metric_exploder_eps),
               Num(r, "metric_modulation_radius", &p->metric_modulation_radius)});
}

void ReadScenario(const Reader& r, const YAML::Node& node, TaskKind task, ScenarioConfig* s) {
  const std::string key = "scenario";
  switch (task) {
    case TaskKind::kPretrain2Link: {
      PretrainScenarioOptions& p = s->pretrain;
      ReadSection(r, node, key,
                  {Rng(r, "target_speed", &p.target_speed), Num(r, "obstacle_side", &p.obstacle_side),
                   Rng(r, "obstacle_lead_time", &p.obstacle_lead_time),
                   Rng(r, "obstacle_path_offset", &p.obstacle_path_offset),
                   Flag(r, "obstacle_out_of_reach", &p.obstacle_out_of_reach), Rng(r, "obstacle_speed", &p.obstacle_speed),
                   Num(r, "start_clearance", &p.start_clearance), Num(r, "target_clearance", &p.target_clearance),
                   Int(r, "max_attempts", &p.max_attempts), Workspace(r, &p.workspace)});
      break;
    }
    case TaskKind::kReachAvoid: {
      sim::CrossingOptions& c = s->crossing;
      ReadSection(r, node, key,
                  {Int(r, "num_obstacles", &c.num_obstacles), Num(r, "obstacle_side", &c.obstacle_side),
                   Num(r, "obstacle_speed", &c.obstacle_speed), Num(r, "obstacle_speed_max", &c.obstacle_speed_max),
                   Num(r, "target_speed", &c.target_speed),
                   Num(r, "min_base_distance", &c.min_base_distance), Num(r, "spawn_margin", &c.spawn_margin),
                   Workspace(r, &c.workspace)});
      break;
    }
    case TaskKind::kLineCrossing: {
      sim::LineCrossingOptions& l = s->line_crossing;
      std::vector<Field> fields = {
          Int(r, "num_obstacles", &l.num_obstacles), Num(r, "obstacle_side", &l.obstacle_side),
          Num(r, "spacing", &l.spacing), Num(r, "target_speed", &l.target_speed),
          Num(r, "max_yaw_deg", &l.max_yaw_deg), Num(r, "min_base_distance", &l.min_base_distance),
          Num(r, "spawn_margin", &l.spawn_margin), Flag(r, "stop_on_impact", &l.stop_on_impact),
          Flag(r, "repeat", &l.repeat), Workspace(r, &l.workspace)};
      fields.push_back({"speeds", [&r, s](const YAML::Node& n, const std::string& k) { s->line_speeds = r.List(n, k); }});
      fields.push_back({"arrangement", [&r, &l](const YAML::Node& n, const std::string& k) {
                          l.arrangement = r.Choice(n, k, {"along", "across"}) == 0 ? sim::LineArrangement::kAlongMotion
                                                                                   : sim::LineArrangement::kAcrossMotion;
                        }});
      ReadSection(r, node, key, fields);
      break;
    }
    case TaskKind::kCluttered: {
      sim::ClutteredOptions& c = s->cluttered;
      ReadSection(r, node, key,
                  {Int(r, "num_obstacles", &c.num_obstacles), Num(r, "obstacle_side", &c.obstacle_side),
                   Num(r, "min_distance", &c.min_distance), Num(r, "max_distance", &c.max_distance),
                   Num(r, "target_speed", &c.target_speed), Num(r, "start_clearance", &c.start_clearance),
                   Num(r, "target_clearance", &c.target_clearance), Int(r, "max_attempts", &c.max_attempts),
                   Workspace(r, &c.workspace)});
      break;
    }
  }
}

// ------------------------------------------------------------------------------------------------- validation
}  // namespace

std::string_view InterfaceModeName(InterfaceMode mode) {
  switch (mode) {
    case InterfaceMode::kPerJointRmp: return "per-joint-rmp";
    case InterfaceMode::kDirect: return "direct";
    case InterfaceMode::kPerJointDirect: return "per-joint-direct";
  }
  return "?";
}

InterfaceMode ParseInterfaceMode(std::string_view name) {
  for (InterfaceMode mode : {InterfaceMode::kPerJointRmp, InterfaceMode::kDirect, InterfaceMode::kPerJointDirect}) {
    if (InterfaceModeName(mode) == name) return mode;
  }
  throw InputError(fmt::format("interface: expected per-joint-rmp, direct or per-joint-direct, got '{}'", name));
}

std::string_view OptionTerminationName(OptionTermination termination) {
  return termination == OptionTermination::kLearned ? "learned" : "fixed";
}

std::string_view TaskKindName(TaskKind kind) {
  switch (kind) {
    case TaskKind::kPretrain2Link: return "pretrain-2link";
    case TaskKind::kReachAvoid: return "reach-avoid";
    case TaskKind::kLineCrossing: return "line-crossing";
    case TaskKind::kCluttered: return "cluttered";
  }
  return "?";
}

std::vector<std::string> TaskNames() { return {"pretrain-2link", "reach-avoid", "line-crossing", "cluttered"}; }

TaskKind ParseTaskKind(std::string_view name) {
  for (TaskKind k : {TaskKind::kPretrain2Link, TaskKind::kReachAvoid, TaskKind::kLineCrossing, TaskKind::kCluttered}) {
    if (TaskKindName(k) == name) return k;
  }
  throw InputError(fmt::format("unknown task '{}': expected one of pretrain-2link, reach-avoid, line-crossing, "
                               "cluttered", name));
}

TaskConfig DefaultTaskConfig(TaskKind task) {
  TaskConfig c;
  c.task = task;
  // the paper's RMPs with the collision RMP switched off beyond the 15 cm warning distance (its sensor horizon)
  c.basic_layer.params.collision.metric_modulation_radius = 0.15;
  c.controller.max_substep = 0.01;  // one policy evaluation per 100 Hz control step
  c.controller.control_rate = c.episode.control_rate;
  // slow targets and obstacles move once per env step (≤ 3 mm); the fast line of line-crossing every physics step
  c.episode.scenario_update = task == TaskKind::kLineCrossing ? ScenarioUpdate::kPhysicsStep : ScenarioUpdate::kControlStep;
  switch (task) {
    case TaskKind::kPretrain2Link:
      c.robot = "planar2";
      c.episode.max_steps = 400;
      c.observation.max_obstacles = 1;
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
      c.episode.max_steps = 500;
      c.observation.max_obstacles = 4;
      c.randomization.variants = 8;
      c.randomization.link_scale = {0.85, 1.15};
      c.scenario.crossing.num_obstacles = 1;
      c.scenario.crossing.obstacle_speed = 0.3;
      c.scenario.crossing.target_speed = 0.1;
      break;
    case TaskKind::kLineCrossing:
      c.robot = "panda";
      c.episode.max_steps = 600;
      c.observation.max_obstacles = 5;
      c.scenario.line_crossing.num_obstacles = 5;
      break;
    case TaskKind::kCluttered:
      c.robot = "panda";
      c.episode.max_steps = 500;
      c.observation.max_obstacles = 6;
      c.scenario.cluttered.num_obstacles = 6;
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

YAML::Node LoadYamlFile(const std::string& file) {
  try {
    return YAML::LoadFile(file);
  } catch (const YAML::BadFile&) {
    throw InputError(fmt::format("{}: cannot open task config (missing or unreadable)", file));
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", file, e.mark.line + 1, e.msg));
  }
}

YAML::Node LoadYamlText(const std::string& text, const std::string& source) {
  try {
    return YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", source, e.mark.line + 1, e.msg));
  }
}

TaskConfig ParseTaskNode(const YAML::Node& root, const std::string& file);
void ReadTaskNode(const YAML::Node& root, const std::string& file, TaskConfig& c);

}  // namespace

TaskConfig LoadTaskConfig(const std::filesystem::path& path) {
  return ParseTaskNode(LoadYamlFile(path.string()), path.string());
}

TaskConfig LoadTaskConfig(const std::filesystem::path& path, const std::string& overrides_yaml) {
  YAML::Node root = LoadYamlFile(path.string());
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
  if (!task_node) r.Fail(root, "task", "missing (expected one of pretrain-2link, reach-avoid, line-crossing, cluttered)");
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
  if (const YAML::Node n = root["robot"]) c.robot = r.String(n, "robot");
  if (const YAML::Node n = root["collision"]) c.collision = r.String(n, "collision");
  if (const YAML::Node n = root["interface"]) {
    c.interface = static_cast<InterfaceMode>(r.Choice(n, "interface", {"per-joint-rmp", "direct", "per-joint-direct"}));
  }
  if (const YAML::Node n = root["episode"]) {
    EpisodeConfig& e = c.episode;
    ReadSection(r, n, "episode",
                {Int(r, "max_steps", &e.max_steps), Num(r, "control_rate", &e.control_rate),
                 Num(r, "physics_timestep", &e.physics_timestep),
                 {"integrator",
                  [&r, &e](const YAML::Node& v, const std::string& k) {
                    e.integrator = r.Choice(v, k, {"euler", "implicit"}) == 0 ? sim::Integrator::kEuler
                                                                              : sim::Integrator::kImplicit;
                  }},
                 Flag(r, "terminate_on_collision", &e.terminate_on_collision), Num(r, "discount", &e.discount),
                 {"scenario_update",
                  [&r, &e](const YAML::Node& v, const std::string& k) {
                    e.scenario_update = r.Choice(v, k, {"physics", "control"}) == 0 ? ScenarioUpdate::kPhysicsStep
                                                                                     : ScenarioUpdate::kControlStep;
                  }},
                 Num(r, "success_max_final_error", &e.success_max_final_error, /*allow_inf=*/true)});
  }
  c.controller.control_rate = c.episode.control_rate;
  if (const YAML::Node n = root["controller"]) {
    sim::ControllerOptions& o = c.controller;
    ReadSection(r, n, "controller",
                {Num(r, "max_substep", &o.max_substep),
                 {"policy_input",
                  [&r, &o](const YAML::Node& v, const std::string& k) {
                    o.policy_input = r.Choice(v, k, {"commanded", "measured"}) == 0 ? sim::PolicyInput::kCommanded
                                                                                    : sim::PolicyInput::kMeasured;
                  }},
                 Num(r, "velocity_limit_scale", &o.velocity_limit_scale),
                 Num(r, "resync_threshold", &o.resync_threshold, /*allow_inf=*/true)});
  }
  if (const YAML::Node n = root["options"]) {
    OptionConfig& o = c.options;
    ReadSection(r, n, "options",
                {{"termination",
                  [&r, &o](const YAML::Node& v, const std::string& k) {
                    o.termination = r.Choice(v, k, {"learned", "fixed"}) == 0 ? OptionTermination::kLearned
                                                                              : OptionTermination::kFixed;
                  }},
                 Int(r, "horizon", &o.horizon), Num(r, "gain_range", &o.gain_range),
                 Num(r, "target_gain_range", &o.target_gain_range),
                 Num(r, "collision_target_weight", &o.collision_target_weight),
                 Num(r, "collision_length_exponent", &o.collision_length_exponent),
                 Int(r, "fixed_option", &o.fixed_option),
                 Int(r, "parameter_period", &o.parameter_period),
                 Num(r, "target_gate_clearance", &o.target_gate_clearance, /*allow_inf=*/true),
                 Num(r, "target_gate_clear", &o.target_gate_clear), Num(r, "target_gate_threat", &o.target_gate_threat),
                 {"warnings", [&r, &o](const YAML::Node& v, const std::string& k) {
                    o.warnings = r.Choice(v, k, {"obstacles", "all"}) == 0 ? OptionWarnings::kObstacles
                                                                          : OptionWarnings::kAll;
                  }}});
  }
  if (const YAML::Node n = root["direct"]) {
    ReadSection(r, n, "direct", {Num(r, "max_speed_fraction", &c.direct.max_speed_fraction)});
  }
  if (const YAML::Node n = root["observation"]) {
    ObservationConfig& o = c.observation;
    ReadSection(r, n, "observation",
                {Num(r, "length_scale", &o.length_scale), Num(r, "speed_scale", &o.speed_scale),
                 Num(r, "warning_distance", &o.warning_distance), Int(r, "max_obstacles", &o.max_obstacles),
                 Num(r, "lookahead", &o.lookahead)});
  }
  if (const YAML::Node n = root["reward"]) {
    RewardConfig& w = c.reward;
    ReadSection(r, n, "reward",
                {{"joint_reach_weights",
                  [&r, &w](const YAML::Node& v, const std::string& k) { w.joint_reach_weights = r.List(v, k); }},
                 Num(r, "joint_reach_tolerance", &w.joint_reach_tolerance),
                 Num(r, "distance_weight", &w.distance_weight), Num(r, "distance_unit", &w.distance_unit),
                 Num(r, "time_reward", &w.time_reward), Num(r, "reach_tolerance", &w.reach_tolerance),
                 Num(r, "reach_release", &w.reach_release), Num(r, "collision_penalty", &w.collision_penalty),
                 Num(r, "tracking_weight", &w.tracking_weight), Num(r, "precision_weight", &w.precision_weight),
                 Num(r, "precision_length", &w.precision_length),
                 Num(r, "precision_pass_clearance", &w.precision_pass_clearance, /*allow_inf=*/true)});
  }
  if (const YAML::Node n = root["randomization"]) {
    RandomizationConfig& d = c.randomization;
    ReadSection(r, n, "randomization",
                {Int(r, "variants", &d.variants), Flag(r, "include_nominal", &d.include_nominal),
                 {"seed",
                  [&r, &d](const YAML::Node& v, const std::string& k) {
                    const int seed = r.Integer(v, k);
                    if (seed < 0) r.Fail(v, k, fmt::format("expected an integer >= 0, got {}", seed));
                    d.seed = static_cast<std::uint64_t>(seed);
                  }},
                 Rng(r, "link_scale", &d.link_scale), Num(r, "initial_q_spread", &d.initial_q_spread),
                 Num(r, "initial_qd_fraction", &d.initial_qd_fraction)});
  }
  if (const YAML::Node n = root["planar2"]) {
    Planar2Config& p = c.planar2;
    ReadSection(r, n, "planar2",
                {Rng(r, "link1_length", &p.link1_length), Rng(r, "link2_length", &p.link2_length),
                 Num(r, "link_radius", &p.link_radius), Num(r, "joint_limit", &p.joint_limit),
                 Num(r, "velocity_limit", &p.velocity_limit)});
  }
  if (const YAML::Node n = root["scenario"]) ReadScenario(r, n, task, &c.scenario);
  if (const YAML::Node n = root["rmp"]) {
    r.CheckKeys(n, "rmp", {"target_rmp", "collision_rmp", "relative_regularizer", "resolve", "target_scale"});
    if (const YAML::Node t = n["target_rmp"]) ReadTargetRmp(r, t, "rmp.target_rmp", &c.basic_layer.params.target);
    if (const YAML::Node t = n["collision_rmp"]) {
      ReadCollisionRmp(r, t, "rmp.collision_rmp", &c.basic_layer.params.collision);
    }
    if (const YAML::Node t = n["relative_regularizer"]) {
      c.basic_layer.relative_regularizer = r.Number(t, "rmp.relative_regularizer");
    }
    if (const YAML::Node t = n["resolve"]) {
      c.basic_layer.resolve = r.Choice(t, "rmp.resolve", {"per-joint", "coupled"}) == 0 ? rmp::LayerResolve::kPerJoint
                                                                                         : rmp::LayerResolve::kCoupled;
    }
    if (const YAML::Node t = n["target_scale"]) {
      c.basic_layer.params.target_scale = r.Choice(t, "rmp.target_scale", {"acceleration", "stiffness"}) == 0
                                              ? rmp::TargetScale::kAcceleration
                                              : rmp::TargetScale::kStiffness;
    }
  }
  ValidateTaskConfig(c, file);
}

}  // namespace

bool IsUrdfPath(const std::string& robot) {
  return robot.size() > 5 && robot.compare(robot.size() - 5, 5, ".urdf") == 0;
}

}  // namespace rmpmarl::tasks
