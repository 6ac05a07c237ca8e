#pragma once
/// Immutable kinematic model of a robot (a tree of links joined by revolute, continuous, prismatic or fixed joints)
/// and its preallocated Data. Algorithms are free functions over (const Model&, Data*) — see forward_kinematics.h.
///
/// Layout (like Pinocchio/RBDL): links are numbered in topological order, link 0 is the root (fixed to the world,
/// X_WL0 = identity). Every link k > 0 hangs from `links[k].parent` through exactly one joint, stored with the link.
/// Per URDF, the joint frame J coincides with the child link frame L at q = 0: X_PL(q) = X_PJ · motion(axis_J, q).
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
  int q_index = -1;                ///< index of the joint's coordinate in q, -1 for fixed joints and the root
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
};

/// Mutable buffers of the kinematics algorithms, sized once from a Model. No algorithm allocates.
struct Data {
  explicit Data(const Model& model);
  std::vector<Eigen::Isometry3d> X_WL;  ///< pose of every link frame in world (CalcForwardKinematics)
  Eigen::Matrix3Xd axis_W;              ///< per dof: joint axis in world (CalcForwardKinematics), 3 x nq
  Eigen::Matrix3Xd w_WL;                ///< per link: angular velocity in world (CalcVelocityKinematics)
  Eigen::Matrix3Xd v_WLo;               ///< per link: velocity of the link origin in world (CalcVelocityKinematics)
  Eigen::Matrix3Xd alpha_bias_WL;       ///< per link: angular acceleration at q̈ = 0 (CalcVelocityKinematics)
  Eigen::Matrix3Xd a_bias_WLo;          ///< per link: acceleration of the origin at q̈ = 0 (CalcVelocityKinematics)
  bool has_velocities = false;          ///< true after CalcVelocityKinematics, false after CalcForwardKinematics
};

}  // namespace rmpmarl::kinematics
