// World: one mjData of a shared WorldModel — reset, servo targets, mocap poses, split stepping, contact report.
#include "rmpmarl/sim/world.h"

#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"

namespace rmpmarl::sim {

void World::DataDeleter::operator()(mjData* d) const { mj_deleteData(d); }

World::World(std::shared_ptr<const WorldModel> model) : model_(std::move(model)) {
  if (!model_) throw InputError("sim::World: expected a WorldModel, got a null pointer");
  const mjModel* m = model_->mj_model();
  data_.reset(mj_makeData(m));
  RMPMARL_ASSERT(data_ != nullptr, "mj_makeData failed (out of memory)");
  const int nq = model_->nq();
  q_.setZero(nq);
  qd_.setZero(nq);
  q_cmd_.setZero(nq);
  feedforward_acc_.assign(m->nv, 0.0);
  feedforward_tau_.assign(m->nv, 0.0);
  // the scene's initial mocap poses (mj_makeData copied them from the model) are the authoritative copy.
  saved_mocap_pos_.assign(data_->mocap_pos, data_->mocap_pos + 3 * m->nmocap);
  saved_mocap_quat_.assign(data_->mocap_quat, data_->mocap_quat + 4 * m->nmocap);
  mocap_moved_.assign(m->nmocap, 0);
  report_.warnings.reserve(m->nconmax);
  report_.colliding_pairs.reserve(m->nconmax);
  const Eigen::VectorXd q0 = Eigen::VectorXd::Zero(nq).cwiseMax(model_->lower_limits()).cwiseMin(model_->upper_limits());
  Reset(q0);
}

World::~World() = default;
World::World(World&&) noexcept = default;
World& World::operator=(World&&) noexcept = default;

double World::time() const { return data_->time; }

Eigen::Vector3d World::EndEffectorPosition() const {
  const kinematics::Robot& robot = model_->robot();
  const int body = model_->link_body(robot.end_effector.link);
  const Eigen::Map<const Eigen::Vector3d> p_WL(data_->xpos + 3 * body);
  const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> R_WL(data_->xmat + 9 * body);
  return p_WL + R_WL * robot.end_effector.X_LE.translation();
}

void World::Sync() {
  mj_step1(model_->mj_model(), data_.get());
  MarkSynced();
}

void World::MarkSynced() {
  stale_ = false;
  std::fill(mocap_moved_.begin(), mocap_moved_.end(), 0);
}

bool World::NeedsWholeStep1AfterMocapMove() const {
  const mjModel* m = model_->mj_model();
  return m->nsensor > 0 || m->ntendon > 0 || (m->opt.enableflags & mjENBL_ENERGY) != 0;
}

void World::SyncMovedMocap() {
  const mjModel* m = model_->mj_model();
  mjData* d = data_.get();
  // Only mocap poses changed since the last mj_step1: qpos and qvel did not. Recomputed is what reads the mocap bodies'
  // poses: the bodies' and geoms' poses and the composite inertias (mj_kinematics, mj_comPos, mj_crb), the contacts
  // and the constraints built on them with their reference accelerations. What depends on qpos and qvel alone is
  // still valid: the joint-space inertia's factor, the bias and passive forces, the actuators' transmissions. Sensors,
  // tendons and the energy could read a mocap body's pose: a model with any takes the whole mj_step1.
  if (NeedsWholeStep1AfterMocapMove()) {
    Sync();
    return;
  }
  mj_kinematics(m, d);
  mj_comPos(m, d);
  mj_camlight(m, d);
  mj_crb(m, d);
  // no contact before and none possible now: the contacts and the constraints are what they were
  if (d->ncon == 0 && MovedGeomsClear()) {
    MarkSynced();
    return;
  }
  mj_collision(m, d);
  mj_makeConstraint(m, d);
  mj_projectConstraint(m, d);
  mj_referenceConstraint(m, d);
  MarkSynced();
}

Eigen::Vector3d World::GeomCentreAtMocapPoses(int g) const {
  const mjModel* m = model_->mj_model();
  const mjData* d = data_.get();
  const int mocap = m->body_mocapid[m->geom_bodyid[g]];
  if (mocap < 0) return Eigen::Map<const Eigen::Vector3d>(d->geom_xpos + 3 * g);
  // a mocap body's pose is its mocap pose (its quaternion normalised), as mj_kinematics sets it
  const double* q = d->mocap_quat + 4 * mocap;
  const Eigen::Quaterniond R(q[0], q[1], q[2], q[3]);
  return Eigen::Map<const Eigen::Vector3d>(d->mocap_pos + 3 * mocap) +
         R.normalized() * Eigen::Map<const Eigen::Vector3d>(m->geom_pos + 3 * g);
}

bool World::MovedGeomsClear() const {
  const mjModel* m = model_->mj_model();
  const mjData* d = data_.get();
  // a user's contact filter may let pairs through that MayCollide (MuJoCo's own rules) rules out
  if (mjcb_contactfilter != nullptr) return false;
  const double margin = model_->max_contact_margin();
  // the moved mocap geoms' positions from the mocap poses, so that the test holds also before mj_kinematics ran on
  // them; the slack below covers the rounding by which this differs from MuJoCo's own. A geom that did not move
  // keeps what it had: no contact where there was none.
  for (int g : model_->mocap_geoms()) {
    if (!mocap_moved_[m->body_mocapid[m->geom_bodyid[g]]]) continue;
    const Eigen::Vector3d p_g = GeomCentreAtMocapPoses(g);
    const double r_g = m->geom_rbound[g];
    if (!(r_g > 0.0)) return false;  // a plane (or another geom without a bounding sphere) on a mocap body
    for (int h : model_->collidable_geoms()) {
      if (h == g || !model_->MayCollide(g, h)) continue;
      const Eigen::Vector3d p_h = GeomCentreAtMocapPoses(h);
      // beyond contact distance with a relative slack far above the rounding of these few operations
      double gap = 0.0;
      if (m->geom_type[h] == mjGEOM_PLANE) {
        if (m->body_mocapid[m->geom_bodyid[h]] >= 0) return false;  // (its normal would be a stale one)
        const Eigen::Vector3d n_h(d->geom_xmat[9 * h + 2], d->geom_xmat[9 * h + 5], d->geom_xmat[9 * h + 8]);
        gap = n_h.dot(p_g - p_h) - r_g;
      } else if (m->geom_rbound[h] > 0.0) {
        gap = (p_g - p_h).norm() - r_g - m->geom_rbound[h];
      } else {
        return false;  // no bounding sphere to test
      }
      if (!(gap > margin + 1e-9 * (1.0 + std::abs(gap)))) return false;
    }
  }
  return true;
}

void World::ReadState() {
  for (int i = 0; i < model_->nq(); ++i) {
    q_[i] = data_->qpos[model_->dof_qpos_adr(i)];
    qd_[i] = data_->qvel[model_->dof_vel_adr(i)];
  }
}

StepIssue World::NewIssue() {
  // MuJoCo's own NaN handling (mj_checkPos/Vel/Acc) counts a warning and resets mjData, re-counting after the reset;
  // the counters are zeroed before every step, so any count means "this step".
  if (data_->warning[mjWARN_BADQACC].number > 0) return StepIssue::kBadQacc;
  if (data_->warning[mjWARN_BADQVEL].number > 0) return StepIssue::kBadQvel;
  if (data_->warning[mjWARN_BADQPOS].number > 0) return StepIssue::kBadQpos;
  return StepIssue::kNone;
}

void World::Reset(const Eigen::Ref<const Eigen::VectorXd>& q0, const Eigen::Ref<const Eigen::VectorXd>& qd0) {
  const kinematics::Model& kin = model_->kinematic_model();
  kinematics::CheckJointVector(kin, q0, "q0");
  kinematics::CheckJointVector(kin, qd0, "qd0");
  for (int i = 0; i < nq(); ++i) {
    if (q0[i] < model_->lower_limits()[i] || q0[i] > model_->upper_limits()[i]) {
      throw InputError(fmt::format("sim::World::Reset: q0[{}] ({}): expected a value within the joint limits "
                                   "[{}, {}], got {}", i, kin.dof_name(i), model_->lower_limits()[i],
                                   model_->upper_limits()[i], q0[i]));
    }
  }
  const mjModel* m = model_->mj_model();
  mjData* d = data_.get();
  mj_resetData(m, d);
  std::copy(saved_mocap_pos_.begin(), saved_mocap_pos_.end(), d->mocap_pos);
  std::copy(saved_mocap_quat_.begin(), saved_mocap_quat_.end(), d->mocap_quat);
  for (int i = 0; i < nq(); ++i) {
    d->qpos[model_->dof_qpos_adr(i)] = q0[i];
    d->qvel[model_->dof_vel_adr(i)] = qd0[i];
    d->ctrl[model_->dof_actuator(i)] = q0[i];
  }
  for (const WorldModel::MimicJoint& mimic : model_->mimic_joints()) {  // start on the equality constraint
    d->qpos[mimic.qpos_adr] = mimic.multiplier * q0[mimic.dof] + mimic.offset;
    d->qvel[mimic.vel_adr] = mimic.multiplier * qd0[mimic.dof];
  }
  q_cmd_ = q0;
  Sync();
  ReadState();
}

void World::Reset(const Eigen::Ref<const Eigen::VectorXd>& q0) { Reset(q0, Eigen::VectorXd::Zero(nq())); }

void World::SetJointTargets(const Eigen::Ref<const Eigen::VectorXd>& q_cmd) {
  kinematics::CheckJointVector(model_->kinematic_model(), q_cmd, "q_cmd");
  for (int i = 0; i < nq(); ++i) {
    q_cmd_[i] = std::clamp(q_cmd[i], model_->lower_limits()[i], model_->upper_limits()[i]);
    data_->ctrl[model_->dof_actuator(i)] = q_cmd_[i];
  }
}

void World::SetJointTargets(const Eigen::Ref<const Eigen::VectorXd>& q_cmd,
                            const Eigen::Ref<const Eigen::VectorXd>& qdd_cmd) {
  kinematics::CheckJointVector(model_->kinematic_model(), qdd_cmd, "qdd_cmd");
  SetJointTargets(q_cmd);  // the commands (checked, clamped) and, without the feed-forward, the servos' targets
  if (!model_->options().servo.inverse_dynamics_feedforward) return;
  // τ = M(q) q̈_cmd + c(q, q̇) + h D q̈_cmd, from mjData's M and c of the current state (mj_step1 ran on it): both
  // integrators take the joint damping D implicitly, the step solving (M + h D) q̈ = f (the implicit one also the
  // velocity derivative of c, left out here). A mimic joint accelerates with its leader (its root servoed dof), whose
  // servo supplies the follower's torque and joint damping through the equality (virtual work: multiplier × τ_f).
  const mjModel* m = model_->mj_model();
  std::fill(feedforward_acc_.begin(), feedforward_acc_.end(), 0.0);
  for (int i = 0; i < nq(); ++i) feedforward_acc_[model_->dof_vel_adr(i)] = qdd_cmd[i];
  for (const WorldModel::MimicJoint& mimic : model_->mimic_joints()) {
    feedforward_acc_[mimic.vel_adr] = mimic.multiplier * qdd_cmd[mimic.dof];
  }
  mj_mulM(m, data_.get(), feedforward_tau_.data(), feedforward_acc_.data());
  const double h = m->opt.timestep;
  for (int v = 0; v < m->nv; ++v) {
    feedforward_tau_[v] += data_->qfrc_bias[v] + h * m->dof_damping[v] * feedforward_acc_[v];
  }
  for (const WorldModel::MimicJoint& mimic : model_->mimic_joints()) {
    feedforward_tau_[model_->dof_vel_adr(mimic.dof)] +=
        mimic.multiplier * (feedforward_tau_[mimic.vel_adr] - data_->qfrc_passive[mimic.vel_adr]);
  }
  const Eigen::VectorXd& kp = model_->servo_gains().kp;
  for (int i = 0; i < nq(); ++i) {
    const double tau = feedforward_tau_[model_->dof_vel_adr(i)];
    data_->ctrl[model_->dof_actuator(i)] =
        std::clamp(q_cmd_[i] + tau / kp[i], model_->lower_limits()[i], model_->upper_limits()[i]);
  }
}

void World::SetObstaclePose(int j, const Eigen::Vector3d& p_WO, const Eigen::Matrix3d& R_WO) {
  if (j < 0 || j >= model_->num_obstacles()) {
    throw InputError(fmt::format("sim::World::SetObstaclePose: expected an obstacle index in [0, {}), got {}",
                                 model_->num_obstacles(), j));
  }
  if (!p_WO.allFinite() || !R_WO.allFinite()) {
    throw InputError(fmt::format("sim::World::SetObstaclePose: obstacle {}: expected a finite pose, got non-finite "
                                 "entries", j));
  }
  const double err = (R_WO.transpose() * R_WO - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (err > 1e-6 || R_WO.determinant() < 0.0) {
    throw InputError(fmt::format("sim::World::SetObstaclePose: obstacle {}: expected a rotation matrix "
                                 "(orthonormal, det +1), got |RᵀR − I|max = {:.3g}, det = {:.6g}", j, err,
                                 R_WO.determinant()));
  }
  const int id = model_->obstacle_mocap(j);
  const Eigen::Quaterniond quat(R_WO);
  const double pos[3] = {p_WO.x(), p_WO.y(), p_WO.z()};
  const double wxyz[4] = {quat.w(), quat.x(), quat.y(), quat.z()};
  std::copy(pos, pos + 3, &saved_mocap_pos_[3 * id]);
  std::copy(wxyz, wxyz + 4, &saved_mocap_quat_[4 * id]);
  std::copy(pos, pos + 3, data_->mocap_pos + 3 * id);
  std::copy(wxyz, wxyz + 4, data_->mocap_quat + 4 * id);
  stale_ = true;
  mocap_moved_[id] = 1;
}

void World::SetObstaclePose(int j, const Eigen::Isometry3d& X_WO) {
  SetObstaclePose(j, X_WO.translation(), X_WO.linear());
}

Eigen::Isometry3d World::ObstaclePose(int j) const {
  if (j < 0 || j >= model_->num_obstacles()) {
    throw InputError(fmt::format("sim::World::ObstaclePose: expected an obstacle index in [0, {}), got {}",
                                 model_->num_obstacles(), j));
  }
  const int id = model_->obstacle_mocap(j);
  const double* p = &saved_mocap_pos_[3 * id];
  const double* q = &saved_mocap_quat_[4 * id];
  Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
  X.linear() = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  X.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  return X;
}

void World::SetTargetPosition(const Eigen::Vector3d& p_WT) {
  if (model_->target_mocap() < 0) {
    throw InputError("sim::World::SetTargetPosition: expected a scene with a target (SceneSpec.has_target), got "
                     "none");
  }
  if (!p_WT.allFinite()) {
    throw InputError("sim::World::SetTargetPosition: expected a finite position, got non-finite entries");
  }
  const int id = model_->target_mocap();
  for (int a = 0; a < 3; ++a) {
    saved_mocap_pos_[3 * id + a] = p_WT[a];
    data_->mocap_pos[3 * id + a] = p_WT[a];
  }
  stale_ = true;
  mocap_moved_[id] = 1;
}

Eigen::Vector3d World::TargetPosition() const {
  if (model_->target_mocap() < 0) {
    throw InputError("sim::World::TargetPosition: expected a scene with a target (SceneSpec.has_target), got none");
  }
  const double* p = &saved_mocap_pos_[3 * model_->target_mocap()];
  return {p[0], p[1], p[2]};
}

StepResult World::Step(int num_steps) {
  if (num_steps < 1) {
    throw InputError(fmt::format("sim::World::Step: expected num_steps >= 1, got {}", num_steps));
  }
  const mjModel* m = model_->mj_model();
  mjData* d = data_.get();
  StepResult result;
  for (int s = 0; s < num_steps; ++s) {
    d->warning[mjWARN_BADQPOS].number = 0;
    d->warning[mjWARN_BADQVEL].number = 0;
    d->warning[mjWARN_BADQACC].number = 0;
    // After a mocap move, mj_step2 needs the pass over the moved poses only where it reads them: through contacts
    // and constraints. With no contact before and none possible after the move, it reads none (forces, inertia and
    // integration see the joints' bodies alone; mocap bodies carry no dof), and the mj_step1 after it computes every
    // moved pose, contact and constraint as the pass would have.
    if (stale_) {
      if (NeedsWholeStep1AfterMocapMove() || m->nq != m->nv || d->ncon != 0 || !MovedGeomsClear()) {
        SyncMovedMocap();
      } else {
        // what of the pass outlives the mj_step1 below: its mj_kinematics normalises the mocap quaternions in
        // place (and would the joints' quaternions, which a model with nq == nv has none of)
        for (int i = 0; i < m->nmocap; ++i) mju_normalize4(d->mocap_quat + 4 * i);
        ++skipped_mocap_passes_;
      }
    }
    // mj_step2 then mj_step1 is mj_step shifted by half a step: the position stage (kinematics, collisions) of the
    // new state is computed right away, so contacts in mjData always describe the current state.
    mj_step2(m, d);
    Sync();
    StepIssue issue = NewIssue();
    if (issue == StepIssue::kNone) {
      for (int i = 0; i < m->nq && issue == StepIssue::kNone; ++i) {
        if (!std::isfinite(d->qpos[i])) issue = StepIssue::kBadQpos;
      }
      for (int i = 0; i < m->nv && issue == StepIssue::kNone; ++i) {
        if (!std::isfinite(d->qvel[i])) issue = StepIssue::kBadQvel;
      }
    }
    if (issue != StepIssue::kNone) {
      // MuJoCo reset mjData (or the state is non-finite): put back the scene and the servo targets, zero the robot.
      result.ok = false;
      result.issue = issue;
      result.state_was_reset = true;
      mj_resetData(m, d);
      std::copy(saved_mocap_pos_.begin(), saved_mocap_pos_.end(), d->mocap_pos);
      std::copy(saved_mocap_quat_.begin(), saved_mocap_quat_.end(), d->mocap_quat);
      for (int i = 0; i < nq(); ++i) d->ctrl[model_->dof_actuator(i)] = q_cmd_[i];
      Sync();
      break;
    }
  }
  ReadState();
  result.time = d->time;
  return result;
}

const ContactReport& World::QueryContacts() {
  if (stale_) SyncMovedMocap();
  const mjModel* m = model_->mj_model();
  const mjData* d = data_.get();
  ContactReport& r = report_;
  r.num_collisions = 0;
  r.colliding_pairs.clear();
  r.warnings.clear();
  r.min_clearance = std::numeric_limits<double>::infinity();
  r.contact_buffer_full = d->ncon >= m->nconmax || d->nefc >= m->njmax;
  for (int c = 0; c < d->ncon; ++c) {
    const mjContact& con = d->contact[c];
    const GeomInfo& info1 = model_->geom_info(con.geom1);
    const GeomInfo& info2 = model_->geom_info(con.geom2);
    // robot side (shape 1) and the other side (shape 2); `robot_is_geom1` fixes the MuJoCo normal's orientation.
    bool robot_is_geom1 = true;
    if (info1.role == GeomRole::kRobot && info2.role == GeomRole::kRobot) {
      if (!model_->IsCheckedLinkPair(info1.link, info2.link)) continue;
      robot_is_geom1 = info1.link < info2.link || (info1.link == info2.link && info1.capsule < info2.capsule);
    } else if (info1.role == GeomRole::kRobot) {
      if (info2.role == GeomRole::kTarget) continue;
      robot_is_geom1 = true;
    } else if (info2.role == GeomRole::kRobot) {
      if (info1.role == GeomRole::kTarget) continue;
      robot_is_geom1 = false;
    } else {
      continue;  // scene–scene contacts never count (none are generated)
    }
    const GeomInfo& robot = robot_is_geom1 ? info1 : info2;
    const GeomInfo& other = robot_is_geom1 ? info2 : info1;
    // MuJoCo: pos is the midpoint between the surfaces, frame[0:3] the normal pointing from geom1 to geom2.
    const Eigen::Vector3d pos(con.pos[0], con.pos[1], con.pos[2]);
    const Eigen::Vector3d n12(con.frame[0], con.frame[1], con.frame[2]);
    const Eigen::Vector3d p_geom1 = pos - 0.5 * con.dist * n12;
    const Eigen::Vector3d p_geom2 = pos + 0.5 * con.dist * n12;
    WarningContact w;
    w.robot_geom = robot_is_geom1 ? con.geom1 : con.geom2;
    w.other_geom = robot_is_geom1 ? con.geom2 : con.geom1;
    w.link = robot.link;
    w.capsule = robot.capsule;
    switch (other.role) {
      case GeomRole::kRobot:
        w.other_kind = PartnerKind::kLink;
        w.other_index = other.link;
        w.other_capsule = other.capsule;
        break;
      case GeomRole::kObstacle:
        w.other_kind = PartnerKind::kObstacle;
        w.other_index = other.obstacle;
        break;
      default:
        w.other_kind = PartnerKind::kFloor;
        w.other_index = -1;
    }
    w.distance = con.dist;
    w.p_W1 = robot_is_geom1 ? p_geom1 : p_geom2;
    w.p_W2 = robot_is_geom1 ? p_geom2 : p_geom1;
    w.n_W = robot_is_geom1 ? Eigen::Vector3d(-n12) : n12;
    r.min_clearance = std::min(r.min_clearance, w.distance);
    if (w.distance < 0.0) {
      auto it = std::find_if(r.colliding_pairs.begin(), r.colliding_pairs.end(), [&](const CollidingPair& p) {
        return p.link == w.link && p.other_kind == w.other_kind && p.other_index == w.other_index;
      });
      if (it == r.colliding_pairs.end()) {
        r.colliding_pairs.push_back(CollidingPair{w.link, w.other_kind, w.other_index, -w.distance});
      } else {
        it->depth = std::max(it->depth, -w.distance);
      }
    }
    r.warnings.push_back(w);
  }
  r.num_collisions = static_cast<int>(r.colliding_pairs.size());
  return r;
}

}  // namespace rmpmarl::sim
