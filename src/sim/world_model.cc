// WorldModel: servo gains from the joint-space inertia, MJCF compilation and the rmpmarl ↔ MuJoCo index maps.
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::sim {
namespace {


// id of the named MuJoCo object; the names come from our own MJCF, so a miss is an internal error.
int IdOf(const mjModel* m, mjtObj type, const std::string& name) {
  const int id = mj_name2id(m, type, name.c_str());
  RMPMARL_ASSERT(id >= 0, "generated MJCF lacks element '" + name + "'");
  return id;
}

// reference configuration of the gain computation: middle of each finite joint range, else 0.
Eigen::VectorXd ReferenceConfiguration(const kinematics::Model& model) {
  Eigen::VectorXd q = Eigen::VectorXd::Zero(model.nq());
  for (int i = 0; i < model.nq(); ++i) {
    const kinematics::DofLimits& lim = model.limits()[i];
    if (std::isfinite(lim.lower) && std::isfinite(lim.upper)) q[i] = 0.5 * (lim.lower + lim.upper);
  }
  return q;
}

// diagonal of the joint-space inertia (armature included) at q, in rmpmarl dof order.
Eigen::VectorXd InertiaDiagonal(const kinematics::Robot& robot, const mjModel* m, const Eigen::VectorXd& q) {
  std::unique_ptr<mjData, void (*)(mjData*)> d(mj_makeData(m), mj_deleteData);
  const int nq = robot.model.nq();
  for (int i = 0; i < nq; ++i) {
    const int joint = IdOf(m, mjOBJ_JOINT, robot.model.dof_name(i));
    d->qpos[m->jnt_qposadr[joint]] = q[i];
  }
  mj_kinematics(m, d.get());
  mj_comPos(m, d.get());
  mj_crb(m, d.get());
  Eigen::VectorXd diag(nq);
  for (int i = 0; i < nq; ++i) {
    const int joint = IdOf(m, mjOBJ_JOINT, robot.model.dof_name(i));
    diag[i] = d->qM[m->dof_Madr[m->jnt_dofadr[joint]]];
  }
  return diag;
}

}  // namespace

WorldModel::WorldModel(kinematics::Robot robot, SceneSpec scene, WorldOptions options)
    : robot_(std::move(robot)), collision_(robot_), scene_(std::move(scene)), options_(std::move(options)) {
  CheckWorldInputs(robot_, scene_, options_);
  const kinematics::Model& model = robot_.model;
  const int nq = model.nq();
  const std::string source = fmt::format("sim world of robot '{}'", robot_.name);

  // servo gains: explicit, or from the inertia a unit-gain compile of the same model reports (see ServoOptions).
  const ServoOptions& servo = options_.servo;
  gains_.kp = servo.kp;
  gains_.damping = servo.damping;
  if (nq > 0 && (servo.kp.size() == 0 || servo.damping.size() == 0)) {
    const ServoGains unit{Eigen::VectorXd::Ones(nq), Eigen::VectorXd::Zero(nq)};
    const std::shared_ptr<mjModel> probe = CompileMjcf(WriteMjcf(robot_, scene_, options_, unit), source);
    const Eigen::VectorXd M = InertiaDiagonal(robot_, probe.get(), ReferenceConfiguration(model));
    const double w = servo.natural_frequency;
    if (servo.kp.size() == 0) gains_.kp = w * w * M;
    if (servo.damping.size() == 0) {
      gains_.damping = (2.0 * servo.damping_ratio * (gains_.kp.array() * M.array()).sqrt()).matrix();
    }
  } else if (nq == 0) {
    gains_.kp.resize(0);
    gains_.damping.resize(0);
  }

  mjcf_ = WriteMjcf(robot_, scene_, options_, gains_);
  const std::shared_ptr<mjModel> compiled = CompileMjcf(mjcf_, source);
  mj_model_ = compiled;
  const mjModel* m = compiled.get();

  dof_qpos_adr_.resize(nq);
  dof_vel_adr_.resize(nq);
  dof_actuator_.resize(nq);
  for (int i = 0; i < nq; ++i) {
    const int joint = IdOf(m, mjOBJ_JOINT, model.dof_name(i));
    dof_qpos_adr_[i] = m->jnt_qposadr[joint];
    dof_vel_adr_[i] = m->jnt_dofadr[joint];
    dof_actuator_[i] = IdOf(m, mjOBJ_ACTUATOR, MjcfNames::Actuator(robot_, i));
  }
  // the position limits (continuous joints unlimited) are the servos' (control::ServosOf)
  servos_ = control::ServosOf(robot_);
  servos_.timestep = m->opt.timestep;
  servos_.feedforward = (gains_.damping.array() / gains_.kp.array()).matrix();
  for (int k = 1; k < model.num_links(); ++k) {
    const kinematics::Link& link = model.link(k);
    if (link.mimic_dof < 0) continue;
    const int joint = IdOf(m, mjOBJ_JOINT, link.joint_name);
    mimic_joints_.push_back(
        {m->jnt_qposadr[joint], m->jnt_dofadr[joint], link.mimic_dof, link.mimic_multiplier, link.mimic_offset});
  }
  link_body_.resize(model.num_links());
  for (int k = 0; k < model.num_links(); ++k) link_body_[k] = IdOf(m, mjOBJ_BODY, MjcfNames::LinkBody(robot_, k));

  geom_info_.assign(m->ngeom, GeomInfo{});
  std::vector<char> assigned(m->ngeom, 0);
  capsule_geom_.resize(robot_.capsules.size());
  for (size_t c = 0; c < robot_.capsules.size(); ++c) {
    const int g = IdOf(m, mjOBJ_GEOM, MjcfNames::CapsuleGeom(robot_, static_cast<int>(c)));
    capsule_geom_[c] = g;
    geom_info_[g] = GeomInfo{GeomRole::kRobot, robot_.capsules[c].link, static_cast<int>(c), -1};
    assigned[g] = 1;
  }
  // the self-collision capsules: robot geoms numbered after the capsules (the collision checker's numbering)
  for (size_t c = 0; c < robot_.self_capsules.size(); ++c) {
    const int g = IdOf(m, mjOBJ_GEOM, MjcfNames::SelfCapsuleGeom(robot_, static_cast<int>(c)));
    geom_info_[g] = GeomInfo{GeomRole::kRobot, robot_.self_capsules[c].link,
                             static_cast<int>(robot_.capsules.size() + c), -1};
    assigned[g] = 1;
  }
  const int num_obs = num_obstacles();
  obstacle_body_.resize(num_obs);
  obstacle_mocap_.resize(num_obs);
  obstacle_geom_.resize(num_obs);
  for (int j = 0; j < num_obs; ++j) {
    obstacle_body_[j] = IdOf(m, mjOBJ_BODY, MjcfNames::ObstacleBody(j));
    obstacle_mocap_[j] = m->body_mocapid[obstacle_body_[j]];
    obstacle_geom_[j] = IdOf(m, mjOBJ_GEOM, MjcfNames::ObstacleGeom(j));
    geom_info_[obstacle_geom_[j]] = GeomInfo{GeomRole::kObstacle, -1, -1, j};
    assigned[obstacle_geom_[j]] = 1;
  }
  if (scene_.has_target) {
    target_mocap_ = m->body_mocapid[IdOf(m, mjOBJ_BODY, MjcfNames::kTargetBody)];
    target_geom_ = IdOf(m, mjOBJ_GEOM, MjcfNames::kTargetGeom);
    geom_info_[target_geom_] = GeomInfo{GeomRole::kTarget, -1, -1, -1};
    assigned[target_geom_] = 1;
  }
  if (scene_.has_floor) {
    floor_geom_ = IdOf(m, mjOBJ_GEOM, MjcfNames::kFloorGeom);
    geom_info_[floor_geom_] = GeomInfo{GeomRole::kFloor, -1, -1, -1};
    assigned[floor_geom_] = 1;
  }
  for (int g = 0; g < m->ngeom; ++g) RMPMARL_ASSERT(assigned[g], "every MuJoCo geom must have a role");

  for (int g = 0; g < m->ngeom; ++g) {
    if (m->geom_contype[g] == 0 && m->geom_conaffinity[g] == 0) continue;
    collidable_geoms_.push_back(g);
    if (m->body_mocapid[m->geom_bodyid[g]] >= 0) mocap_geoms_.push_back(g);
    max_contact_margin_ = std::max(max_contact_margin_, m->geom_margin[g]);
  }
  for (int p = 0; p < m->npair; ++p) max_contact_margin_ = std::max(max_contact_margin_, m->pair_margin[p]);
  // MuJoCo's contact rules: the explicit pairs, and its dynamic filter (a contype/conaffinity match on bodies of
  // distinct weld bodies; what its parent filter and the excluded body pairs drop is kept here: a superset)
  ngeom_ = m->ngeom;
  may_collide_.assign(static_cast<size_t>(ngeom_) * ngeom_, 0);
  for (int g = 0; g < ngeom_; ++g) {
    for (int h = 0; h < ngeom_; ++h) {
      const bool match = (m->geom_contype[g] & m->geom_conaffinity[h]) != 0 ||
                         (m->geom_contype[h] & m->geom_conaffinity[g]) != 0;
      const bool welded = m->body_weldid[m->geom_bodyid[g]] == m->body_weldid[m->geom_bodyid[h]];
      may_collide_[static_cast<size_t>(g) * ngeom_ + h] = match && !welded ? 1 : 0;
    }
  }
  for (int p = 0; p < m->npair; ++p) {
    const int g = m->pair_geom1[p], h = m->pair_geom2[p];
    may_collide_[static_cast<size_t>(g) * ngeom_ + h] = may_collide_[static_cast<size_t>(h) * ngeom_ + g] = 1;
  }

  const int L = model.num_links();
  checked_link_pair_.assign(static_cast<size_t>(L) * L, 0);
  for (int i = 0; i < L; ++i) {
    for (int j = 0; j < L; ++j) checked_link_pair_[i * L + j] = (i != j && !robot_.IsExcludedPair(i, j)) ? 1 : 0;
  }
}

}  // namespace rmpmarl::sim
