#pragma once
// Internal helpers of the rmp module: kinematics of a world point taken as fixed on a link (witness points), written
// with world-frame vectors so that no link-frame round trip and no full 3 × nq Jacobian is needed. They follow the
// conventions of kinematics/forward_kinematics.cc (the joint acts at the child link origin, URDF).
#include <Eigen/Core>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/model.h"

namespace rmpmarl::rmp::internal {

// column `dof` of the position Jacobian of world point p_W fixed on a link that `dof` moves.
inline Eigen::Vector3d PointJacobianColumn(const kinematics::Model& model, const kinematics::Data& kin, int dof,
                                           const Eigen::Vector3d& p_W) {
  const int joint_link = model.dof_link(dof);
  const Eigen::Vector3d axis = kin.axis_W.col(dof);
  if (model.link(joint_link).joint_type == kinematics::JointType::kPrismatic) return axis;
  return axis.cross(p_W - kin.X_WL[joint_link].translation());
}

// row += sign · nᵀ J_WP for world point p_W fixed on `link` (only the dofs moving the link are touched):
// nᵀ (a × r) = a · (r × n) for a revolute axis a, nᵀ a for a prismatic one.
inline void AddDistanceJacobianRow(const kinematics::Model& model, const kinematics::Data& kin, int link,
                                   const Eigen::Vector3d& p_W, const Eigen::Vector3d& n, double sign, double* row) {
  for (int dof : model.link_dofs(link)) {
    const int joint_link = model.dof_link(dof);
    const Eigen::Vector3d axis = kin.axis_W.col(dof);
    if (model.link(joint_link).joint_type == kinematics::JointType::kPrismatic) {
      row[dof] += sign * axis.dot(n);
    } else {
      row[dof] += sign * axis.dot((p_W - kin.X_WL[joint_link].translation()).cross(n));
    }
  }
}

// the same row update with per-dof joint origins o_W (3 × nq) and prismatic flags gathered once per evaluation.
inline void AddDistanceJacobianRow(const kinematics::Model& model, const kinematics::Data& kin,
                                   const Eigen::Matrix3Xd& origin_W, const std::vector<char>& prismatic, int link,
                                   const Eigen::Vector3d& p_W, const Eigen::Vector3d& n, double sign, double* row) {
  for (int dof : model.link_dofs(link)) {
    const Eigen::Vector3d axis = kin.axis_W.col(dof);
    row[dof] += sign * (prismatic[dof] ? axis.dot(n) : axis.dot((p_W - origin_W.col(dof)).cross(n)));
  }
}

// linear velocity of the material point of `link` at world point p_W.  \pre CalcVelocityKinematics.
inline Eigen::Vector3d MaterialPointVelocity(const kinematics::Data& kin, int link, const Eigen::Vector3d& p_W) {
  return kin.v_WLo.col(link) + kin.w_WL.col(link).cross(p_W - kin.X_WL[link].translation());
}

// velocity-product acceleration (J̇q̇) of the material point of `link` at world point p_W.
// \pre CalcVelocityKinematics.
inline Eigen::Vector3d MaterialPointJdotQdot(const kinematics::Data& kin, int link, const Eigen::Vector3d& p_W) {
  const Eigen::Vector3d r = p_W - kin.X_WL[link].translation();
  const Eigen::Vector3d w = kin.w_WL.col(link);
  return kin.a_bias_WLo.col(link) + kin.alpha_bias_WL.col(link).cross(r) + w.cross(w.cross(r));
}

}  // namespace rmpmarl::rmp::internal
