#pragma once
/// The configuration of the agents a controller file carries (docs/environments.md): how they act (interface,
/// options), what they see (observation), the basic layer under them, the ReactiveController that integrates it and
/// the episodes' horizon and clock they were trained on. These are the controller sections of a task config
/// (tasks::TaskConfig adds the scene, reward and randomisation of training); ParseAgentConfig reads them from a
/// controller file's task YAML without the rest of the task.
#include <cmath>
#include <limits>
#include <string>
#include <string_view>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/rmp/joint_layer.h"

namespace rmpmarl::control {

/// How the agents act (the three learners of the paper's comparison).
enum class InterfaceMode {
  kPerJointRmp,     ///< `per-joint-rmp`: one agent per joint choosing an RMP option + gain/priority scales (MARL-RMP)
  kDirect,          ///< `direct`: one agent commanding every Δq_i, no RMPs (the PPO baseline)
  kPerJointDirect,  ///< `per-joint-direct`: one agent per joint commanding its own Δq_i, no RMPs (MARL-PPO)
};

/// How a running option ends (besides its built-in conditions, docs/environments.md).
enum class OptionTermination {
  kLearned,  ///< the action's termination flag (≥ 0.5) ends the option after the step
  kFixed,    ///< the option runs exactly `horizon` steps (no termination flag in the action)
};

/// "per-joint-rmp", "direct", "per-joint-direct".
std::string_view InterfaceModeName(InterfaceMode mode);
/// the interface called `name`; throws InputError "interface: expected per-joint-rmp, direct or per-joint-direct,
/// got '<name>'".
InterfaceMode ParseInterfaceMode(std::string_view name);
/// "learned", "fixed".
std::string_view OptionTerminationName(OptionTermination termination);

/// The horizon and clock of the episodes the agents were trained on.
struct AgentEpisode {
  int max_steps = 500;              ///< truncation horizon [env steps], ≥ 1 (the agents' progress feature)
  double control_rate = 100.0;      ///< env steps per simulated second [Hz]; period = whole physics timesteps
  double physics_timestep = 0.002;  ///< the simulator's timestep [s] of training
};

/// Which warning contacts make up W_i, the warning set of the options' initiation and termination.
enum class OptionWarnings {
  /// obstacles within the warning distance of a capsule joint i moves: what the collision RMPs act on (default)
  kObstacles,
  /// every warning contact, the floor and the robot's own links included (the first implementation: self-contacts
  /// within 15 cm warned 78 % of Panda agent-steps without any obstacle, and the collision option then coasted)
  kAll,
};

/// The per-joint-rmp action (options, docs/environments.md).
struct OptionConfig {
  OptionTermination termination = OptionTermination::kLearned;
  /// fixed: the option length [steps]; learned: only the normaliser of the `option_age` observation. ≥ 1.
  int horizon = 10;
  /// scale = exp(clip(u, −1, 1) · ln gain_range) for every gain/priority parameter u, so scale ∈ [1/g, g]. ≥ 1.
  double gain_range = 4.0;
  /// the gain range of the target RMP's two scales (accel, metric) alone; 0: `gain_range`. 1: the target RMP keeps
  /// unit scales whatever the action (the agents modulate the collision RMPs only, so an arm with no obstacle near
  /// tracks exactly as the unscaled layer does). 0 or in [1, 1e6].
  double target_gain_range = 0.0;
  /// the gain range the target RMP's scales use: target_gain_range, or gain_range when it is 0
  double TargetGainRange() const { return target_gain_range > 0.0 ? target_gain_range : gain_range; }
  /// priority of the target RMP while the collision RMPs run (collision option, composite phase b): the target RMP
  /// stays active with its metric × this weight, so it only prevails where the collision RMPs' metric has faded
  /// (obstacle receding or beyond the warning distance) and an arm inside the warning band returns to tracking
  /// instead of stalling. 0: the collision RMPs alone. In [0, 1].
  double collision_target_weight = 1e-4;
  /// e: the collision RMPs' acceleration length scales l_p, l_d (eq 8) are multiplied by s_a^e, where s_a is the
  /// agent's collision accel scale, so one learned parameter sets how strongly AND how far ahead the arm evades
  /// (0: gains only, the length scales stay as configured). In [0, 4].
  double collision_length_exponent = 0.0;
  /// ≥ 0: every joint always runs this option (0 target, 1 collision, 2 target-then-collision) and the action's option
  /// index is ignored — the agents learn the RMP parameters only (an ablation of the option layer); −1: learned.
  int fixed_option = -1;
  /// how often a joint reads the RMP parameters (the action's continuous part): at the start of an option, when the
  /// joint's warning set W_i empties or fills, and every `parameter_period` steps; held in between (temporally
  /// consistent exploration; the learner counts their log-probability only where read,
  /// StepOutput::parameters_read). 1: every step (the paper). In [1, 1000].
  int parameter_period = 1;
  OptionWarnings warnings = OptionWarnings::kObstacles;
  /// A hand prior under the learned target accel scale (residual learning over the hand threat gate,
  /// docs/method.md): joint i's target accel parameter is u_agent + target_gate_clear while no moving obstacle is
  /// predicted by the look-ahead block (observation.lookahead) to pass within target_gate_clearance [m] of a capsule
  /// joint i moves, and u_agent + target_gate_threat while one is; the sum is clipped to [−1, 1]. The prior is read
  /// every step, the agent's part as options.parameter_period says. With u_agent = 0 the layer is the hand gate
  /// experiments::Method::ThreatGate for clearances in (−ℓ, 2ℓ] (ℓ = observation.length_scale), where the gate's clipped
  /// feature and the metres compared here agree.
  /// −inf: off (the agent's u alone). Needs observation.lookahead > 0 and the per-joint-rmp interface.
  double target_gate_clearance = -std::numeric_limits<double>::infinity();
  double target_gate_clear = 0.0;   ///< the prior's u with no pass predicted, in [−1, 1]
  double target_gate_threat = 0.0;  ///< the prior's u while a pass is predicted, in [−1, 1]
  /// The same gate's prior under the learned collision accel parameter (which also sets the collision RMPs' length
  /// scales, options.collision_length_exponent): u_agent + collision_gate_clear while no pass is predicted within
  /// target_gate_clearance, u_agent + collision_gate_threat while one is, clipped to [−1, 1]. With the v2 gains and
  /// exponent 0.75, u = −1 is RMPflow's collision RMP (gain and reach ÷ 4 and ÷ 2.83): gentle near the walls of a
  /// cell, the v2 gains only for an obstacle about to pass. Both 0: no prior (the target gate alone).
  double collision_gate_clear = 0.0;
  double collision_gate_threat = 0.0;
  /// true: the agents' four parameters count only while the gate predicts a pass within target_gate_clearance of a
  /// capsule the joint moves; otherwise joint i's layer runs on the priors alone (the hand gates): the learned
  /// residual acts where an obstacle is about to pass, and a static cell is left to the layer. Needs the gate and a
  /// fixed option (options.fixed_option ≥ 0).
  bool agents_under_threat_only = false;
  bool TargetGated() const { return std::isfinite(target_gate_clearance); }
};

/// The direct and per-joint-direct actions: Δq_i = clip(u_i, −1, 1) · max_speed_fraction · v_max,i · T.
struct DirectConfig {
  double max_speed_fraction = 1.0;  ///< (0, 1]
};

/// Observation scaling (every feature O(1), docs/environments.md).
struct ObservationConfig {
  double length_scale = 0.5;      ///< ℓ [m]: positions and levers are divided by it
  double speed_scale = 1.0;       ///< v_s [m/s]: linear velocities are divided by it
  double warning_distance = 0.15; ///< [m] the sensing margin of the World (paper: 15 cm warning distance)
  int max_obstacles = 4;          ///< obstacle slots of the global state (≥ the scenario's obstacle count)
  /// [s] horizon T of the moving-obstacle look-ahead block of every local observation (LocalObs::kLookahead…);
  /// 0: off (the block is absent and the local observation keeps its paper size)
  double lookahead = 0.0;
};

/// The basic movement layer (paper RMPs, eqs 5–9) under the agents.
struct BasicLayerConfig {
  rmp::BasicRmpParams params;          ///< target_rmp, collision_rmp (defaults: see DefaultTaskConfig)
  double relative_regularizer = 1e-6;  ///< λ rule of EvaluateJointLayer, > 0
  /// `resolve`: per-joint (the paper) or coupled (one resolve of every joint's RMPs on top of the robot's RMPflow
  /// C-space, joint-limit and self-collision leaves, configs/rmpflow; rmp::EvaluateCoupledLayer)
  rmp::LayerResolve resolve = rmp::LayerResolve::kPerJoint;
};

/// The controller sections of a task: everything a LearnedController is built from besides its robot and actor.
struct AgentConfig {
  InterfaceMode interface = InterfaceMode::kPerJointRmp;
  AgentEpisode episode;
  ControllerOptions controller;  ///< control_rate is taken from episode.control_rate
  OptionConfig options;
  DirectConfig direct;
  ObservationConfig observation;
  BasicLayerConfig basic_layer;
};

/// the agents' defaults of a task (`task`: pretrain-2link, reach-avoid, line-crossing, cluttered or cells): the episode
/// horizon and the obstacle slots differ per task. Throws InputError naming the known tasks.
AgentConfig DefaultAgentConfig(std::string_view task);
/// reads the controller sections of a task config's YAML text (`task:` picks the defaults; interface, episode's
/// max_steps, control_rate and physics_timestep, controller, options, direct, observation, rmp); the task's other
/// sections are left to its own reader (tasks::ParseTaskConfig). Throws InputError naming `source` and the key for
/// unknown keys in these sections, wrong types and out-of-range values.
AgentConfig ParseAgentConfig(const std::string& yaml_text, const std::string& source);
/// throws InputError naming `where` and the key unless every value is in range.
void ValidateAgentConfig(const AgentConfig& config, std::string_view where);

}  // namespace rmpmarl::control
