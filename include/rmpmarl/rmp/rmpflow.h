#pragma once
/// The RMPflow baseline the paper compares against: the usual manipulator leaf set combined by an rmp::Tree —
///  - end-effector target: the target RMP of eqs (5)–(7) on the end-effector position (RMPflow's linear damping by
///    default, see configs/rmpflow/default.yaml), fed with the velocity relative to the target;
///  - C-space target to a home posture (damped attractor with robust capping, plus `inertia`) and C-space damping;
///  - obstacle avoidance: the collision RMP of eqs (8)–(9) for every moving link capsule × every obstacle slot;
///  - self-collision avoidance: the same RMP (own parameters) for every capsule pair on non-excluded links
///    (Robot::IsExcludedPair; pairs where neither link moves are left out);
///  - joint-position limits (two 1-D barriers per joint with finite limits) and the joint-velocity cap;
/// then q̈ = (M_q + λI)⁻¹ f_q, scaled down to `max_acceleration_norm` when longer (Lula's canonical_resolve).
/// Parameters load from configs/rmpflow/<robot>.yaml, falling back to configs/rmpflow/default.yaml.
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/joint_rmps.h"
#include "rmpmarl/rmp/paper_rmps.h"
#include "rmpmarl/rmp/rmp.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/rmp/tree.h"

namespace rmpmarl::rmp {

/// Parameters of the RMPflow baseline; RmpflowOptions{} equals configs/rmpflow/default.yaml.
struct RmpflowOptions {
  RmpflowOptions();

  CSpaceTargetRmpParams cspace_target;        ///< `rmp_params.cspace_target_rmp`
  CSpaceDampingRmpParams cspace_damping;      ///< `rmp_params.cspace_damping_rmp`
  JointLimitRmpParams joint_limit;            ///< `rmp_params.joint_limit_rmp`
  JointVelocityCapRmpParams joint_velocity_cap;  ///< `rmp_params.joint_velocity_cap_rmp`
  TargetRmpParams target;                     ///< `rmp_params.target_rmp` (default: linear damping, k_d = 85 1/s)
  CollisionRmpParams collision;               ///< `rmp_params.collision_rmp` (obstacles)
  CollisionRmpParams self_collision;          ///< `rmp_params.self_collision_rmp` (link capsule pairs)
  bool self_collision_enabled = true;         ///< `self_collision_enabled`
  double joint_limit_buffer = 0.01;           ///< [rad or m] ≥ 0, limits padded inwards, `joint_limit_buffer`
  double max_acceleration_norm = 50.0;        ///< ‖q̈‖ cap, > 0 (inf: none), `canonical_resolve.max_acceleration_norm`
  ResolveOptions resolve;                     ///< `canonical_resolve.relative_regularizer`
  /// C-space target posture (`home`); empty: the middle of each joint's limits (0 for continuous joints).
  std::vector<double> home;
};

/// throws InputError naming `where` unless every parameter is finite and in range.
void ValidateRmpflowOptions(const RmpflowOptions& options, std::string_view where);

/// loads RMPflow parameters from YAML; keys missing from the file keep RmpflowOptions{} values. Throws InputError
/// naming the file and key for unknown keys, non-numbers, non-finite or out-of-range values.
RmpflowOptions LoadRmpflowOptions(const std::filesystem::path& path);

/// reads the keys of `overrides_yaml` (a mapping in the config file's layout, e.g. `rmp_params: {collision_rmp:
/// {repulsion_gain: 3200}}`) onto `options`; keys it lacks keep their values. Throws InputError naming `source` and
/// the key; `options` is unchanged then.
void ApplyRmpflowOverrides(RmpflowOptions& options, const std::string& overrides_yaml, const std::string& source);

/// directory of the shipped RMPflow configs (configs/rmpflow/ beside the models directory).
std::filesystem::path RmpflowConfigDirectory();

/// configs/rmpflow/<robot_name>.yaml when it exists, else configs/rmpflow/default.yaml.
std::filesystem::path RmpflowConfigPath(const std::string& robot_name);

/// the settings of this robot: robot.settings_path (a user's <urdf stem>.rmpflow.yaml) when set; for a shipped robot
/// RmpflowConfigPath(robot.name); for any other robot configs/rmpflow/default.yaml — a user's URDF is never matched
/// to a shipped config by its robot name.
std::filesystem::path RmpflowConfigPath(const kinematics::Robot& robot);

/// LoadRmpflowOptions(RmpflowConfigPath(robot)), with robot.home (a home found in memory) replacing `home` when set.
RmpflowOptions LoadRmpflowOptions(const kinematics::Robot& robot);

/// Diagnostics of the last evaluation.
struct RmpflowDiagnostics {
  double min_obstacle_distance = 0.0;  ///< min signed capsule–obstacle distance among evaluated pairs (+inf: none)
  double min_self_distance = 0.0;      ///< min signed self distance among evaluated pairs (+inf: none)
  int active_obstacle_pairs = 0;       ///< obstacle pairs within the deactivation radius
  int active_self_pairs = 0;           ///< self pairs within the deactivation radius
  double target_distance = 0.0;        ///< ‖x₀ − x_E‖ (0 without a target)
  double lambda = 0.0;                 ///< resolve regulariser
  bool clipped = false;                ///< q̈ was scaled down to max_acceleration_norm
};

/// The RMPflow baseline policy (q, q̇, scene) ↦ q̈. Evaluate allocates nothing.
class RmpflowPolicy {
 public:
  /// builds the tree for `robot` with slots for up to max_obstacles obstacles; validates options (InputError).
  RmpflowPolicy(const kinematics::Robot& robot, const RmpflowOptions& options, int max_obstacles);

