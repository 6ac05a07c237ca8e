#pragma once
/// Reactive control (docs/control.md): an acceleration policy (q, q̇, scene) ↦ q̈ — RMPflow, the fixed basic layers,
/// or the learned per-joint agents (control::LearnedController) — integrated at the control rate into commanded joint
/// positions and velocities for the robot's position servos. Knows no simulator: a robot program feeds it measured
/// joint states; the MuJoCo world (sim::StepController) is one such program.
///
/// Integration: semi-implicit Euler on the controller's own commanded state (q_cmd, q̇_cmd), in substeps h ≤
/// `max_substep`: q̇_cmd ← clamp(q̇_cmd + h q̈, ±v_max); q_cmd ← clamp(q_cmd + h q̇_cmd, limits) (velocity zeroed at
/// a limit). The commanded state, not the measured one, is integrated because the MuJoCo position servo has no velocity
/// feed-forward: a command q + h q̇ built from the measured state would brake the joint (docs/control.md).
#include <Eigen/Core>
#include <memory>
#include <string>

#include "rmpmarl/control/servos.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::control {

/// A joint-space acceleration policy the ReactiveController drives: the one controller interface of every method
/// (RMPflow, the basic layers, the learned per-joint agents, the RRT replanner).
class AccelerationPolicy {
 public:
  virtual ~AccelerationPolicy();

  /// q̈ for the joint state (q, q̇) in `scene`; q̈ has nq() entries. Should not allocate. Non-finite output is
  /// allowed: the controller catches it, holds position and counts it.
  virtual void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                        const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) = 0;
  /// called by ReactiveController::Reset at the start of every episode with the initial configuration (default:
  /// nothing).
  virtual void Reset(const Eigen::Ref<const Eigen::VectorXd>& q0);
  /// called by ReactiveController::Update once per control step, before the substeps' Evaluate calls, with the
  /// measured state: a policy that decides at the control rate (the learned agents) decides here (default: nothing).
  /// Should not allocate.
  virtual void BeginControlStep(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                                const rmp::Scene& scene);
  /// a short name for logs and results ("rmpflow").
  virtual std::string name() const = 0;
  /// number of joints the policy is built for.
  virtual int nq() const = 0;
};

/// The RMPflow baseline (rmp::RmpflowPolicy) as an AccelerationPolicy.
class RmpflowAccelerationPolicy final : public AccelerationPolicy {
 public:
  /// RMPflow for `robot` with slots for up to `max_obstacles` obstacles. Throws InputError (bad options).
  RmpflowAccelerationPolicy(const kinematics::Robot& robot, const rmp::RmpflowOptions& options, int max_obstacles);
  /// the same with the robot's own parameters: rmp::LoadRmpflowOptions(robot) (configs/rmpflow/<name>.yaml for a
  /// shipped robot, <urdf stem>.rmpflow.yaml beside a user's URDF, else default.yaml).
  RmpflowAccelerationPolicy(const kinematics::Robot& robot, int max_obstacles);

  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override;
  std::string name() const override { return "rmpflow"; }
  int nq() const override;

  rmp::RmpflowPolicy& rmpflow() { return policy_; }
  const rmp::RmpflowPolicy& rmpflow() const { return policy_; }

 private:
  rmp::RmpflowPolicy policy_;
};

/// Which joint state the policy is evaluated at.
enum class PolicyInput {
  /// the controller's integrated state (q_cmd, q̇_cmd) at every substep — RMPflow's ideal-integrator assumption, as in
  /// Lula's RmpFlow (default). The measured state enters through the re-synchronisation (resync_threshold).
  kCommanded,
  /// MuJoCo's measured (q, q̇), once per control step; q̈ is held over the substeps. The servo lag (≈ 2ζ/ω_n = 50 ms)
  /// then sits inside the policy's feedback loop, which stiff RMP damping gains do not tolerate well.
  kMeasured,
};

/// Options of the ReactiveController.
struct ControllerOptions {
  /// control rate [Hz]; the period must be a whole number of physics timesteps (100 Hz = 5 × 2 ms).
  double control_rate = 100.0;
  /// largest internal integration step h [s]; the control period is split into ceil(period / max_substep) equal
  /// substeps. Keeps semi-implicit Euler stable for stiff RMP gains (needs k_d h < 2; RMPflow's joint-limit damper
  /// has k_d = 200 1/s). Lula integrates RMPflow at ≤ 3.34 ms.
  double max_substep = 0.002;
  PolicyInput policy_input = PolicyInput::kCommanded;
  /// v_max,i = velocity_limit_scale × URDF velocity limit of dof i (no clamp where the URDF gives none), > 0.
  double velocity_limit_scale = 1.0;
  /// servo target = q_cmd + (d_i / kp_i) q̇_cmd: with the servo's joint damping d_i this turns τ = kp (q_target − q)
  /// − d q̇ into kp (q_cmd − q) + d (q̇_cmd − q̇), a PD that tracks the commanded velocity too (MuJoCo 2.2.2's
  /// position actuator has no velocity reference). Removes the servo's velocity lag 2ζ/ω_n · q̇ (50 ms).
  bool velocity_feedforward = true;
  /// [rad or m] when max_i |q_cmd,i − q_i| exceeds this at the start of a control step (the arm was pushed, or blocked
  /// by a collision), the commanded state restarts from the measured one. +inf: never. Must exceed the servo's
  /// tracking lag (without feed-forward ≈ 2ζ/ω_n · |q̇| = 0.05 rad at 1 rad/s).
  double resync_threshold = 0.25;
};

