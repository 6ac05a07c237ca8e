#pragma once
/// The MuJoCo physics world every later layer runs in. MuJoCo's own Model/Data split:
///  - `WorldModel`: built once per robot variant + scene + options; holds the immutable mjModel (shared, never
///    modified after construction) and the index maps between rmpmarl and MuJoCo (dof → qpos/dof/actuator, link →
///    body, capsule → geom, obstacle → mocap body/geom, target).
///  - `World`: one simulated episode; owns an mjData of a shared WorldModel. Step() and QueryContacts() allocate
///    nothing (every buffer is sized at construction).
/// Conventions (docs/sim.md): gravity is off (MuJoCo 2.2.2 has no gravity compensation), a per-dof position servo
/// tracks commanded joint positions, contacts within `warning_margin` of robot geoms are reported but only real
/// penetrations (distance < 0) reach the constraint solver.
#include <mujoco/mjdata.h>
#include <mujoco/mjmodel.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/collision/checker.h"
#include "rmpmarl/control/servos.h"
#include "rmpmarl/control/warning.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/sim/mjcf.h"

namespace rmpmarl::sim {

/// What a MuJoCo geom of the world is.
enum class GeomRole { kRobot, kObstacle, kTarget, kFloor };

/// Identity of one MuJoCo geom in rmpmarl terms.
struct GeomInfo {
  GeomRole role = GeomRole::kRobot;
  int link = -1;      ///< robot link (kRobot)
  int capsule = -1;   ///< index into Robot::capsules, then Robot::self_capsules (kRobot)
  int obstacle = -1;  ///< index into SceneSpec::obstacles (kObstacle)
};

/// The immutable, shareable half of a world: compiled mjModel + index maps. Cheap to copy (the mjModel is shared).
class WorldModel {
 public:
  /// generates the MJCF, computes the servo gains (ServoOptions), compiles. Throws InputError on bad input or when
  /// MuJoCo rejects the model (with its compiler message).
  WorldModel(kinematics::Robot robot, SceneSpec scene = {}, WorldOptions options = {});

  const mjModel* mj_model() const { return mj_model_.get(); }
  const kinematics::Robot& robot() const { return robot_; }
  /// the robot collision checker of the robot's capsules (clearances of what the world shows)
  const collision::RobotCollisionModel& collision() const { return collision_; }
  const kinematics::Model& kinematic_model() const { return robot_.model; }
  const SceneSpec& scene() const { return scene_; }
  const WorldOptions& options() const { return options_; }
  /// the MJCF text the mjModel was compiled from.
  const std::string& mjcf() const { return mjcf_; }
  /// servo gains per dof, as compiled.
  const ServoGains& servo_gains() const { return gains_; }
  /// the joints as a control::ReactiveController commands them: limits, the physics timestep, the servos'
  /// velocity feed-forward d_i / kp_i.
  const control::ServoSpec& servos() const { return servos_; }

  int nq() const { return robot_.model.nq(); }
  int num_obstacles() const { return static_cast<int>(scene_.obstacles.size()); }
  /// qpos address of dof i.
  int dof_qpos_adr(int i) const { return dof_qpos_adr_[i]; }
  /// qvel/dof address of dof i.
  int dof_vel_adr(int i) const { return dof_vel_adr_[i]; }
  /// A mimic joint of the robot in MuJoCo: its qpos/qvel address and the dof it follows (kinematics::Link).
  struct MimicJoint {
    int qpos_adr = 0, vel_adr = 0, dof = 0;
    double multiplier = 1.0, offset = 0.0;
  };
  /// the robot's mimic joints (held to their leaders by MuJoCo joint equalities; set with them on Reset).
  const std::vector<MimicJoint>& mimic_joints() const { return mimic_joints_; }
  /// actuator id of dof i's servo.
  int dof_actuator(int i) const { return dof_actuator_[i]; }
  /// MuJoCo body id of link k.
  int link_body(int k) const { return link_body_[k]; }
  /// MuJoCo geom id of capsule c.
  int capsule_geom(int c) const { return capsule_geom_[c]; }
  /// MuJoCo body id, mocap id and geom id of obstacle j.
  int obstacle_body(int j) const { return obstacle_body_[j]; }
  int obstacle_mocap(int j) const { return obstacle_mocap_[j]; }
  int obstacle_geom(int j) const { return obstacle_geom_[j]; }
  /// mocap id / geom id of the target, -1 without one.
  int target_mocap() const { return target_mocap_; }
  int target_geom() const { return target_geom_; }
  /// geom id of the floor, -1 without one.
  int floor_geom() const { return floor_geom_; }
  /// what geom g is.
  const GeomInfo& geom_info(int g) const { return geom_info_[g]; }
  /// true when robot links i and j are checked against each other (not Robot::IsExcludedPair, i != j).
  bool IsCheckedLinkPair(int i, int j) const { return checked_link_pair_[i * robot_.model.num_links() + j] != 0; }
  /// the geoms of mocap bodies (obstacles, target) that take part in contacts (a contype or conaffinity bit).
  const std::vector<int>& mocap_geoms() const { return mocap_geoms_; }
  /// every geom that takes part in contacts.
  const std::vector<int>& collidable_geoms() const { return collidable_geoms_; }
  /// false when MuJoCo never makes a contact between geoms g and h: no explicit pair names them and its dynamic
  /// filter rules them out (no contype/conaffinity match, or both on one weld body — two world-welded bodies, such as
  /// a mocap body and the world or two mocap bodies, never collide dynamically).
  bool MayCollide(int g, int h) const { return may_collide_[static_cast<size_t>(g) * ngeom_ + h] != 0; }
  /// the largest contact margin of a geom or an explicit pair: beyond it MuJoCo makes no contact.
  double max_contact_margin() const { return max_contact_margin_; }
  /// lower/upper commanded position per dof (joint limits; ±inf for continuous joints).
  const Eigen::VectorXd& lower_limits() const { return servos_.lower; }
  const Eigen::VectorXd& upper_limits() const { return servos_.upper; }

