#pragma once
/// The per-joint agents' side of the manipulator task (docs/environments.md), shared by ManipulatorEnv (training,
/// evaluation) and LearnedController (a user's own control loop): what each joint senses (its nearest warning
/// contact, the look-ahead of moving obstacles), its local observation, and — in the per-joint-rmp interface — its
/// option machine, held RMP parameters, the hand prior and the basic layer the actions set. Sized at construction;
/// Sense, WriteLocal, Apply and End allocate nothing.
#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <span>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/control/agent_config.h"
#include "rmpmarl/rmp/joint_layer.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/control/warning.h"

namespace rmpmarl::control {

/// The nearest warning contact of joint i (W_i): among the robot contacts within the warning distance whose robot
/// capsule joint i moves while the partner (obstacle, floor, or a link) is not moved by it.
struct JointWarning {
  bool present = false;
  double distance = std::numeric_limits<double>::infinity();  ///< signed [m]
  int link = -1;                                   ///< the link joint i moves
  Eigen::Vector3d p_W1 = Eigen::Vector3d::Zero();  ///< witness point on that link's capsule
  Eigen::Vector3d p_W2 = Eigen::Vector3d::Zero();  ///< witness point on the partner
  Eigen::Vector3d n_W = Eigen::Vector3d::Zero();   ///< unit normal from partner to robot
  PartnerKind partner = PartnerKind::kObstacle;
  int partner_index = -1;                          ///< obstacle or link index
  double closing_speed = 0.0;                      ///< −ḋ [m/s]
  double gradient = 0.0;                           ///< ∂d/∂q_i [m/rad or m/m]
};

/// The closest predicted pass of a moving obstacle by the capsules joint i moves (LocalObs::kLookahead…).
struct JointLookahead {
  /// [m] capsule surface to the obstacle's bounding sphere at the closest approach (+inf: none)
  double clearance = std::numeric_limits<double>::infinity();
  double time = 0.0;       ///< [s] when, in [0, T]
  double speed = 0.0;      ///< [m/s] that obstacle's speed
};

/// The per-joint agents of one task config on one robot.
class JointAgents {
 public:
  /// `config` is copied; `robot` must outlive the agents (or be replaced by set_robot). One agent per joint of
  /// `robot`, whatever the config was trained on (the agents share their parameters).
  JointAgents(const AgentConfig& config, const kinematics::Robot* robot);
  ~JointAgents();
  JointAgents(const JointAgents&) = delete;
  JointAgents& operator=(const JointAgents&) = delete;

  /// switches to another link-length variant of the same robot (same joints).
  void set_robot(const kinematics::Robot* robot);
  const kinematics::Robot& robot() const { return *robot_; }
  const AgentConfig& config() const { return config_; }
  int nq() const { return nq_; }

  /// starts an episode: every option idle, every joint reads its parameters at the next Apply.
  void Reset();
  /// what the joints sense in state (q, q̇): kinematics, the end effector against the target (p_WT, v_WT), each
  /// joint's nearest warning among `warnings` (contacts within the warning distance; obstacle indices are those of
  /// `scene`, whose velocities give the closing speeds) and, with observation.lookahead > 0, the look-ahead of the
  /// moving obstacles of `scene`.
  void Sense(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
             const Eigen::Vector3d& p_WT, const Eigen::Vector3d& v_WT, std::span<const WarningContact> warnings,
             const rmp::Scene& scene);
  /// the first half of Sense: kinematics and the end effector against the target (the capsules' poses are then
  /// kinematics().X_WL, for a caller that computes the warning contacts itself).
  void SenseState(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                  const Eigen::Vector3d& p_WT, const Eigen::Vector3d& v_WT);
  /// the same from the kinematics of (q, q̇) a caller has computed already (kinematics::CalcVelocityKinematics on
  /// this robot's model).
  void SenseState(const kinematics::Data& kin, const Eigen::Ref<const Eigen::VectorXd>& q,
                  const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::Vector3d& p_WT,
                  const Eigen::Vector3d& v_WT);
  /// the second half: the joints' nearest warnings and the look-ahead. \pre SenseState.
  void SenseContacts(std::span<const WarningContact> warnings, const rmp::Scene& scene);
  /// joint i's local observation after Sense, at env step `step` (the progress feature: step / episode.max_steps,
  /// at most 1). \pre Sense.
  void WriteLocal(int i, int step, float* o) const;
  /// per-joint-rmp: reads the actions (nq × action size floats) into the option machines, held parameters and the
  /// basic layer's weights. `option_started` / `parameters_read` (nq each, may be null) flag what was read.
  void Apply(const float* actions, float* option_started, float* parameters_read);
  /// per-joint-rmp: ends the step — options end by their termination flag or the warnings sensed since Apply.
  void End();
  /// per-joint-rmp: whether the next Apply reads some part of joint i's action — its termination flag (learned
  /// termination), its option index and parameters (an option starts), or its parameters (options.parameter_period
  /// elapsed, or the warning set emptied or filled). false: Apply ignores the action, so an actor need not compute
  /// it. Valid after End (or Reset) and the Sense that precedes the next Apply.
  bool ReadsAction(int i) const;
  /// every joint's predicted pass clears the arm by more than `clearance` [m] (−inf: always true).
  bool PassesClear(double clearance) const;

