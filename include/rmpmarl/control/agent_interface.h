#pragma once
/// The agents' side of the manipulator environment (docs/environments.md): action layouts of the three interface
/// modes, the options of the per-joint RMP agents (initiation sets, termination conditions, the composite
/// "target then collision"), the gain mapping, and the names/offsets of the local observation and global state.
#include <cmath>
#include <string>
#include <vector>

#include "rmpmarl/control/action_spec.h"
#include "rmpmarl/control/agent_config.h"

namespace rmpmarl::control {

/// The discrete options of a per-joint RMP agent (paper III.C).
enum class RmpOption {
  kTarget = 0,               ///< the target RMP (eqs 5–7) at the end effector
  kCollision = 1,            ///< the collision RMPs (eqs 8–9) at the witness points of the capsules joint i moves
  kTargetThenCollision = 2,  ///< composite ab: target until an obstacle enters the warning set, then collision
};
inline constexpr int kNumRmpOptions = 3;

/// Offsets inside one per-joint-rmp action: [option, 4 gain parameters, terminate?].
struct RmpActionLayout {
  static constexpr int kOption = 0;
  static constexpr int kTargetAccelScale = 1;     ///< u → s_a of the target RMP
  static constexpr int kTargetMetricScale = 2;    ///< u → s_m of the target RMP (its priority)
  static constexpr int kCollisionAccelScale = 3;  ///< u → s_a of the collision RMPs
  static constexpr int kCollisionMetricScale = 4; ///< u → s_m of the collision RMPs
  static constexpr int kTerminate = 5;            ///< present with OptionTermination::kLearned
  static constexpr int kNumContinuous = 4;
};

/// the number of agents of a mode for a robot with nq joints (1 for direct).
int NumAgents(InterfaceMode mode, int nq);

/// the action layout of one agent.
ActionSpec MakeActionSpec(const AgentConfig& config, int nq);

/// gain/priority scale of a raw parameter: exp(clip(u, −1, 1) · ln gain_range) ∈ [1/gain_range, gain_range].
double GainScale(double u, double gain_range);

/// reads a float option index: the integer it holds (|x − round(x)| ≤ 1e-3) when in [0, num_options), else −1.
int DecodeOptionIndex(float value, int num_options);

/// What an agent's option asks of the basic layer this step.
struct OptionSelection {
  bool started = false;        ///< the action's option index was read (a new option began this step)
  bool use_target = false;     ///< target RMP active
  bool use_collision = false;  ///< collision RMPs active
};

/// The option state machine of one per-joint agent (docs/environments.md, "Options"):
///  - initiation sets: target and composite: every state; collision: W_i ≠ ∅ (an obstacle, the floor or a link that
///    joint i does not move is within the warning distance of a capsule that joint i moves). Chosen outside its
///    initiation set, the collision option is not applicable: the target RMP runs for that one step and the option
///    ends after it.
///  - the composite ab runs phase a (target) until W_i ≠ ∅, then phase b (collision) until W_i = ∅, then ends (if
///    W_i ≠ ∅ when it starts, phase a ends at once).
///  - the collision option ends when W_i = ∅.
///  - every option also ends by `termination`: learned: the termination flag of the step's action; fixed: after
///    `horizon` steps.
/// An ended option leaves the agent idle; the next step's option index starts a new one.
class OptionMachine {
 public:
  OptionMachine(OptionTermination termination = OptionTermination::kLearned, int horizon = 10);
  /// idle (start of an episode).
  void Reset();
  /// starts the step: when idle, `chosen` (in [0, kNumRmpOptions)) starts a new option; `warning` is W_i ≠ ∅ now.
  OptionSelection Begin(int chosen, bool warning);
  /// ends the step: `terminate_flag` is the action's flag (learned mode), `warning_next` is W_i ≠ ∅ after the step.
  /// Returns true when the option ended.
  bool End(bool terminate_flag, bool warning_next);

  bool idle() const { return option_ < 0; }
  /// the running option (−1 idle).
  int option() const { return option_; }
  /// the composite is in phase b (collision).
  bool phase_b() const { return phase_b_; }
  /// steps the running option has run.
  int age() const { return age_; }