/// the substeps per control step of `period` [s]: ceil(period / max_substep), at least 1 (the controller's rule; a
/// policy that keeps its own clock, e.g. the RRT replanner, uses period / ControlSubsteps as its evaluation period).
int ControlSubsteps(double period, const ControllerOptions& options);

/// throws InputError (expected vs got) unless the options are valid for a loop with the given time quantum (0: any).
void ValidateControllerOptions(const ControllerOptions& options, double physics_timestep);

/// Result of one control step.
struct ControlStepResult {
  bool finite = true;         ///< false: the policy returned a non-finite q̈; the command holds position (q̇_cmd = 0)
  bool resynced = false;      ///< the commanded state was restarted from the measured state
  int position_clamps = 0;    ///< substep × dof events where q_cmd was clamped to a joint limit
  int velocity_clamps = 0;    ///< substep × dof events where q̇_cmd was clamped to ±v_max
  double compute_us = 0.0;    ///< wall time of policy evaluation + integration [µs] (steady_clock)
};

/// Counters over the steps since the last Reset.
struct ControllerStats {
  long steps = 0;              ///< control steps
  long nonfinite_outputs = 0;  ///< control steps whose policy output was non-finite
  long resyncs = 0;
  long position_clamps = 0;
  long velocity_clamps = 0;
  double total_compute_us = 0.0;
  double max_compute_us = 0.0;

  /// mean wall time of a control step [µs] (0 before the first step).
  double mean_compute_us() const { return steps > 0 ? total_compute_us / static_cast<double>(steps) : 0.0; }
};

/// Drives an AccelerationPolicy at the control rate: takes the measured q, q̇, evaluates q̈, integrates the commanded
/// state and gives the servo targets. Update() allocates nothing.
class ReactiveController {
 public:
  /// a controller for the joints `servos` describes. Throws InputError for a null policy, a policy of the wrong
  /// size, inconsistent servos, or bad options (ValidateControllerOptions).
  ReactiveController(const ServoSpec& servos, std::unique_ptr<AccelerationPolicy> policy,
                     ControllerOptions options = {});

  /// starts an episode from the measured state (q, q̇): the commanded state becomes it (clamped to the limits), the
  /// counters are zeroed and the policy is reset. Throws InputError unless both have nq finite entries.
  void Reset(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd);

  /// one control step: measured (q, q̇) in, commanded state (q_cmd(), qd_cmd()) and servo_target() out. Throws
  /// InputError unless q, q̇ have nq finite entries.  \pre Reset.
  ControlStepResult Update(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                           const rmp::Scene& scene);

  /// commanded joint positions / velocities after the last step.
  const Eigen::VectorXd& q_cmd() const { return q_cmd_; }
  const Eigen::VectorXd& qd_cmd() const { return qd_cmd_; }
  /// the position-servo target of the last Update: q_cmd + (d/kp) q̇_cmd with velocity_feedforward, else q_cmd.
  const Eigen::VectorXd& servo_target() const { return q_target_; }
  /// the commanded acceleration of the last Update: (q̇_cmd after it − q̇_cmd at its start) / control_period(), the
  /// commanded state's mean acceleration over the period (clamps included; 0 after Reset and when a non-finite q̈
  /// holds the position) — what a servo with an inverse-dynamics feed-forward adds to its target
  /// (sim::ServoOptions::inverse_dynamics_feedforward).
  const Eigen::VectorXd& qdd_cmd() const { return qdd_cmd_; }
  /// the policy's last q̈ (as returned, possibly non-finite).
  const Eigen::VectorXd& qdd() const { return qdd_; }

  int nq() const { return static_cast<int>(q_cmd_.size()); }
  const ControllerOptions& options() const { return options_; }
  AccelerationPolicy& policy() { return *policy_; }
  const AccelerationPolicy& policy() const { return *policy_; }
  const ControllerStats& stats() const { return stats_; }
  /// control period [s]: physics_steps_per_control() × the servos' timestep (1 / control_rate without one).
  double control_period() const { return period_; }
  /// the servos' timesteps per control step (1 without a timestep).
  int physics_steps_per_control() const { return physics_steps_; }
  /// substeps per control step and their length h [s].
  int substeps() const { return substeps_; }
  double substep() const { return period_ / substeps_; }
  /// per-dof velocity clamp v_max (+inf where none) and position limits (±inf for continuous joints).
  const Eigen::VectorXd& velocity_limits() const { return v_max_; }
  const Eigen::VectorXd& lower_limits() const { return lower_; }
  const Eigen::VectorXd& upper_limits() const { return upper_; }

 private:
  // throws InputError unless q and q̇ have nq finite entries; `where` names the caller ("Update").
  void CheckMeasuredState(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                          const char* where) const;
  // one semi-implicit Euler substep of length h with acceleration qdd_; counts clamps into `result`.
  void Integrate(double h, ControlStepResult* result);

  std::unique_ptr<AccelerationPolicy> policy_;
  ControllerOptions options_;
  double period_ = 0.0;
  int physics_steps_ = 1;
  int substeps_ = 1;
  Eigen::VectorXd lower_, upper_, v_max_;
  Eigen::VectorXd feedforward_;  // d_i / kp_i, or 0
  Eigen::VectorXd q_cmd_, qd_cmd_, qdd_, q_target_, qdd_cmd_;
  ControllerStats stats_;
};

}  // namespace rmpmarl::control