 private:
  kinematics::Robot robot_;
  collision::RobotCollisionModel collision_;
  SceneSpec scene_;
  WorldOptions options_;
  ServoGains gains_;
  control::ServoSpec servos_;
  std::string mjcf_;
  std::shared_ptr<const mjModel> mj_model_;
  std::vector<int> dof_qpos_adr_, dof_vel_adr_, dof_actuator_, link_body_, capsule_geom_;
  std::vector<MimicJoint> mimic_joints_;
  std::vector<int> obstacle_body_, obstacle_mocap_, obstacle_geom_;
  int target_mocap_ = -1, target_geom_ = -1, floor_geom_ = -1;
  std::vector<GeomInfo> geom_info_;
  std::vector<char> checked_link_pair_;  // num_links x num_links
  std::vector<int> mocap_geoms_, collidable_geoms_;
  std::vector<std::uint8_t> may_collide_;  // ngeom × ngeom
  int ngeom_ = 0;
  double max_contact_margin_ = 0.0;
};

/// Numerical trouble MuJoCo detected during a step (its mjWARN_BAD* warnings).
enum class StepIssue { kNone, kBadQpos, kBadQvel, kBadQacc };

/// Result of World::Step.
struct StepResult {
  bool ok = true;                     ///< false when the state became non-finite or huge (see issue)
  StepIssue issue = StepIssue::kNone;
  /// MuJoCo responded to the bad value by resetting the robot state to q = 0, q̇ = 0 (obstacle and target poses
  /// are kept); the caller should Reset() or end the episode.
  bool state_was_reset = false;
  double time = 0.0;                  ///< simulation time after the step [s]
};

using control::PartnerKind;
using control::WarningContact;

/// A pair in real penetration (distance < 0). For link–link pairs link < other_index.
struct CollidingPair {
  int link = -1;
  PartnerKind other_kind = PartnerKind::kObstacle;
  int other_index = -1;
  double depth = 0.0;  ///< deepest penetration of the pair [m], > 0
};

/// Result of World::QueryContacts. Obstacle–obstacle and target contacts never appear; robot–robot contacts only for
/// pairs WorldModel::IsCheckedLinkPair.
struct ContactReport {
  int num_collisions = 0;                       ///< == colliding_pairs.size()
  std::vector<CollidingPair> colliding_pairs;   ///< distinct (link, partner) pairs with distance < 0
  /// smallest signed distance among the warning contacts; +inf when nothing is within the margin.
  double min_clearance = std::numeric_limits<double>::infinity();
  std::vector<WarningContact> warnings;         ///< every robot contact within the warning margin
  bool contact_buffer_full = false;             ///< MuJoCo's contact list overflowed; the report may be incomplete
};

/// One simulated world: an mjData of a shared WorldModel, plus preallocated query buffers. Move-only.
class World {
 public:
  /// makes the data and resets to q = clamp(0, limits), q̇ = 0, targets = q, obstacles/target at the scene's poses.
  explicit World(std::shared_ptr<const WorldModel> model);
  ~World();
  World(World&&) noexcept;
  World& operator=(World&&) noexcept;
  World(const World&) = delete;
  World& operator=(const World&) = delete;

  const WorldModel& model() const { return *model_; }
  const std::shared_ptr<const WorldModel>& shared_model() const { return model_; }
  int nq() const { return model_->nq(); }

  /// sets q, q̇ and the joint targets (= q0), time 0; obstacle and target poses are kept. Throws InputError unless
  /// q0/qd0 have nq finite entries and q0 lies within the joint limits.
  void Reset(const Eigen::Ref<const Eigen::VectorXd>& q0, const Eigen::Ref<const Eigen::VectorXd>& qd0);
  /// Reset(q0, 0).
  void Reset(const Eigen::Ref<const Eigen::VectorXd>& q0);

