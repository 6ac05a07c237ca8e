#include "rmpmarl/kinematics/forward_kinematics.h"

#include <fmt/format.h>

#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::kinematics {
namespace {

// pose of the child link in its parent for joint coordinate q: X_PL = X_PJ · motion(axis_J, q) (URDF convention).
Eigen::Isometry3d JointPose(const Link& link, double q) {
  Eigen::Isometry3d X_PL = link.X_PJ;
  switch (link.joint_type) {
    case JointType::kRevolute:
    case JointType::kContinuous:
      X_PL.linear() = link.X_PJ.linear() * Eigen::AngleAxisd(q, link.axis_J).toRotationMatrix();
      break;
    case JointType::kPrismatic:
      X_PL.translation() += link.X_PJ.linear() * (link.axis_J * q);
      break;
    case JointType::kFixed:
      break;
  }
  return X_PL;
}

bool IsRotational(JointType type) { return type == JointType::kRevolute || type == JointType::kContinuous; }

}  // namespace

void CalcForwardKinematics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, Data* data) {
  RMPMARL_DASSERT(q.size() == model.nq(), "q has the wrong size");
  data->X_WL[0].setIdentity();
  for (int k = 1; k < model.num_links(); ++k) {
    const Link& link = model.link(k);
    data->X_WL[k] = data->X_WL[link.parent] * JointPose(link, model.JointValue(k, q));
    if (link.moving()) {
      data->axis_WL.col(k) = data->X_WL[k].linear() * link.axis_J;
      if (link.q_index >= 0) data->axis_W.col(link.q_index) = data->axis_WL.col(k);
    }
  }
  data->has_velocities = false;
}

void CalcVelocityKinematics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& qd, Data* data) {
  RMPMARL_DASSERT(qd.size() == model.nq(), "qd has the wrong size");
  CalcForwardKinematics(model, q, data);
  data->w_WL.col(0).setZero();
  data->v_WLo.col(0).setZero();
  data->alpha_bias_WL.col(0).setZero();
  data->a_bias_WLo.col(0).setZero();
  // Recursive propagation from the root (Featherstone, RBDA §2–3, written with world-frame vectors): r is the
  // vector from the parent origin to the child origin, and the joint acts at the child origin (URDF).
  for (int k = 1; k < model.num_links(); ++k) {
    const Link& link = model.link(k);
    const int p = link.parent;
    const Eigen::Vector3d r = data->X_WL[k].translation() - data->X_WL[p].translation();
    const Eigen::Vector3d w_p = data->w_WL.col(p);
    const Eigen::Vector3d alpha_p = data->alpha_bias_WL.col(p);
    Eigen::Vector3d w = w_p;
    Eigen::Vector3d v = data->v_WLo.col(p) + w_p.cross(r);
    Eigen::Vector3d alpha = alpha_p;
    Eigen::Vector3d a = data->a_bias_WLo.col(p) + alpha_p.cross(r) + w_p.cross(w_p.cross(r));
    if (link.moving()) {
      // axis times rate (a mimic joint's rate is its multiplier times its leader's)
      const double rate = link.q_index >= 0 ? qd[link.q_index] : link.mimic_multiplier * qd[link.mimic_dof];
      const Eigen::Vector3d s = data->axis_WL.col(k) * rate;
      if (IsRotational(link.joint_type)) {
        w += s;
        alpha += w_p.cross(s);   // d/dt of the axis, which turns with the parent
      } else {
        v += s;
        a += 2.0 * w_p.cross(s);  // Coriolis term of a sliding joint
      }
    }
    data->w_WL.col(k) = w;
    data->v_WLo.col(k) = v;
    data->alpha_bias_WL.col(k) = alpha;
    data->a_bias_WLo.col(k) = a;
  }
  data->has_velocities = true;
}

Eigen::Vector3d CalcPointPosition(const Data& data, int link, const Eigen::Vector3d& p_LP) {
  return data.X_WL[link] * p_LP;
}

