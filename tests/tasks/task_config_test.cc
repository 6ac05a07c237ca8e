// Task configs: the shipped YAML equals the C++ defaults; bad files fail with the file and key in the message.
#include "rmpmarl/tasks/task_config.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "rmpmarl/common/error.h"

namespace rmpmarl::tasks {
namespace {

// every value of a config as name → number (enums and flags as numbers), for whole-config comparisons.
std::map<std::string, double> Flatten(const TaskConfig& c) {
  std::map<std::string, double> f;
  f["task"] = static_cast<double>(c.task);
  f["interface"] = static_cast<double>(c.interface);
  const EpisodeConfig& e = c.episode;
  f["episode.max_steps"] = e.max_steps;
  f["episode.control_rate"] = e.control_rate;
  f["episode.physics_timestep"] = e.physics_timestep;
  f["episode.integrator"] = static_cast<double>(e.integrator);
  f["episode.terminate_on_collision"] = e.terminate_on_collision;
  f["episode.discount"] = e.discount;
  f["episode.scenario_update"] = static_cast<double>(e.scenario_update);
  f["episode.success_max_final_error"] = e.success_max_final_error;
  f["controller.control_rate"] = c.controller.control_rate;
  f["controller.max_substep"] = c.controller.max_substep;
  f["controller.policy_input"] = static_cast<double>(c.controller.policy_input);
  f["controller.velocity_limit_scale"] = c.controller.velocity_limit_scale;
  f["controller.resync_threshold"] = c.controller.resync_threshold;
  f["options.termination"] = static_cast<double>(c.options.termination);
  f["options.horizon"] = c.options.horizon;
  f["options.gain_range"] = c.options.gain_range;
  f["options.target_gain_range"] = c.options.target_gain_range;
  f["options.collision_target_weight"] = c.options.collision_target_weight;
  f["options.warnings"] = static_cast<double>(c.options.warnings);
  f["options.target_gate_clearance"] = c.options.target_gate_clearance;
  f["options.target_gate_clear"] = c.options.target_gate_clear;
  f["options.target_gate_threat"] = c.options.target_gate_threat;
  f["options.collision_gate_clear"] = c.options.collision_gate_clear;
  f["options.collision_gate_threat"] = c.options.collision_gate_threat;
  f["options.agents_under_threat_only"] = c.options.agents_under_threat_only;
  f["direct.max_speed_fraction"] = c.direct.max_speed_fraction;
  f["observation.length_scale"] = c.observation.length_scale;
  f["observation.speed_scale"] = c.observation.speed_scale;
  f["observation.warning_distance"] = c.observation.warning_distance;
  f["observation.max_obstacles"] = c.observation.max_obstacles;
  f["observation.lookahead"] = c.observation.lookahead;
  const RewardConfig& r = c.reward;
  for (size_t i = 0; i < r.joint_reach_weights.size(); ++i) {
    f["reward.joint_reach_weights." + std::to_string(i)] = r.joint_reach_weights[i];
  }
  f["reward.joint_reach_tolerance"] = r.joint_reach_tolerance;
  f["reward.distance_weight"] = r.distance_weight;
  f["reward.distance_unit"] = r.distance_unit;
  f["reward.time_reward"] = r.time_reward;
  f["reward.reach_tolerance"] = r.reach_tolerance;
  f["reward.reach_release"] = r.reach_release;
  f["reward.collision_penalty"] = r.collision_penalty;
  f["reward.tracking_weight"] = r.tracking_weight;
  f["reward.precision_weight"] = r.precision_weight;
  f["reward.precision_length"] = r.precision_length;
  f["reward.precision_pass_clearance"] = r.precision_pass_clearance;
  const RandomizationConfig& d = c.randomization;
  f["randomization.variants"] = d.variants;
  f["randomization.include_nominal"] = d.include_nominal;
  f["randomization.seed"] = static_cast<double>(d.seed);
  f["randomization.link_scale.min"] = d.link_scale[0];
  f["randomization.link_scale.max"] = d.link_scale[1];
  f["randomization.initial_q_spread"] = d.initial_q_spread;
  f["randomization.initial_qd_fraction"] = d.initial_qd_fraction;
  const Planar2Config& p = c.planar2;
  f["planar2.link1_length.min"] = p.link1_length[0];
  f["planar2.link1_length.max"] = p.link1_length[1];
  f["planar2.link2_length.min"] = p.link2_length[0];
  f["planar2.link2_length.max"] = p.link2_length[1];
  f["planar2.link_radius"] = p.link_radius;
  f["planar2.joint_limit"] = p.joint_limit;
  f["planar2.velocity_limit"] = p.velocity_limit;
  const auto workspace = [&f](const std::string& k, const sim::WorkspaceOptions& w) {
    f[k + ".near"] = w.near;
    f[k + ".far"] = w.far;
    f[k + ".half_width"] = w.half_width;
    f[k + ".half_height"] = w.half_height;
    f[k + ".min_height"] = w.min_height;
    f[k + ".samples"] = w.samples;
  };
  const PretrainScenarioOptions& s = c.scenario.pretrain;
  f["pretrain.target_speed.min"] = s.target_speed[0];
  f["pretrain.target_speed.max"] = s.target_speed[1];
  f["pretrain.obstacle_side"] = s.obstacle_side;
  f["pretrain.obstacle_lead_time.min"] = s.obstacle_lead_time[0];
  f["pretrain.obstacle_lead_time.max"] = s.obstacle_lead_time[1];
  f["pretrain.obstacle_path_offset.min"] = s.obstacle_path_offset[0];
  f["pretrain.obstacle_path_offset.max"] = s.obstacle_path_offset[1];
  f["pretrain.obstacle_out_of_reach"] = s.obstacle_out_of_reach;
  f["pretrain.obstacle_speed.min"] = s.obstacle_speed[0];
  f["pretrain.obstacle_speed.max"] = s.obstacle_speed[1];
  f["pretrain.start_clearance"] = s.start_clearance;
  f["pretrain.target_clearance"] = s.target_clearance;
  f["pretrain.max_attempts"] = s.max_attempts;
  workspace("pretrain.workspace", s.workspace);
  const sim::CellsOptions& cl = c.scenario.cells;
  for (size_t i = 0; i < cl.kind_weights.size(); ++i) f["cells.kind_weights." + std::to_string(i)] = cl.kind_weights[i];
  f["cells.panel_length"] = cl.panel_length;
  f["cells.panel_width"] = cl.panel_width;
  f["cells.panel_thickness"] = cl.panel_thickness;
  f["cells.num_panels"] = cl.num_panels;
  f["cells.num_objects"] = cl.num_objects;
  f["cells.object_side"] = cl.object_side;
  for (const auto& [key, range] : {std::pair{"opening_width", cl.opening_width}, std::pair{"opening_height", cl.opening_height},
                                   std::pair{"depth", cl.depth}, std::pair{"box_size", cl.box_size},
                                   std::pair{"box_height", cl.box_height}, std::pair{"table_gap", cl.table_gap},
                                   std::pair{"grasp_clearance", cl.grasp_clearance}}) {
    f[std::string("cells.") + key + ".min"] = range[0];
    f[std::string("cells.") + key + ".max"] = range[1];
  }
  f["cells.grasp_object_probability"] = cl.grasp_object_probability;
  f["cells.grasp_object_half_width"] = cl.grasp_object_half_width;
  f["cells.grasp_object_half_length"] = cl.grasp_object_half_length;
  f["cells.num_crossing"] = cl.num_crossing;
  f["cells.crossing_side"] = cl.crossing_side;
  f["cells.crossing_speed"] = cl.crossing_speed;
  f["cells.crossing_speed_max"] = cl.crossing_speed_max;
  f["cells.min_base_distance"] = cl.min_base_distance;
  f["cells.spawn_margin"] = cl.spawn_margin;
  f["cells.start_spread"] = cl.start_spread;
  f["cells.limit_margin"] = cl.limit_margin;
  f["cells.min_target_distance"] = cl.min_target_distance;
  f["cells.goal_clearance"] = cl.goal_clearance;
  f["cells.start_clearance"] = cl.start_clearance;
  f["cells.joint_goal"] = cl.joint_goal;
  f["cells.max_attempts"] = cl.max_attempts;
  workspace("cells.workspace", cl.workspace);
  const sim::CrossingOptions& x = c.scenario.crossing;
  f["crossing.num_obstacles"] = x.num_obstacles;
  f["crossing.obstacle_side"] = x.obstacle_side;
  f["crossing.obstacle_speed"] = x.obstacle_speed;
  f["crossing.target_speed"] = x.target_speed;
  f["crossing.min_base_distance"] = x.min_base_distance;
  f["crossing.spawn_margin"] = x.spawn_margin;
  workspace("crossing.workspace", x.workspace);
  const sim::LineCrossingOptions& l = c.scenario.line_crossing;
  f["line.num_obstacles"] = l.num_obstacles;
  f["line.obstacle_side"] = l.obstacle_side;
  f["line.spacing"] = l.spacing;
  f["line.arrangement"] = static_cast<double>(l.arrangement);
  f["line.target_speed"] = l.target_speed;
  f["line.max_yaw_deg"] = l.max_yaw_deg;
  f["line.min_base_distance"] = l.min_base_distance;
  f["line.spawn_margin"] = l.spawn_margin;
  f["line.stop_on_impact"] = l.stop_on_impact;
  f["line.repeat"] = l.repeat;
  for (size_t i = 0; i < c.scenario.line_speeds.size(); ++i) f["line.speeds." + std::to_string(i)] = c.scenario.line_speeds[i];
  workspace("line.workspace", l.workspace);
  const sim::ClutteredOptions& k = c.scenario.cluttered;
  f["cluttered.num_obstacles"] = k.num_obstacles;
  f["cluttered.obstacle_side"] = k.obstacle_side;
  f["cluttered.min_distance"] = k.min_distance;
  f["cluttered.max_distance"] = k.max_distance;
  f["cluttered.target_speed"] = k.target_speed;
  f["cluttered.start_clearance"] = k.start_clearance;
  f["cluttered.target_clearance"] = k.target_clearance;
  f["cluttered.max_attempts"] = k.max_attempts;
  workspace("cluttered.workspace", k.workspace);
  const rmp::TargetRmpParams& t = c.basic_layer.params.target;
  f["target_rmp.damping"] = static_cast<double>(t.damping);
  f["target_rmp.accel_p_gain"] = t.accel_p_gain;
  f["target_rmp.accel_d_gain"] = t.accel_d_gain;
  f["target_rmp.accel_norm_eps"] = t.accel_norm_eps;
  f["target_rmp.metric_alpha_length_scale"] = t.metric_alpha_length_scale;
  f["target_rmp.min_metric_alpha"] = t.min_metric_alpha;
  f["target_rmp.max_metric_scalar"] = t.max_metric_scalar;
  f["target_rmp.min_metric_scalar"] = t.min_metric_scalar;
  f["target_rmp.proximity_metric_boost_scalar"] = t.proximity_metric_boost_scalar;
  f["target_rmp.proximity_metric_boost_length_scale"] = t.proximity_metric_boost_length_scale;
  const rmp::CollisionRmpParams& o = c.basic_layer.params.collision;
  f["collision_rmp.repulsion_gain"] = o.repulsion_gain;
  f["collision_rmp.repulsion_std_dev"] = o.repulsion_std_dev;
  f["collision_rmp.damping_gain"] = o.damping_gain;
  f["collision_rmp.damping_std_dev"] = o.damping_std_dev;
  f["collision_rmp.damping_robustness_eps"] = o.damping_robustness_eps;
  f["collision_rmp.damping_velocity_gate_length_scale"] = o.damping_velocity_gate_length_scale;
  f["collision_rmp.metric_scalar"] = o.metric_scalar;
  f["collision_rmp.metric_exploder_std_dev"] = o.metric_exploder_std_dev;
  f["collision_rmp.metric_exploder_eps"] = o.metric_exploder_eps;
  f["collision_rmp.metric_modulation_radius"] = o.metric_modulation_radius;
  f["relative_regularizer"] = c.basic_layer.relative_regularizer;
  return f;
}

// writes `text` to a fresh file under the test's temporary directory and returns its path.
std::filesystem::path WriteTemp(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "rmpmarl_task_config_test";
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / name;
  std::ofstream(path) << text;
  return path;
}

// the InputError message of loading `text`, or "" when it loads.
std::string LoadError(const std::string& name, const std::string& text) {
  try {
    LoadTaskConfig(WriteTemp(name, text));
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(TaskConfigTest, ShippedFilesEqualTheDefaults) {
  for (const std::string& name : TaskNames()) {
    SCOPED_TRACE(name);
    const TaskConfig shipped = LoadShippedTaskConfig(name);
    const TaskConfig defaults = DefaultTaskConfig(ParseTaskKind(name));
    EXPECT_EQ(shipped.robot, defaults.robot);
    const auto a = Flatten(shipped), b = Flatten(defaults);
    ASSERT_EQ(a.size(), b.size());
    for (const auto& [key, value] : b) EXPECT_EQ(a.at(key), value) << key;
  }
}

TEST(TaskConfigTest, KeysOverrideTheTaskDefaults) {
  const TaskConfig c = LoadTaskConfig(WriteTemp("override.yaml", R"(
task: line-crossing
robot: ur5e
interface: per-joint-direct
episode: {max_steps: 77, terminate_on_collision: true}
options: {termination: fixed, horizon: 3, collision_length_exponent: 0.5}
reward: {distance_weight: 0.5, joint_reach_weights: [1, 2, 3, 4, 5, 6]}
scenario: {speeds: [1.2], num_obstacles: 3}
rmp: {collision_rmp: {metric_scalar: 2}, resolve: coupled, target_scale: stiffness}
)"));
  EXPECT_EQ(c.task, TaskKind::kLineCrossing);
  EXPECT_EQ(c.robot, "ur5e");
  EXPECT_EQ(c.interface, InterfaceMode::kPerJointDirect);
  EXPECT_EQ(c.episode.max_steps, 77);
  EXPECT_TRUE(c.episode.terminate_on_collision);
  EXPECT_EQ(c.options.termination, OptionTermination::kFixed);
  EXPECT_EQ(c.options.horizon, 3);
  EXPECT_EQ(c.options.collision_length_exponent, 0.5);
  EXPECT_EQ(c.reward.distance_weight, 0.5);
  EXPECT_EQ(c.reward.joint_reach_weights.size(), 6u);
  EXPECT_EQ(c.scenario.line_speeds, std::vector<double>{1.2});
  EXPECT_EQ(c.scenario.line_crossing.num_obstacles, 3);
  EXPECT_EQ(c.basic_layer.params.collision.metric_scalar, 2.0);
  EXPECT_EQ(c.basic_layer.resolve, rmp::LayerResolve::kCoupled);
  EXPECT_EQ(c.basic_layer.params.target_scale, rmp::TargetScale::kStiffness);
  // untouched keys keep the task's defaults
  EXPECT_EQ(c.observation.max_obstacles, DefaultTaskConfig(TaskKind::kLineCrossing).observation.max_obstacles);
  EXPECT_EQ(c.basic_layer.params.collision.metric_modulation_radius, 0.15);
}

TEST(TaskConfigTest, OverridesMergeOverTheFile) {
  const TaskConfig c = LoadTaskConfig(TaskConfigPath("line-crossing"),
                                      "episode: {max_steps: 33}\nscenario: {arrangement: across, speeds: [2.8]}\n");
  EXPECT_EQ(c.episode.max_steps, 33);
  EXPECT_EQ(c.episode.control_rate, 100.0);  // the rest of the episode section stays
  EXPECT_EQ(c.scenario.line_crossing.arrangement, sim::LineArrangement::kAcrossMotion);
  EXPECT_EQ(c.scenario.line_speeds, std::vector<double>{2.8});
  EXPECT_EQ(c.scenario.line_crossing.num_obstacles, 5);
  try {
    LoadTaskConfig(TaskConfigPath("line-crossing"), "episode: {max_stepz: 33}");
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("line-crossing.yaml + overrides"), std::string::npos) << msg;
    EXPECT_NE(msg.find("'episode.max_stepz'"), std::string::npos) << msg;
  }
  // a sequence as a key in the overrides is an InputError, not a yaml-cpp exception (found by fuzzing)
  EXPECT_THROW(LoadTaskConfig(TaskConfigPath("line-crossing"), "{[a]: 1}"), InputError);
  EXPECT_THROW(LoadTaskConfig(TaskConfigPath("line-crossing"), "episode: {[a]: 1}"), InputError);
  const TaskConfig p = ParseTaskConfig("task: pretrain-2link\ninterface: direct\n", "inline");
  EXPECT_EQ(p.interface, InterfaceMode::kDirect);
  EXPECT_EQ(p.source, "inline");
  EXPECT_THROW(ParseTaskConfig("task: [", "inline"), InputError);
}

TEST(TaskConfigTest, UnknownKeysNameFileAndKey) {
  std::string msg = LoadError("unknown.yaml", "task: reach-avoid\nepisode: {max_stepz: 3}\n");
  EXPECT_NE(msg.find("unknown.yaml:2"), std::string::npos) << msg;
  EXPECT_NE(msg.find("'episode.max_stepz'"), std::string::npos) << msg;
  EXPECT_NE(msg.find("max_steps"), std::string::npos) << msg;  // lists what is allowed
  msg = LoadError("unknown_root.yaml", "task: reach-avoid\nrobots: panda\n");
  EXPECT_NE(msg.find("'robots'"), std::string::npos) << msg;
  // scenario keys belong to the task: a line-crossing key in a cluttered file is unknown
  msg = LoadError("wrong_scenario.yaml", "task: cluttered\nscenario: {speeds: [1]}\n");
  EXPECT_NE(msg.find("'scenario.speeds'"), std::string::npos) << msg;
}

TEST(TaskConfigTest, BadValuesSayExpectedAndGot) {
  struct Case {
    std::string yaml, key, got;
  };
  const Case cases[] = {
      {"task: reach-avoid\nepisode: {discount: 1.5}\n", "'episode.discount'", "got 1.5"},
      {"task: reach-avoid\nepisode: {max_steps: 0}\n", "'episode.max_steps'", "got 0"},
      {"task: reach-avoid\nepisode: {max_steps: 2.5}\n", "'episode.max_steps'", "got 2.5"},
      {"task: reach-avoid\nepisode: {control_rate: 300}\n", "'episode.control_rate'", "got 300 Hz"},
      {"task: reach-avoid\noptions: {termination: sometimes}\n", "'options.termination'", "got 'sometimes'"},
      {"task: reach-avoid\nepisode: {integrator: rk4}\n", "'episode.integrator'", "got 'rk4'"},
      {"task: reach-avoid\noptions: {gain_range: 0.5}\n", "'options.gain_range'", "got 0.5"},
      {"task: reach-avoid\nobservation: {lookahead: -1}\n", "'observation.lookahead'", "got -1"},
      {"task: reach-avoid\noptions: {target_gain_range: 0.5}\n", "'options.target_gain_range'", "got 0.5"},
      {"task: reach-avoid\noptions: {collision_target_weight: 2}\n", "'options.collision_target_weight'", "got 2"},
      {"task: reach-avoid\noptions: {warnings: some}\n", "'options.warnings'", "got 'some'"},
      {"task: reach-avoid\noptions: {collision_length_exponent: -1}\n", "'options.collision_length_exponent'",
       "got -1"},
      {"task: reach-avoid\noptions: {fixed_option: 3}\n", "'options.fixed_option'", "got 3"},
      {"task: reach-avoid\nscenario: {obstacle_speed: 0.5, obstacle_speed_max: 0.4}\n",
       "'scenario.obstacle_speed_max'", "got 0.4"},
      {"task: reach-avoid\ninterface: joint\n", "'interface'", "got 'joint'"},
      {"task: reach-avoid\nrobot: r2d2\n", "'robot'", "got 'r2d2'"},
      {"task: pretrain-2link\nrobot: panda\n", "'robot'", "got 'panda'"},
      {"task: reach-avoid\nrandomization: {initial_q_spread: 0.5}\n", "'randomization.initial_q_spread'", "got 0.5"},
      {"task: reach-avoid\nrandomization: {link_scale: [1.2, 0.9]}\n", "'randomization.link_scale'", "got [1.2, 0.9]"},
      {"task: reach-avoid\nreward: {reach_release: 0.01}\n", "'reward.reach_release'", "got 0.01"},
      {"task: reach-avoid\nreward: {collision_penalty: .nan}\n", "'reward.collision_penalty'", "finite"},
      {"task: reach-avoid\nscenario: {num_obstacles: 5}\n", "'scenario.num_obstacles'", "got 5"},
      {"task: line-crossing\nscenario: {speeds: [0.6, -1]}\n", "'scenario.speeds[1]'", "got -1"},
      {"task: line-crossing\nobservation: {max_obstacles: 2}\n", "'observation.max_obstacles'", "got 2"},
      {"task: reach-avoid\nrmp: {target_rmp: {accel_norm_eps: -1}}\n", "rmp.target_rmp", "-1"},
      {"task: reach-avoid\nrmp: {resolve: global}\n", "'rmp.resolve'", "got 'global'"},
      {"task: reach-avoid\nrmp: {target_scale: damping}\n", "'rmp.target_scale'", "got 'damping'"},
      {"task: reach-avoid\nepisode: {terminate_on_collision: maybe}\n", "'episode.terminate_on_collision'",
       "got 'maybe'"},
      {"robot: panda\n", "'task'", "missing"},
      {"task: dance\n", "'task'", "unknown task 'dance'"},
  };
  int n = 0;
  for (const Case& c : cases) {
    SCOPED_TRACE(c.yaml);
    const std::string msg = LoadError("bad" + std::to_string(n++) + ".yaml", c.yaml);
    ASSERT_FALSE(msg.empty());
    EXPECT_NE(msg.find(".yaml"), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.key), std::string::npos) << msg;
    EXPECT_NE(msg.find(c.got), std::string::npos) << msg;
    EXPECT_NE(msg.find("expected"), std::string::npos) << msg;
  }
}

TEST(TaskConfigTest, MissingFileIsAnInputError) {
  EXPECT_THROW(LoadTaskConfig("/nonexistent/task.yaml"), InputError);
  EXPECT_THROW(LoadShippedTaskConfig("dance"), InputError);
}

}  // namespace
}  // namespace rmpmarl::tasks
