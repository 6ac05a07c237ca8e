#pragma once
// Internal helpers of the rmp module: kinematics of a world point taken as fixed on a link (witness points), written
// with world-frame vectors so that no link-frame round trip and no full 3 × nq Jacobian is needed. They follow the
// conventions of kinematics/forward_kinematics.cc (the joint acts at the child link origin, URDF).
#include <Eigen/Core>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/model.h"

namespace rmpmarl::rmp::internal {

// kinematics::CalcPointJacobianColumn(model, kin, dof, link, p_W) inline, the same arithmetic: a × (p_W − o_J) for
// the rotational joint of `dof`, a for a prismatic one (the general column where mimic joints exist)
inline Eigen::Vector3d PointJacobianColumn(const kinematics::Model& model, const kinematics::Data& kin, int dof,
                                           int link, const Eigen::Vector3d& p_W) {
  if (model.has_mimic_joints()) return kinematics::CalcPointJacobianColumn(model, kin, dof, link, p_W);
  const int joint_link = model.dof_link(dof);
  const Eigen::Vector3d axis = kin.axis_W.col(dof);
  const kinematics::JointType type = model.link(joint_link).joint_type;
  if (type != kinematics::JointType::kRevolute && type != kinematics::JointType::kContinuous) return axis;
  return axis.cross(p_W - kin.X_WL[joint_link].translation());
}

// row += sign · nᵀ J_WP for world point p_W fixed on `link` (only the dofs moving the link are touched), with per-dof
// joint origins o_W (3 × nq) and prismatic flags gathered once per evaluation:
// nᵀ (a × r) = a · (r × n) for a revolute axis a, nᵀ a for a prismatic one.
inline void AddDistanceJacobianRow(const kinematics::Model& model, const kinematics::Data& kin,
                                   const Eigen::Matrix3Xd& origin_W, const std::vector<char>& prismatic, int link,
                                   const Eigen::Vector3d& p_W, const Eigen::Vector3d& n, double sign, double* row) {
  if (model.has_mimic_joints()) {  // a dof may drive several joints: the general column
    for (int dof : model.link_dofs(link)) {
      row[dof] += sign * n.dot(kinematics::CalcPointJacobianColumn(model, kin, dof, link, p_W));
    }
    return;
  }
  for (int dof : model.link_dofs(link)) {
    const Eigen::Vector3d axis = kin.axis_W.col(dof);
    row[dof] += sign * (prismatic[dof] ? axis.dot(n) : axis.dot((p_W - origin_W.col(dof)).cross(n)));
  }
}

}  // namespace rmpmarl::rmp::internal