Eigen::Vector3d CalcPointJacobianColumn(const Model& model, const Data& data, int dof, const Eigen::Vector3d& p_WP) {
  const int joint_link = model.dof_link(dof);
  const Eigen::Vector3d axis = data.axis_W.col(dof);
  if (!IsRotational(model.link(joint_link).joint_type)) return axis;
  return axis.cross(p_WP - data.X_WL[joint_link].translation());
}

Eigen::Vector3d CalcPointJacobianColumn(const Model& model, const Data& data, int dof, int link,
                                        const Eigen::Vector3d& p_WP) {
  if (!model.has_mimic_joints()) return CalcPointJacobianColumn(model, data, dof, p_WP);
  // the sum over the joints dof drives that move `link`: its own (multiplier 1) and its mimic followers'
  Eigen::Vector3d column = Eigen::Vector3d::Zero();
  for (int k : model.dof_joint_links(dof)) {
    if (!model.IsAncestorOrSelf(k, link)) continue;
    const Link& joint = model.link(k);
    const double m = joint.q_index >= 0 ? 1.0 : joint.mimic_multiplier;
    const Eigen::Vector3d axis = data.axis_WL.col(k);
    column += m * (IsRotational(joint.joint_type) ? axis.cross(p_WP - data.X_WL[k].translation()) : axis);
  }
  return column;
}

void CalcPointJacobianAtWorldPoint(const Model& model, const Data& data, int link, const Eigen::Vector3d& p_WP,
                                   Eigen::Ref<Eigen::Matrix3Xd> J_WP) {
  RMPMARL_DASSERT(J_WP.cols() == model.nq(), "J_WP has the wrong number of columns");
  J_WP.setZero();
  for (int i : model.link_dofs(link)) J_WP.col(i) = CalcPointJacobianColumn(model, data, i, link, p_WP);
}

void CalcPointJacobian(const Model& model, const Data& data, int link, const Eigen::Vector3d& p_LP,
                       Eigen::Ref<Eigen::Matrix3Xd> J_WP) {
  CalcPointJacobianAtWorldPoint(model, data, link, data.X_WL[link] * p_LP, J_WP);
}

Eigen::Vector3d CalcPointVelocityAtWorldPoint(const Data& data, int link, const Eigen::Vector3d& p_WP) {
  RMPMARL_DASSERT(data.has_velocities, "CalcVelocityKinematics must run first");
  return data.v_WLo.col(link) + data.w_WL.col(link).cross(p_WP - data.X_WL[link].translation());
}

Eigen::Vector3d CalcPointJdotQdotAtWorldPoint(const Data& data, int link, const Eigen::Vector3d& p_WP) {
  RMPMARL_DASSERT(data.has_velocities, "CalcVelocityKinematics must run first");
  const Eigen::Vector3d r = p_WP - data.X_WL[link].translation();
  const Eigen::Vector3d w = data.w_WL.col(link);
  return data.a_bias_WLo.col(link) + data.alpha_bias_WL.col(link).cross(r) + w.cross(w.cross(r));
}

Eigen::Vector3d CalcPointVelocity(const Data& data, int link, const Eigen::Vector3d& p_LP) {
  return CalcPointVelocityAtWorldPoint(data, link, data.X_WL[link] * p_LP);
}

Eigen::Vector3d CalcPointJdotQdot(const Data& data, int link, const Eigen::Vector3d& p_LP) {
  return CalcPointJdotQdotAtWorldPoint(data, link, data.X_WL[link] * p_LP);
}

void CheckJointVector(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& v, std::string_view what) {
  if (v.size() != model.nq()) {
    throw InputError(fmt::format("{} for robot '{}': expected {} values (one per joint), got {}", what,
                                 model.name(), model.nq(), v.size()));
  }
  for (int i = 0; i < v.size(); ++i) {
    if (!std::isfinite(v[i])) {
      throw InputError(fmt::format("{} for robot '{}': entry {} (joint '{}') must be finite, got {}", what,
                                   model.name(), i, model.dof_name(i), v[i]));
    }
  }
}

}  // namespace rmpmarl::kinematics