  /// per-joint-rmp: the basic layer (its weights set by Apply) as an acceleration policy for a ReactiveController;
  /// it refers to the agents' layer, so the agents must outlive it. \pre per-joint-rmp.
  std::unique_ptr<AccelerationPolicy> MakeLayerPolicy();

  const kinematics::Data& kinematics() const { return kin_; }
  const Eigen::Vector3d& p_WE() const { return p_WE_; }
  const Eigen::Vector3d& v_WE() const { return v_WE_; }
  const Eigen::Vector3d& p_WT() const { return p_WT_; }
  const Eigen::Vector3d& v_WT() const { return v_WT_; }
  const Eigen::Matrix3Xd& J_WE() const { return J_WE_; }
  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& qd() const { return qd_; }
  const JointWarning& warning(int i) const { return warnings_[i]; }
  const JointLookahead& lookahead(int i) const { return lookahead_[i]; }
  const OptionMachine& option_machine(int i) const { return options_[i]; }
  /// per-joint-rmp: the basic-layer weights joint i's action set at the last Apply (gain scales s_a, s_m of the
  /// target and collision RMPs, after the hand gate). \pre per-joint-rmp.
  const rmp::JointLayerWeights& layer_weights(int i) const;
  /// v_max,i: the URDF velocity limit (1 where none) × controller.velocity_limit_scale.
  const Eigen::VectorXd& velocity_limits() const { return v_max_; }

 private:
  class Layer;
  void UpdateLookahead(const rmp::Scene& scene);
  // SenseState's end-effector part, on kin_
  void SenseEndEffector(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                        const Eigen::Vector3d& p_WT, const Eigen::Vector3d& v_WT);
  /// Apply reads joint i's parameters even if no option starts: every step (parameter_period 1), at the episode's
  /// first step, when the period elapsed, or when the warning set emptied or filled since the last read
  bool ParametersDue(int i) const;

  AgentConfig config_;
  ActionSpec action_;
  const kinematics::Robot* robot_;
  int nq_;
  kinematics::Data kin_;
  Eigen::VectorXd q_, qd_, v_max_;
  Eigen::Vector3d p_WE_ = Eigen::Vector3d::Zero(), v_WE_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_WT_ = Eigen::Vector3d::Zero(), v_WT_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3Xd J_WE_;
  std::vector<JointWarning> warnings_;
  // per joint: the four gain parameters Apply last turned into scales, and those scales
  struct ScaleMemo {
    std::array<double, 4> u{}, scale{};
    double length_scale = 1.0;
    bool valid = false;
  };
  std::vector<ScaleMemo> scale_memo_;
  std::vector<std::uint8_t> option_warning_;  // W_i ≠ ∅ for the options (options.warnings)
  std::vector<JointLookahead> lookahead_;
  std::vector<OptionMachine> options_;
  std::vector<std::uint8_t> terminate_flags_;
  // options.parameter_period > 1: the RMP parameters each joint holds, the steps since it read them, and the warning
  // state at that read (nq × kNumContinuous; nq; nq); a negative age forces a read (episode start)
  Eigen::Matrix<float, Eigen::Dynamic, RmpActionLayout::kNumContinuous, Eigen::RowMajor> held_parameters_;
  std::vector<int> parameter_age_;
  std::vector<std::uint8_t> parameter_warning_;
  std::unique_ptr<Layer> layer_;  // per-joint-rmp
};

}  // namespace rmpmarl::control
