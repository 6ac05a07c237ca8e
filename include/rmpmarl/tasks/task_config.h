#pragma once
/// The configuration of a manipulator task (docs/environments.md): ONE environment parameterised by robot, scenario
/// and agent interface; the paper's four tasks are configurations of it, shipped as configs/tasks/<task>.yaml.
/// DefaultTaskConfig(task) equals the shipped file (checked by a test); LoadTaskConfig starts from those defaults,
/// applies the keys present and rejects unknown keys and out-of-range values with an InputError naming file and key.
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <string_view>
#include <vector>

#include "rmpmarl/control/agent_config.h"
#include "rmpmarl/rmp/joint_layer.h"
#include "rmpmarl/sim/episode_metrics.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::tasks {

// the controller sections of a task (control/agent_config.h)
using control::AgentConfig;
using control::BasicLayerConfig;
using control::DirectConfig;
using control::InterfaceMode;
using control::InterfaceModeName;
using control::ObservationConfig;
using control::OptionConfig;
using control::OptionTermination;
using control::OptionTerminationName;
using control::OptionWarnings;
using control::ParseInterfaceMode;

/// Which scenario moves target and obstacles.
enum class TaskKind {
  kPretrain2Link,  ///< `pretrain-2link`: planar2, target in linear motion, one obstacle beside (or on) the target's path (IV.A)
  kReachAvoid,     ///< `reach-avoid`: moving target, up to four crossing cubes (IV.B; sim::CrossingScenario)
  kLineCrossing,   ///< `line-crossing`: a line of cubes crossing at speed v, stop on impact (IV.C, Table 4)
  kCluttered,      ///< `cluttered`: static cubes 20–50 cm around the start end effector (IV.C)
  kCells,          ///< `cells`: a generated shelf, box, table or under-table cell around a static target (sim::CellsScenario)
};

/// When the scenario moves obstacles and target inside one env step (the episode loop's choice).
using ScenarioUpdate = sim::ScenarioUpdate;

/// "pretrain-2link", "reach-avoid", "line-crossing", "cluttered", "cells".
std::string_view TaskKindName(TaskKind kind);
/// the registered scene a task runs (sim::MakeScenario): pretrain-2link, crossing (reach-avoid), line-crossing,
/// cluttered, cells.
std::string_view TaskSceneName(TaskKind kind);
/// the task whose scene is `scene`; throws InputError naming the scenes that have a task.
TaskKind TaskOfScene(std::string_view scene);
/// whether `scene` is the scene of an arm task (crossing, line-crossing, cluttered, cells): where the learned controllers run.
bool IsArmTaskScene(std::string_view scene);

/// Episode timing and ending: the agents' horizon and clock (control::AgentEpisode) and how training runs them.
struct EpisodeConfig : control::AgentEpisode {
  /// MuJoCo integrator. Euler (joint damping implicit) tracks the servos like `implicit` (after a 0.3 rad step on
  /// every shipped arm: errors at 0.4 s within 3e-4 rad, peak speeds within 1 %) at half the cost per physics step
  /// (docs/environments.md, "Cost").
  sim::Integrator integrator = sim::Integrator::kEuler;
  bool terminate_on_collision = false;  ///< end the episode at the first collision event
  double discount = 0.99;               ///< γ, in (0, 1]
  ScenarioUpdate scenario_update = ScenarioUpdate::kPhysicsStep;
  /// success also needs the final tracking error below this [m] (+inf: success = no collision, not invalid).
  double success_max_final_error = std::numeric_limits<double>::infinity();
};

/// Reward of eq (14): r = Σ δ_i R_i + γ_d R_d + R_t − φ (every term logged separately).
struct RewardConfig {
  std::vector<double> joint_reach_weights = {1.0};  ///< δ_i: one value (every joint) or one per joint, ≥ 0
  double joint_reach_tolerance = 1e-4;  ///< η [m]: R_i = 1 needs the sub-target residual to shrink by more
  double distance_weight = 1.0;         ///< γ_d ≥ 0 (0 disables R_d)
  double distance_unit = 0.001;         ///< R_d = (d_prev − d)/unit: one point per 0.1 cm [m], > 0
  double time_reward = 25.0;            ///< R_t when a reach cycle is shorter than the previous one, ≥ 0
  double reach_tolerance = 0.02;        ///< a reach cycle ends when d ≤ this [m], > 0
  double reach_release = 0.04;          ///< a new cycle starts when d > this after a reach [m], > reach_tolerance
  double collision_penalty = 75.0;      ///< φ per collision event, ≥ 0
  /// a dense precision term beside eq (14)'s: − this × d per step, d the end-effector–target distance [m];
  /// logged with R_d in the `distance` term. ≥ 0 (0: eq 14 alone)
  double tracking_weight = 0.0;
  /// a bounded dense precision term: + precision_weight × exp(−d / precision_length) per step, in
  /// [0, precision_weight]; it saturates away from the target, so an arm dodging far from it loses nothing more
  /// while one close to it is paid for every millimetre. Logged in the `distance` term. ≥ 0 (0: off)
  double precision_weight = 0.0;
  double precision_length = 0.02;  ///< δ [m] of the kernel, > 0
  /// the kernel is paid only on steps where every moving obstacle's predicted pass (the look-ahead block,
  /// observation.lookahead > 0) clears every capsule a joint moves by more than this [m]. −inf (default): every step.
  /// Precision is then asked for where no evasion is due, and never traded against one.
  double precision_pass_clearance = -std::numeric_limits<double>::infinity();
};

