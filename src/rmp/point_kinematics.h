#pragma once
// Internal helpers of the rmp module: kinematics of a world point taken as fixed on a link (witness points), written
// with world-frame vectors so that no link-frame round trip and no full 3 × nq Jacobian is needed. They follow the
// conventions of kinematics/forward_kinematics.cc (the joint acts at the child link origin, URDF).
#include <Eigen/Core>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/model.h"

namespace rmpmarl::rmp::internal {

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