 private:
  OptionTermination termination_;
  int horizon_;
  int option_ = -1;
  bool phase_b_ = false;
  bool not_applicable_ = false;
  int age_ = 0;
};

/// Offsets of the per-joint local observation o_i (every vector in joint i's frame J_i; docs/environments.md has the
/// scaling of each feature). The per-joint-rmp mode appends the option block.
struct LocalObs {
  static constexpr int kEeToTarget = 0;        ///< (p_E − p_T)/ℓ, 3
  static constexpr int kLogDistance = 3;       ///< ln(1 + ‖p_E − p_T‖/1 mm)/ln(1001), 1
  static constexpr int kEeVelocity = 4;        ///< (v_E − v_T)/v_s, 3
  static constexpr int kLever = 7;             ///< (p_E − o_i)/ℓ, 3
  static constexpr int kAxis = 10;             ///< joint axis (unit), 3
  static constexpr int kEeJacobian = 13;       ///< ∂p_E/∂q_i / ℓ (= axis × lever for a revolute joint), 3
  static constexpr int kWarningFlag = 16;      ///< 1 when W_i ≠ ∅, 1
  static constexpr int kWarningDirection = 17; ///< unit vector from joint i's witness point to the partner's, 3
  static constexpr int kWarningDistance = 20;  ///< signed distance / warning distance, 1
  static constexpr int kClosingSpeed = 21;     ///< −ḋ / v_s (> 0 approaching), 1
  static constexpr int kWitnessLever = 22;     ///< (p_witness − o_i)/ℓ, 3
  static constexpr int kDistanceGradient = 25; ///< ∂d/∂q_i / ℓ, 1
  static constexpr int kWarningIsSelf = 26;    ///< the partner is another link of the robot, 1
  static constexpr int kJointPosition = 27;    ///< q_i normalised to [−1, 1] (continuous: wrapped angle/π), 1
  static constexpr int kJointSin = 28;         ///< sin q_i, 1
  static constexpr int kJointCos = 29;         ///< cos q_i, 1
  static constexpr int kJointVelocity = 30;    ///< q̇_i / v_max,i, 1
  static constexpr int kJointIndex = 31;       ///< i/(nq − 1) (0 for nq = 1), 1
  static constexpr int kProgress = 32;         ///< step / max_steps, 1
  static constexpr int kBaseSize = 33;
  static constexpr int kOption = 33;           ///< per-joint-rmp: running option one-hot (zeros when idle), 3
  static constexpr int kOptionPhaseB = 36;     ///< per-joint-rmp: composite in phase b, 1
  static constexpr int kOptionAge = 37;        ///< per-joint-rmp: min(age / options.horizon, 1), 1
  static constexpr int kRmpSize = 38;
  /// observation.lookahead T > 0 appends a moving-obstacle look-ahead block after the mode's block (at kBaseSize or
  /// kRmpSize). Of every moving obstacle's straight path over [0, T] against every capsule joint i moves (the arm
  /// held still, the obstacle as its bounding sphere), the pass with the smallest clearance:
  static constexpr int kLookaheadClearance = 0;  ///< predicted clearance / ℓ, clipped to [−1, 2] (2: none), 1
  static constexpr int kLookaheadTime = 1;       ///< time of that closest approach / T, in [0, 1] (1: none), 1
  static constexpr int kLookaheadSpeed = 2;      ///< that obstacle's speed / v_s (0: none), 1
  static constexpr int kLookaheadSize = 3;
};

/// the log-distance feature ln(1 + d/1 mm)/ln(1001) of a distance d [m]: 0 at the target, 0.35 at 1 cm, 1 at 1 m.
inline double LogDistanceFeature(double d) { return std::log1p(d / 0.001) / std::log(1001.0); }

/// names of the local observation features of a per-joint mode (size LocalObs::kBaseSize or kRmpSize, plus
/// kLookaheadSize with the look-ahead block).
std::vector<std::string> PerJointObservationNames(InterfaceMode mode, bool lookahead = false);

/// where the look-ahead block starts in a per-joint mode's local observation (LocalObs::kLookahead… count from here).
constexpr int LookaheadOffset(InterfaceMode mode) {
  return mode == InterfaceMode::kPerJointRmp ? LocalObs::kRmpSize : LocalObs::kBaseSize;
}

/// writes the look-ahead block (LocalObs::kLookahead…, kLookaheadSize floats from `block`): the closest predicted pass
/// at `clearance` [m] in `time` [s] (≤ observation.lookahead) by an obstacle moving at `speed` [m/s], or "none"
/// (2, 1, 0) when `clearance` is not finite. The one encoding of ManipulatorEnv and experiments::ProbeLookahead.
void WriteLookaheadBlock(double clearance, double time, double speed, const ObservationConfig& observation,
                         float* block);

/// Layout of the global state (critic); offsets depend on nq and the obstacle slots M.
struct GlobalStateLayout {
  GlobalStateLayout(InterfaceMode mode, int nq, int max_obstacles);
  int nq = 0;
  int max_obstacles = 0;
  bool has_options = false;
  int joint_position = 0;    ///< nq: normalised q (as LocalObs::kJointPosition)
  int joint_velocity = 0;    ///< nq: q̇ / v_max
  int ee_position = 0;       ///< 3: p_E/ℓ (world)
  int ee_velocity = 0;       ///< 3: v_E/v_s
  int target_position = 0;   ///< 3: p_T/ℓ
  int target_velocity = 0;   ///< 3: v_T/v_s
  int ee_to_target = 0;      ///< 3: (p_E − p_T)/ℓ
  int log_distance = 0;      ///< 1: as LocalObs::kLogDistance
  int joint_warning = 0;     ///< 2 per joint: [W_i ≠ ∅, d_i / warning distance]
  int joint_option = 0;      ///< per-joint-rmp: 4 per joint: option one-hot (3) + phase b
  int obstacles = 0;         ///< M slots of kObstacleSlot: present, p/ℓ (3), v/v_s (3), R columns x, y (6), half size/ℓ (3)
  int robot_reach = 0;       ///< 1: the variant's workspace reach / ℓ
  int progress = 0;          ///< 1: step / max_steps
  int size = 0;
  static constexpr int kObstacleSlot = 16;
  std::vector<std::string> Names() const;
};

/// the names of the env's reward terms: joint_reach, distance, time, collision.
std::vector<std::string> RewardTermNames();

}  // namespace rmpmarl::control