/// Planar two-link arm parameters (robot: planar2).
struct Planar2Config {
  std::array<double, 2> link1_length = {0.5, 0.5};  ///< [min, max] for domain randomisation [m]
  std::array<double, 2> link2_length = {0.5, 0.5};
  double link_radius = 0.04;
  double joint_limit = 3.0;
  double velocity_limit = 3.0;
};

/// Domain randomisation (paper III.F, Table 2), drawn per reset.
struct RandomizationConfig {
  /// K robot variants built once per TaskContext (one WorldModel each); one is picked per reset. ≥ 1.
  int variants = 1;
  bool include_nominal = true;          ///< variant 0 is the unscaled robot
  std::uint64_t seed = 0;               ///< seed of the variant draw (fixed per task, not per env)
  /// URDF arms: uniform geometric scale of every joint offset, capsule (end points and radius) and the end-effector
  /// offset, drawn in [min, max] per variant. planar2 draws its two link lengths instead (Planar2Config).
  std::array<double, 2> link_scale = {1.0, 1.0};
  /// pre-training only: q0 = clamp(U(−spread, spread) around the start posture) [rad] (pretrain-2link only)
  double initial_q_spread = 0.0;
  /// pre-training: q̇0,i = U(−f, f) · v_max,i, f in [0, 1]
  double initial_qd_fraction = 0.0;
};

using PretrainScenarioOptions = sim::PretrainScenarioOptions;

/// Scenario parameters: the scene options of every scene (only the task's own scene is read, TaskSceneName) and
/// the line-crossing task's speeds.
struct ScenarioConfig : sim::SceneOptions {
  /// line-crossing: the line's speed is drawn per episode from this list [m/s] (the paper sweeps 0.2 … 2.8); the
  /// scene options' own line_crossing.speed is ignored
  std::vector<double> line_speeds = {0.2, 0.6, 1.2, 1.8, 2.8};
};

/// A whole task.
struct TaskConfig {
  std::string source = "<defaults>";  ///< file it was loaded from (error messages)
  TaskKind task = TaskKind::kReachAvoid;
  std::string robot = "panda";        ///< "planar2", a shipped arm (kinematics::ShippedRobotNames) or a path to a .urdf
  /// a .urdf robot's collision YAML; "" (default): <stem>.collision.yaml or collision.yaml beside the URDF, else
  /// capsules fitted in memory (setup::LoadOrFitRobot)
  std::string collision;
  InterfaceMode interface = InterfaceMode::kPerJointRmp;
  EpisodeConfig episode;
  control::ControllerOptions controller;  ///< control_rate is taken from episode.control_rate
  OptionConfig options;
  DirectConfig direct;
  ObservationConfig observation;
  RewardConfig reward;
  RandomizationConfig randomization;
  Planar2Config planar2;
  ScenarioConfig scenario;
  BasicLayerConfig basic_layer;
};

/// the controller sections of `config` (what its agents are built from).
control::AgentConfig AgentConfigOf(const TaskConfig& config);
/// sets the controller sections of `config` to `agent`.
void SetAgentConfig(TaskConfig& config, const control::AgentConfig& agent);

/// the task names in order: pretrain-2link, reach-avoid, line-crossing, cluttered, cells.
std::vector<std::string> TaskNames();
/// the task called `name`; throws InputError listing the known names.
TaskKind ParseTaskKind(std::string_view name);
/// the defaults of a task (equal to configs/tasks/<task>.yaml).
TaskConfig DefaultTaskConfig(TaskKind task);
/// configs/tasks/ (beside the models directory, like configs/rmpflow/).
std::filesystem::path TaskConfigDirectory();
/// configs/tasks/<name>.yaml.
std::filesystem::path TaskConfigPath(std::string_view name);
/// loads a task file: `task:` picks the defaults, the other keys override them. Throws InputError naming the file
/// and key for unknown keys, wrong types, non-finite or out-of-range values.
TaskConfig LoadTaskConfig(const std::filesystem::path& path);
/// the same with `overrides_yaml` (a YAML mapping, e.g. from a training config) merged over the file's keys first
/// (mappings merge recursively, anything else replaces); messages name "<path> + overrides".
TaskConfig LoadTaskConfig(const std::filesystem::path& path, const std::string& overrides_yaml);
/// parses a task config from YAML text; `source` names it in messages.
TaskConfig ParseTaskConfig(const std::string& yaml_text, const std::string& source);
/// reads the keys of `overrides_yaml` (a YAML mapping of task config keys, e.g. a basic-layer variant) onto
/// `config`; keys it lacks keep their values. `task`, when given, must name config's task. Throws InputError naming
/// `source` and the key; `config` is unchanged then.
void ApplyTaskOverrides(TaskConfig& config, const std::string& overrides_yaml, const std::string& source);
/// the shipped config of a task: LoadTaskConfig(TaskConfigPath(name)).
TaskConfig LoadShippedTaskConfig(std::string_view name);
/// throws InputError naming `where` (a file) and the key unless every value is in range (called by the loader and
/// by TaskContext for configs built in code).
/// true when a task's `robot` names a user's URDF file (ends in ".urdf") rather than a shipped robot: the task then
/// loads it with its collision YAML beside it, else capsules fitted in memory (setup::LoadOrFitRobot).
bool IsUrdfPath(const std::string& robot);

void ValidateTaskConfig(const TaskConfig& config, std::string_view where);

}  // namespace rmpmarl::tasks