  /// commanded joint positions of the servos, clamped to the joint limits. Throws InputError unless q_cmd has nq
  /// finite entries.
  void SetJointTargets(const Eigen::Ref<const Eigen::VectorXd>& q_cmd);
  /// the same, with the commanded acceleration q̈_cmd (ReactiveController::qdd_cmd) for the servos' inverse-dynamics
  /// feed-forward when the model's ServoOptions::inverse_dynamics_feedforward is on (ignored otherwise): the servos'
  /// targets (mjData ctrl) are the clamped commands offset by the torque q̈_cmd needs at the current state over kp,
  /// clamped to the limits again (so within about M q̈ / kp of a limit the feed-forward is cut); joint_targets() keeps
  /// the commands without the offset. The one-argument form gives the PD alone whatever the option. Throws
  /// InputError unless q̈_cmd has nq finite entries.
  void SetJointTargets(const Eigen::Ref<const Eigen::VectorXd>& q_cmd, const Eigen::Ref<const Eigen::VectorXd>& qdd_cmd);
  /// the current (clamped) joint targets, without the feed-forward's offset.
  const Eigen::VectorXd& joint_targets() const { return q_cmd_; }

  /// moves obstacle j's centre frame to (p_WO, R_WO). Throws InputError for a bad index, non-finite values or a
  /// non-rotation R_WO.
  void SetObstaclePose(int j, const Eigen::Vector3d& p_WO, const Eigen::Matrix3d& R_WO);
  void SetObstaclePose(int j, const Eigen::Isometry3d& X_WO);
  /// pose of obstacle j's centre frame.
  Eigen::Isometry3d ObstaclePose(int j) const;
  /// moves the target marker. Throws InputError without a target or for non-finite values.
  void SetTargetPosition(const Eigen::Vector3d& p_WT);
  Eigen::Vector3d TargetPosition() const;

  /// advances the simulation by `num_steps` timesteps (MuJoCo mj_step2 + mj_step1, so contacts and kinematics in
  /// mjData describe the new state). Stops early and reports when MuJoCo flags a non-finite state.
  StepResult Step(int num_steps = 1);

  /// joint positions / velocities in rmpmarl dof order (updated by Reset and Step).
  const Eigen::VectorXd& q() const { return q_; }
  const Eigen::VectorXd& qd() const { return qd_; }
  /// simulation time [s].
  double time() const;
  /// the end effector's position p_WE [m] in the current state (MuJoCo's pose of its link).
  Eigen::Vector3d EndEffectorPosition() const;

  /// contacts of the current state (recomputing MuJoCo's collision detection first when a mocap pose changed).
  /// The returned reference stays valid until the next call; nothing is allocated.
  const ContactReport& QueryContacts();

  /// how many physics steps after an obstacle or target move did without a pass over the moved poses (a
  /// diagnostic: no contact before the move and none possible after it, see docs/sim.md).
  long skipped_mocap_passes() const { return skipped_mocap_passes_; }
  /// the raw MuJoCo data (read it; writing it bypasses the World's bookkeeping).
  const mjData* mj_data() const { return data_.get(); }
  const mjModel* mj_model() const { return model_->mj_model(); }

 private:
  struct DataDeleter {
    void operator()(mjData* d) const;
  };
  void Sync();           // mj_step1 on the current state: kinematics, contacts, velocities
  void SyncMovedMocap();  // the same after a mocap pose changed (the joints' state did not), without the joints' part
  bool NeedsWholeStep1AfterMocapMove() const;  // sensors, tendons or the energy could read a mocap pose
  bool MovedGeomsClear() const;  // no geom of a moved mocap body within contact distance of another (mocap poses)
  Eigen::Vector3d GeomCentreAtMocapPoses(int g) const;  // a geom's centre, a mocap body's from its mocap pose
  void MarkSynced();  // the position stage describes the mocap poses: nothing stale, nothing moved
  void ReadState();      // qpos/qvel -> q_, qd_
  StepIssue NewIssue();  // compares MuJoCo's bad-value warning counters with the last seen ones

  std::shared_ptr<const WorldModel> model_;
  std::unique_ptr<mjData, DataDeleter> data_;
  Eigen::VectorXd q_, qd_, q_cmd_;
  std::vector<double> feedforward_acc_, feedforward_tau_;  // nv: the commanded acceleration, the torque it needs
  std::vector<double> saved_mocap_pos_, saved_mocap_quat_;
  int seen_bad_qpos_ = 0, seen_bad_qvel_ = 0, seen_bad_qacc_ = 0;
  bool stale_ = false;  // a mocap pose changed since the last mj_step1
  std::vector<std::uint8_t> mocap_moved_;  // per mocap body: its pose changed since the last mj_step1
  long skipped_mocap_passes_ = 0;
  ContactReport report_;
};

}  // namespace rmpmarl::sim
