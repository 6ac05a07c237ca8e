// The agents' configuration: per-task defaults, the controller sections of a task YAML, range checks.
#include "rmpmarl/control/agent_config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <limits>
#include <vector>

#include "rmpmarl/control/agent_config_yaml.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::control {
namespace {

using rmpmarl::internal::ConfigChecker;
using rmpmarl::internal::FlagField;
using rmpmarl::internal::IntegerField;
using rmpmarl::internal::NumberField;
using rmpmarl::internal::RangeField;
using rmpmarl::internal::ReadYamlSection;
using rmpmarl::internal::YamlField;
using rmpmarl::internal::YamlReader;

void ReadTargetRmp(const YamlReader& r, const YAML::Node& node, const std::string& key, rmp::TargetRmpParams* p) {
  std::vector<YamlField> fields = {NumberField(r, "accel_p_gain", &p->accel_p_gain),
                               NumberField(r, "accel_d_gain", &p->accel_d_gain),
                               NumberField(r, "accel_norm_eps", &p->accel_norm_eps),
                               NumberField(r, "metric_alpha_length_scale", &p->metric_alpha_length_scale),
                               NumberField(r, "min_metric_alpha", &p->min_metric_alpha),
                               NumberField(r, "max_metric_scalar", &p->max_metric_scalar),
                               NumberField(r, "min_metric_scalar", &p->min_metric_scalar),
                               NumberField(r, "proximity_metric_boost_scalar", &p->proximity_metric_boost_scalar),
                               NumberField(r, "proximity_metric_boost_length_scale", &p->proximity_metric_boost_length_scale)};
  fields.push_back({"damping", [&r, p](const YAML::Node& n, const std::string& k) {
                      p->damping = r.Choice(n, k, {"quadratic", "linear"}) == 0 ? rmp::TargetDamping::kQuadratic
                                                                                : rmp::TargetDamping::kLinear;
                    }});
  ReadYamlSection(r, node, key, fields);
}

void ReadCollisionRmp(const YamlReader& r, const YAML::Node& node, const std::string& key, rmp::CollisionRmpParams* p) {
  ReadYamlSection(r, node, key,
              {NumberField(r, "repulsion_gain", &p->repulsion_gain), NumberField(r, "repulsion_std_dev", &p->repulsion_std_dev),
               NumberField(r, "damping_gain", &p->damping_gain), NumberField(r, "damping_std_dev", &p->damping_std_dev),
               NumberField(r, "damping_robustness_eps", &p->damping_robustness_eps),
               NumberField(r, "damping_velocity_gate_length_scale", &p->damping_velocity_gate_length_scale),
               NumberField(r, "metric_scalar", &p->metric_scalar),
               NumberField(r, "metric_exploder_std_dev", &p->metric_exploder_std_dev),
               NumberField(r, "metric_exploder_eps", &p->metric_exploder_eps),
               NumberField(r, "metric_modulation_radius", &p->metric_modulation_radius)});
}

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

AgentConfig DefaultAgentConfig(std::string_view task) {
  AgentConfig c;
  // the paper's RMPs with the collision RMP switched off beyond the 15 cm warning distance (its sensor horizon)
  c.basic_layer.params.collision.metric_modulation_radius = 0.15;
  c.controller.max_substep = 0.01;  // one policy evaluation per 100 Hz control step
  c.controller.control_rate = c.episode.control_rate;
  if (task == "pretrain-2link") {
    c.episode.max_steps = 400;
    c.observation.max_obstacles = 1;
  } else if (task == "reach-avoid") {
    c.episode.max_steps = 500;
    c.observation.max_obstacles = 4;
  } else if (task == "line-crossing") {
    c.episode.max_steps = 600;
    c.observation.max_obstacles = 5;
  } else if (task == "cluttered") {
    c.episode.max_steps = 500;
    c.observation.max_obstacles = 6;
  } else if (task == "cells") {
    c.episode.max_steps = 1000;      // 10 s: a benchmark problem's time
    c.observation.max_obstacles = 10;  // 6 boards, 2 objects, the object reached for, 1 crossing cube
  } else {
    throw InputError(fmt::format("task: expected one of pretrain-2link, reach-avoid, line-crossing, cluttered, cells, "
                                 "got '{}'", task));
  }
  return c;
}

// the agent sections of a config file, read here and by the task config (agent_config_yaml.h)

void ReadAgentSections(const YamlReader& r, const YAML::Node& root, AgentConfig* config,
                       const std::set<std::string>* episode_also) {
  AgentConfig& c = *config;
  if (const YAML::Node n = root["interface"]) {
    c.interface = static_cast<InterfaceMode>(r.Choice(n, "interface", {"per-joint-rmp", "direct", "per-joint-direct"}));
  }
  if (const YAML::Node n = root["episode"]) {
    AgentEpisode& e = c.episode;
    const std::vector<YamlField> fields = {IntegerField(r, "max_steps", &e.max_steps),
                                           NumberField(r, "control_rate", &e.control_rate),
                                           NumberField(r, "physics_timestep", &e.physics_timestep)};
    if (episode_also != nullptr) {
      ReadYamlSection(r, n, "episode", fields, *episode_also);
    } else {
      if (!n.IsMap()) r.Fail(n, "episode", "expected a mapping");
      for (const YamlField& f : fields) {
        if (const YAML::Node value = n[f.key]) f.read(value, "episode." + f.key);
      }
    }
  }
  c.controller.control_rate = c.episode.control_rate;
  if (const YAML::Node n = root["controller"]) {
    ControllerOptions& o = c.controller;
    ReadYamlSection(r, n, "controller",
                {NumberField(r, "max_substep", &o.max_substep),
                 {"policy_input",
                  [&r, &o](const YAML::Node& v, const std::string& k) {
                    o.policy_input = r.Choice(v, k, {"commanded", "measured"}) == 0 ? PolicyInput::kCommanded
                                                                                    : PolicyInput::kMeasured;
                  }},
                 NumberField(r, "velocity_limit_scale", &o.velocity_limit_scale),
                 NumberField(r, "resync_threshold", &o.resync_threshold, /*allow_inf=*/true)});
  }
  if (const YAML::Node n = root["options"]) {
    OptionConfig& o = c.options;
    ReadYamlSection(r, n, "options",
                {{"termination",
                  [&r, &o](const YAML::Node& v, const std::string& k) {
                    o.termination = r.Choice(v, k, {"learned", "fixed"}) == 0 ? OptionTermination::kLearned
                                                                              : OptionTermination::kFixed;
                  }},
                 IntegerField(r, "horizon", &o.horizon), NumberField(r, "gain_range", &o.gain_range),
                 NumberField(r, "target_gain_range", &o.target_gain_range),
                 NumberField(r, "collision_target_weight", &o.collision_target_weight),
                 NumberField(r, "collision_length_exponent", &o.collision_length_exponent),
                 IntegerField(r, "fixed_option", &o.fixed_option),
                 IntegerField(r, "parameter_period", &o.parameter_period),
                 NumberField(r, "target_gate_clearance", &o.target_gate_clearance, /*allow_inf=*/true),
                 NumberField(r, "target_gate_clear", &o.target_gate_clear), NumberField(r, "target_gate_threat", &o.target_gate_threat),
                 NumberField(r, "collision_gate_clear", &o.collision_gate_clear),
                 NumberField(r, "collision_gate_threat", &o.collision_gate_threat),
                 FlagField(r, "agents_under_threat_only", &o.agents_under_threat_only),
                 {"warnings", [&r, &o](const YAML::Node& v, const std::string& k) {
                    o.warnings = r.Choice(v, k, {"obstacles", "all"}) == 0 ? OptionWarnings::kObstacles
                                                                          : OptionWarnings::kAll;
                  }}});
  }
  if (const YAML::Node n = root["direct"]) {
    ReadYamlSection(r, n, "direct", {NumberField(r, "max_speed_fraction", &c.direct.max_speed_fraction)});
  }
  if (const YAML::Node n = root["observation"]) {
    ObservationConfig& o = c.observation;
    ReadYamlSection(r, n, "observation",
                {NumberField(r, "length_scale", &o.length_scale), NumberField(r, "speed_scale", &o.speed_scale),
                 NumberField(r, "warning_distance", &o.warning_distance), IntegerField(r, "max_obstacles", &o.max_obstacles),
                 NumberField(r, "lookahead", &o.lookahead)});
  }
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
}

void CheckPassClearance(const ConfigChecker& check, const AgentConfig& c, double clearance, const std::string& key,
                        std::string_view off, bool interface_ok, std::string_view interfaces) {
  check(!std::isnan(clearance) && clearance < std::numeric_limits<double>::infinity(), key,
        fmt::format("a clearance [m] or -.inf ({})", off), clearance);
  check(!std::isfinite(clearance) || (c.observation.lookahead > 0.0 && interface_ok), key,
        fmt::format("-.inf unless the look-ahead block is on (observation.lookahead > 0, got {}) on {} interface "
                    "(got {})", c.observation.lookahead, interfaces, InterfaceModeName(c.interface)), clearance);
}

AgentConfig ParseAgentConfig(const std::string& yaml_text, const std::string& source) {
  const YAML::Node root = rmpmarl::internal::LoadYamlText(yaml_text, source);
  const YamlReader r(source);
  if (!root.IsMap()) r.Fail(root, "", "expected a mapping of task config keys");
  const YAML::Node task_node = root["task"];
  if (!task_node) r.Fail(root, "task", "missing (expected one of pretrain-2link, reach-avoid, line-crossing, cluttered)");
  AgentConfig c;
  try {
    c = DefaultAgentConfig(r.String(task_node, "task"));
  } catch (const InputError& e) {
    r.Fail(task_node, "task", e.what());
  }
  ReadAgentSections(r, root, &c, nullptr);
  ValidateAgentConfig(c, source);
  return c;
}

void ValidateAgentConfig(const AgentConfig& c, std::string_view where) {
  const ConfigChecker check(where);
  const AgentEpisode& e = c.episode;
  check(e.max_steps >= 1 && e.max_steps <= 10000000, "episode.max_steps", "an integer in [1, 1e7]", e.max_steps);
  check(std::isfinite(e.physics_timestep) && e.physics_timestep > 0.0 && e.physics_timestep <= 0.1,
        "episode.physics_timestep", "a timestep in (0, 0.1] s", e.physics_timestep);
  check(std::isfinite(e.control_rate) && e.control_rate > 0.0, "episode.control_rate", "a rate > 0 Hz",
        e.control_rate);
  const double ratio = 1.0 / (e.control_rate * e.physics_timestep);
  check(std::round(ratio) >= 1.0 && std::abs(ratio - std::round(ratio)) <= 1e-6 * ratio, "episode.control_rate",
        fmt::format("a control period that is a whole number of physics timesteps ({:g} Hz divided by an integer)",
                    1.0 / e.physics_timestep),
        fmt::format("{:g} Hz", e.control_rate));
  const ControllerOptions& k = c.controller;
  check(k.control_rate == e.control_rate, "controller.control_rate", "episode.control_rate", k.control_rate);
  check(std::isfinite(k.max_substep) && k.max_substep > 0.0, "controller.max_substep", "a step > 0 s", k.max_substep);
  check(std::isfinite(k.velocity_limit_scale) && k.velocity_limit_scale > 0.0, "controller.velocity_limit_scale",
        "a number > 0", k.velocity_limit_scale);
  check(!std::isnan(k.resync_threshold) && k.resync_threshold > 0.0, "controller.resync_threshold",
        "a distance > 0 (.inf: never)", k.resync_threshold);

  // agent interface
  check(c.options.horizon >= 1 && c.options.horizon <= 100000, "options.horizon", "an integer in [1, 100000]",
        c.options.horizon);
  check(std::isfinite(c.options.gain_range) && c.options.gain_range >= 1.0 && c.options.gain_range <= 1e6,
        "options.gain_range", "a factor in [1, 1e6]", c.options.gain_range);
  check(std::isfinite(c.options.target_gain_range) &&
            (c.options.target_gain_range == 0.0 ||
             (c.options.target_gain_range >= 1.0 && c.options.target_gain_range <= 1e6)),
        "options.target_gain_range", "0 (options.gain_range) or a factor in [1, 1e6]", c.options.target_gain_range);
  check(std::isfinite(c.options.collision_target_weight) && c.options.collision_target_weight >= 0.0 &&
            c.options.collision_target_weight <= 1.0,
        "options.collision_target_weight", "a weight in [0, 1]", c.options.collision_target_weight);
  check(std::isfinite(c.options.collision_length_exponent) && c.options.collision_length_exponent >= 0.0 &&
            c.options.collision_length_exponent <= 4.0,
        "options.collision_length_exponent", "an exponent in [0, 4]", c.options.collision_length_exponent);
  check(c.options.parameter_period >= 1 && c.options.parameter_period <= 1000, "options.parameter_period",
        "a period in steps in [1, 1000]", c.options.parameter_period);
  check(c.options.fixed_option >= -1 && c.options.fixed_option < kNumRmpOptions, "options.fixed_option",
        "-1 (learned) or an option index 0, 1, 2", c.options.fixed_option);
  const OptionConfig& op = c.options;
  CheckPassClearance(check, c, op.target_gate_clearance, "options.target_gate_clearance", "no prior",
                     c.interface == InterfaceMode::kPerJointRmp, "the per-joint-rmp");
  check(std::isfinite(op.target_gate_clear) && std::abs(op.target_gate_clear) <= 1.0, "options.target_gate_clear",
        "a parameter u in [-1, 1]", op.target_gate_clear);
  check(std::isfinite(op.target_gate_threat) && std::abs(op.target_gate_threat) <= 1.0, "options.target_gate_threat",
        "a parameter u in [-1, 1]", op.target_gate_threat);
  for (const auto& [key, u] : {std::pair{"options.collision_gate_clear", op.collision_gate_clear},
                               std::pair{"options.collision_gate_threat", op.collision_gate_threat}}) {
    check(std::isfinite(u) && std::abs(u) <= 1.0, key, "a parameter u in [-1, 1]", u);
    check(u == 0.0 || op.TargetGated(), key, "0 unless options.target_gate_clearance sets the gate", u);
  }
  check(!op.agents_under_threat_only || (op.TargetGated() && op.fixed_option >= 0), "options.agents_under_threat_only",
        "false unless options.target_gate_clearance sets the gate and options.fixed_option fixes the option (the "
        "agents' option choice would act in every step)", "true");
  check(std::isfinite(c.direct.max_speed_fraction) && c.direct.max_speed_fraction > 0.0 &&
            c.direct.max_speed_fraction <= 1.0,
        "direct.max_speed_fraction", "a fraction in (0, 1]", c.direct.max_speed_fraction);

  // observation
  const ObservationConfig& o = c.observation;
  check(std::isfinite(o.length_scale) && o.length_scale > 0.0, "observation.length_scale", "a length > 0 m",
        o.length_scale);
  check(std::isfinite(o.speed_scale) && o.speed_scale > 0.0, "observation.speed_scale", "a speed > 0 m/s",
        o.speed_scale);
  check(std::isfinite(o.warning_distance) && o.warning_distance > 0.0 && o.warning_distance <= 1.0,
        "observation.warning_distance", "a distance in (0, 1] m", o.warning_distance);
  check(std::isfinite(o.lookahead) && o.lookahead >= 0.0 && o.lookahead <= 10.0, "observation.lookahead",
        "a horizon in [0, 10] s (0: off)", o.lookahead);
  check(o.max_obstacles >= 0 && o.max_obstacles <= 64, "observation.max_obstacles", "an integer in [0, 64]",
        o.max_obstacles);

  // basic layer
  rmp::ValidateTargetRmpParams(c.basic_layer.params.target, fmt::format("{}: rmp.target_rmp", where));
  rmp::ValidateCollisionRmpParams(c.basic_layer.params.collision, fmt::format("{}: rmp.collision_rmp", where));
  check(std::isfinite(c.basic_layer.relative_regularizer) && c.basic_layer.relative_regularizer > 0.0,
        "rmp.relative_regularizer", "a number > 0", c.basic_layer.relative_regularizer);
}

}  // namespace rmpmarl::control
