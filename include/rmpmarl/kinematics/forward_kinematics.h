#pragma once
/// Forward kinematics, point Jacobians and the J̇q̇ term of points fixed on links. None of these allocate.
#include <Eigen/Core>

#include "rmpmarl/kinematics/model.h"

namespace rmpmarl::kinematics {

/// poses of every link frame (data->X_WL) and joint axes in world (data->axis_W).
/// \pre q.size() == model.nq() (checked by CheckJointVector at API boundaries, debug-asserted here).
void CalcForwardKinematics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q, Data* data);

/// forward kinematics plus every link's angular/linear velocity and its velocity-product (q̈ = 0) acceleration.
void CalcVelocityKinematics(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                            const Eigen::Ref<const Eigen::VectorXd>& qd, Data* data);

/// position of point P, fixed on link `link` at p_LP, in world.  \pre CalcForwardKinematics.
Eigen::Vector3d CalcPointPosition(const Data& data, int link, const Eigen::Vector3d& p_LP);

/// position Jacobian J_WP (3 x nq) of point P fixed on link `link` at p_LP: ṗ_WP = J_WP q̇.
/// Columns of dofs that do not move the link are zero.  \pre CalcForwardKinematics.
void CalcPointJacobian(const Model& model, const Data& data, int link, const Eigen::Vector3d& p_LP,
                       Eigen::Ref<Eigen::Matrix3Xd> J_WP);

/// the same Jacobian evaluated at a world point p_WP treated as fixed on `link` (e.g. a witness point).
void CalcPointJacobianAtWorldPoint(const Model& model, const Data& data, int link, const Eigen::Vector3d& p_WP,
                                   Eigen::Ref<Eigen::Matrix3Xd> J_WP);

/// column `dof` of the position Jacobian of world point p_WP taken as fixed on a link that `dof`'s own joint moves:
/// a × (p_WP − o_J) for a rotational joint, a for a prismatic one. Mimic followers of the dof are not included: use
/// the overload with the link for points that a mimic joint may move.  \pre CalcForwardKinematics.
Eigen::Vector3d CalcPointJacobianColumn(const Model& model, const Data& data, int dof, const Eigen::Vector3d& p_WP);

/// column `dof` of the position Jacobian of world point p_WP fixed on `link`: the sum, over the joints `dof` drives
/// that move `link` (its own joint and its mimic followers, each times its multiplier), of a × (p_WP − o_J) or a;
/// zero when none does. Equals the overload above on robots without mimic joints.  \pre CalcForwardKinematics.
Eigen::Vector3d CalcPointJacobianColumn(const Model& model, const Data& data, int dof, int link,
                                        const Eigen::Vector3d& p_WP);

/// linear velocity of the material point of `link` at world point p_WP.  \pre CalcVelocityKinematics.
Eigen::Vector3d CalcPointVelocityAtWorldPoint(const Data& data, int link, const Eigen::Vector3d& p_WP);

/// J̇q̇ of the material point of `link` at world point p_WP.  \pre CalcVelocityKinematics.
Eigen::Vector3d CalcPointJdotQdotAtWorldPoint(const Data& data, int link, const Eigen::Vector3d& p_WP);

/// J̇q̇ of point P fixed on link `link` at p_LP: its acceleration in world when q̈ = 0.
/// \pre CalcVelocityKinematics.
Eigen::Vector3d CalcPointJdotQdot(const Data& data, int link, const Eigen::Vector3d& p_LP);

/// linear velocity of point P fixed on link `link` at p_LP.  \pre CalcVelocityKinematics.
Eigen::Vector3d CalcPointVelocity(const Data& data, int link, const Eigen::Vector3d& p_LP);

/// throws InputError unless v has model.nq() finite entries; `what` names the vector in the message ("q", "qd").
void CheckJointVector(const Model& model, const Eigen::Ref<const Eigen::VectorXd>& v, std::string_view what);

}  // namespace rmpmarl::kinematics
