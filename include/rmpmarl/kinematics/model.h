#pragma once
/// Immutable kinematic model of a robot (a tree of links joined by revolute, continuous, prismatic or fixed joints)
/// and its preallocated Data. Algorithms are free functions over (const Model&, Data*) — see forward_kinematics.h.
///
/// Layout (like Pinocchio/RBDL): links are numbered in topological order, link 0 is the root (fixed to the world,
/// X_WL0 = identity). Every link k > 0 hangs from `links[k].parent` through exactly one joint, stored with the link.
/// Per URDF, the joint frame J coincides with the child link frame L at q = 0: X_PL(q) = X_PJ · motion(axis_J, q).
///
/// Mimic joints (URDF `<mimic joint= multiplier= offset=>`) have no coordinate of their own: their joint value is
/// multiplier · q[mimic_dof] + offset, so q holds the independent dofs only, and every Jacobian column of a dof sums
/// the contributions of the joint that owns it and of its followers (CalcPointJacobianColumn).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <string_view>
#include <vector>

namespace rmpmarl::kinematics {

enum class JointType { kFixed, kRevolute, kContinuous, kPrismatic };

/// name of a joint type as in URDF ("fixed", "revolute", ...).
std::string_view JointTypeName(JointType type);

/// A link together with the joint that attaches it to its parent (unused for the root link).
struct Link {
  std::string name;
  int parent = -1;                 ///< parent link index, -1 for the root
  std::string joint_name;          ///< name of the joint from the parent ("" for the root)
  JointType joint_type = JointType::kFixed;
  Eigen::Isometry3d X_PJ = Eigen::Isometry3d::Identity();  ///< joint frame in the parent link frame (URDF origin)
  Eigen::Vector3d axis_J = Eigen::Vector3d::UnitZ();       ///< unit joint axis in the joint (= child link) frame
  int q_index = -1;                ///< index of the joint's coordinate in q, -1 for fixed and mimic joints and the root
  /// mimic joints: the dof they follow (-1 for every other joint); value = mimic_multiplier · q[mimic_dof] + offset
  int mimic_dof = -1;
  double mimic_multiplier = 1.0;
  double mimic_offset = 0.0;
  /// true when the joint moves (revolute, continuous, prismatic; mimic joints included)
  bool moving() const { return joint_type != JointType::kFixed; }
  /// the dof that drives this joint (q_index, or mimic_dof for a mimic joint; -1 for fixed joints)
  int driving_dof() const { return q_index >= 0 ? q_index : mimic_dof; }
};

/// Limits of one degree of freedom (from the URDF `<limit>`; continuous joints get ±inf position limits).
struct DofLimits {
  double lower = 0.0;
  double upper = 0.0;
  double velocity = 0.0;  ///< |q̇| bound
  double effort = 0.0;
};

/// The immutable kinematic model.
class Model {
 public:
  Model() = default;
  /// builds a model from links in topological order (parents before children, link 0 the root); validates it.
  Model(std::string name, std::vector<Link> links, std::vector<DofLimits> limits);

  const std::string& name() const { return name_; }
  int nq() const { return static_cast<int>(limits_.size()); }
  int num_links() const { return static_cast<int>(links_.size()); }
  const std::vector<Link>& links() const { return links_; }
  const Link& link(int k) const { return links_[k]; }
  const std::vector<DofLimits>& limits() const { return limits_; }
  /// link index carrying dof i (its joint moves that link).
  int dof_link(int i) const { return dof_link_[i]; }
  /// name of the joint of dof i.
  const std::string& dof_name(int i) const { return links_[dof_link_[i]].joint_name; }
  /// true when dof i moves link k (the joint is link k's own or an ancestor's).
  bool DofMovesLink(int i, int k) const { return supports_[k * nq() + i] != 0; }
  /// dofs that move link k, ascending.
  const std::vector<int>& link_dofs(int k) const { return link_dofs_[k]; }
  /// links whose joints dof i drives: its own joint's link first, then its mimic followers' (tree order).
  const std::vector<int>& dof_joint_links(int i) const { return dof_joint_links_[i]; }
  /// true when some joint is a mimic joint.
  bool has_mimic_joints() const { return has_mimic_; }
  /// true when link a is link k or one of its ancestors.
  bool IsAncestorOrSelf(int a, int k) const { return ancestor_[static_cast<size_t>(k) * num_links() + a] != 0; }
  /// the joint value of link k's joint for the independent coordinates q (0 for fixed joints and the root).
  double JointValue(int k, const Eigen::Ref<const Eigen::VectorXd>& q) const {
    const Link& l = links_[k];
    if (l.q_index >= 0) return q[l.q_index];
    if (l.mimic_dof >= 0) return l.mimic_multiplier * q[l.mimic_dof] + l.mimic_offset;
    return 0.0;
  }
  /// index of the link called `name`; throws InputError listing the known links when absent.
  int LinkIndex(std::string_view name) const;
  /// index of the link called `name`, or -1.
  int FindLink(std::string_view name) const;
  Eigen::VectorXd LowerLimits() const;
  Eigen::VectorXd UpperLimits() const;
  Eigen::VectorXd VelocityLimits() const;

 private:
  std::string name_;
  std::vector<Link> links_;
  std::vector<DofLimits> limits_;
  std::vector<int> dof_link_;
  std::vector<char> supports_;            // num_links x nq, row-major
  std::vector<std::vector<int>> link_dofs_;
  std::vector<std::vector<int>> dof_joint_links_;
  std::vector<char> ancestor_;            // num_links x num_links, row k: the ancestors of k and k itself
  bool has_mimic_ = false;
};

/// Mutable buffers of the kinematics algorithms, sized once from a Model. No algorithm allocates.
struct Data {
  explicit Data(const Model& model);
  std::vector<Eigen::Isometry3d> X_WL;  ///< pose of every link frame in world (CalcForwardKinematics)
  Eigen::Matrix3Xd axis_W;              ///< per dof: its own joint's axis in world (CalcForwardKinematics), 3 x nq
  Eigen::Matrix3Xd axis_WL;             ///< per link: its joint's axis in world, zero for fixed joints, 3 x links
  Eigen::Matrix3Xd w_WL;                ///< per link: angular velocity in world (CalcVelocityKinematics)
  Eigen::Matrix3Xd v_WLo;               ///< per link: velocity of the link origin in world (CalcVelocityKinematics)
  Eigen::Matrix3Xd alpha_bias_WL;       ///< per link: angular acceleration at q̈ = 0 (CalcVelocityKinematics)
  Eigen::Matrix3Xd a_bias_WLo;          ///< per link: acceleration of the origin at q̈ = 0 (CalcVelocityKinematics)
  bool has_velocities = false;          ///< true after CalcVelocityKinematics, false after CalcForwardKinematics
};

}  // namespace rmpmarl::kinematics
