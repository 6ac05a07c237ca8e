#pragma once
/// The learned per-joint agents as a controller for a user's own loop (docs/control-your-robot.md): joint state,
/// end-effector target and obstacles in (AccelerationPolicy's q, q̇ and rmp::Scene), joint accelerations out —
/// the same interface as RMPflow. The agents build their observations themselves from that state and scene, so they
/// run on any robot the project can load:
///
///   const PolicyFile file = LoadPolicyFile("models/policies/marl-rmp-residual.rmpp");
///   const kinematics::Robot robot = kinematics::LoadShippedRobot("ur5e");
///   auto learned = MakeLearnedController(robot, file, "marl-rmp-residual.rmpp", /*max_obstacles=*/4);
///   const ControllerOptions options = learned->controller_options();
///   ReactiveController controller(world_model, std::move(learned), options);
///   controller.Update(q, qd, scene);  // every control period: q_cmd(), qd_cmd() out
///
/// Decisions are taken at the control rate on the measured state (BeginControlStep, called by the
/// ReactiveController), the basic layer is evaluated at every integration substep (Evaluate). The warning contacts
/// the observations need are computed from the robot's capsules and the scene's obstacles (and a floor plane when
/// set), the geometry MuJoCo's narrow phase evaluates in ManipulatorEnv. Nothing is allocated per step.
#include <Eigen/Core>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/joint_agents.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/control/agent_config.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/control/warning.h"

namespace rmpmarl::control {

/// Options of a LearnedController.
struct LearnedControllerOptions {
  /// [m] height of a floor plane z = floor_height whose distance to the capsules of moving links enters the warning
  /// features; NaN (default): no floor, as in the tasks' worlds the shipped agents were trained in.
  double floor_height = std::numeric_limits<double>::quiet_NaN();
  /// the most obstacles a scene may hold (buffers are sized for them); more throw InputError.
  int max_obstacles = 16;
  /// a name for logs ("marl-rmp-residual").
  std::string name = "learned";
};

/// The learned per-joint agents (per-joint-rmp interface) over their basic layer, as an AccelerationPolicy.
class LearnedController final : public AccelerationPolicy {
 public:
  /// agents of `config` (the controller file's task: interface, observation, options, basic layer, controller) with
  /// the actor `weights`, on `robot`. Throws InputError when the interface is not per-joint-rmp or the actor does not
  /// take this config's observation or give its actions (message: expected vs got).
  LearnedController(const kinematics::Robot& robot, const AgentConfig& config, const PolicyWeights& weights,
                    LearnedControllerOptions options = {});
  ~LearnedController() override;

  void Reset(const Eigen::Ref<const Eigen::VectorXd>& q0) override;
  /// senses (q, q̇, scene), ends the last step's options, observes, acts and sets the basic layer's weights. A scene
  /// without a target holds the end effector where it was at the first step without one (for the agents and the
  /// layer) until a target is given again.
  void BeginControlStep(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                        const rmp::Scene& scene) override;
  /// the basic layer's q̈ with the weights of the current control step. \pre BeginControlStep.
  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const rmp::Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) override;
  std::string name() const override { return options_.name; }
  int nq() const override;

  /// the ReactiveController options the agents were trained with (the file's task: substep, velocity limits,
  /// resynchronisation, control rate). Drive the controller with these.
  ControllerOptions controller_options() const;
  /// the agents (their observations, options, warnings) after the last control step.
  const JointAgents& agents() const { return agents_; }
  /// the local observations of the last control step (nq × obs_dim, row-major) and the actions: each agent's row is
  /// that of the last step that read its action (the network runs for an agent only then, JointAgents::ReadsAction),
  /// so rows may come from different steps.
  const std::vector<float>& observations() const { return obs_; }
  const std::vector<float>& actions() const { return actions_; }
  /// per agent, 1 where the last control step read its action (and ran the network for it), else 0.
  const std::vector<float>& actions_read() const { return reads_; }
  /// control steps since Reset, saturated at the task's episode length (the agents' progress feature reads 1 from
  /// there on: a controller running longer than the episodes it was trained on sees the end of an episode).
  int steps() const { return steps_; }
  /// the warning contacts of the last control step (computed from the geometry).
  std::span<const WarningContact> warnings() const { return warnings_.contacts(); }

 private:
  LearnedControllerOptions options_;
  const kinematics::Robot& robot_;
  JointAgents agents_;
  std::unique_ptr<AccelerationPolicy> layer_;
  PolicyRuntime runtime_;
  int obs_dim_ = 0;
  int action_size_ = 0;
  int steps_ = 0;
  bool started_ = false;
  std::vector<float> obs_, actions_;
  std::vector<float> reads_;  // per agent: 1 where this step's Apply reads its action (JointAgents::ReadsAction)
  WarningSensor warnings_;
  // a scene without a target: the end effector is held where it was at the first such step
  bool holding_ = false;
  Eigen::Vector3d p_hold_ = Eigen::Vector3d::Zero();
  rmp::Scene hold_scene_;  // the scene with the held target, for the layer (obstacles reserved at construction)
};

/// the controller of a controller file on `robot`: its task's layer and observation, its actor. Throws InputError
/// naming `path` when the file carries no task or does not fit.
std::unique_ptr<LearnedController> MakeLearnedController(const kinematics::Robot& robot, const PolicyFile& file,
                                                         const std::string& path,
                                                         LearnedControllerOptions options = {});
/// the same with room for `max_obstacles` obstacles and the other options' defaults.
std::unique_ptr<LearnedController> MakeLearnedController(const kinematics::Robot& robot, const PolicyFile& file,
                                                         const std::string& path, int max_obstacles);

}  // namespace rmpmarl::control