  /// q̈ of the combined policy; the C-space target is scene.q_T when given, else home(). Throws InputError for q/q̇
  /// (or a given q_T) of the wrong size or non-finite, or more than max_obstacles obstacles.  \pre ValidateScene(scene) (obstacle data is not rechecked per call).
  void Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                const Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd);

  /// the pulled-back C-space RMP of the leaves that are not the task's — C-space target and damping, joint limits,
  /// velocity cap, self-collision; not the end-effector target nor the obstacles — left unresolved in data().f_root
  /// and data().M_root: the rest of RMPflow under a coupled per-joint basic layer (rmp::EvaluateCoupledLayer). The
  /// end-effector node is left out (end_effector_position() stays that of the last Evaluate). The C-space target is
  /// `posture` when non-empty (a scene's q_T), else home(), with metric scalar `posture_metric` when > 0 (a scene's
  /// q_T_metric), else the options', moving with `posture_velocity` when non-empty (a scene's qd_T) and
  /// `posture_acceleration` (qdd_T, only with a velocity). Throws InputError for q/q̇/posture/posture velocity or
  /// acceleration of the wrong size or non-finite. Allocates nothing.
  void EvaluateStructure(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                         const Eigen::VectorXd& posture = Eigen::VectorXd(), double posture_metric = 0.0,
                         const Eigen::VectorXd& posture_velocity = Eigen::VectorXd(),
                         const Eigen::VectorXd& posture_acceleration = Eigen::VectorXd());

  /// sets the C-space target posture (nq finite values).
  void set_home(const Eigen::Ref<const Eigen::VectorXd>& home);
  const Eigen::VectorXd& home() const { return home_; }
  const RmpflowOptions& options() const { return options_; }
  int max_obstacles() const { return max_obstacles_; }
  const Tree& tree() const { return tree_; }
  const TreeData& data() const { return data_; }
  const RmpflowDiagnostics& diagnostics() const { return diagnostics_; }
  /// world position of the end effector at the last evaluation.
  Eigen::Vector3d end_effector_position() const;

 private:
  /// writes the leaves' RMPs after PushForward; without task_leaves, not the target's nor the obstacles'.
  void WriteLeaves(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                   const Scene& scene, const Eigen::VectorXd& posture, double posture_metric,
                   const Eigen::VectorXd& posture_velocity, const Eigen::VectorXd& posture_acceleration,
                   bool task_leaves);
  /// `posture` when given (checked), else home_.
  const Eigen::VectorXd& PostureTarget(const Eigen::VectorXd& posture) const;

  struct JointLimitLeaf {
    int node;
    int dof;
  };
  RmpflowOptions options_;
  int max_obstacles_;
  Tree tree_;
  TreeData data_;
  Eigen::VectorXd home_;
  Eigen::VectorXd v_max_;  // per-dof velocity cap
  int ee_node_ = -1;
  int cspace_node_ = -1;
  std::vector<JointLimitLeaf> joint_limit_nodes_;
  std::vector<int> velocity_cap_nodes_;  // one per dof
  std::vector<int> obstacle_nodes_;
  std::vector<int> self_nodes_;
  RmpflowDiagnostics diagnostics_;
  Scene no_task_;  ///< no target, no obstacles (EvaluateStructure)
};

}  // namespace rmpmarl::rmp
