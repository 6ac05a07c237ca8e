#pragma once
/// An RMPflow tree (Cheng et al. 2018): the root is the configuration space (dimension nq); every other node is a
/// task space reached from its parent through a task map. The tree is built once from a description (`NodeSpec`s,
/// structure errors rejected with InputError) into an immutable `Tree`; a `TreeData` sized from it holds every buffer
/// of an evaluation, which allocates nothing:
///
///   PushForward(tree, q, q̇, scene, &data);   // kinematics once, then x, ẋ, J, J̇ẏ of every node (parents first)
///   ... write each node's RMP in natural form into data.f(i), data.M(i) (all start at zero) ...
///   PullbackAndResolve(tree, &data, qdd);    // children before parents; q̈ = (M_q + λI)⁻¹ f_q at the root
///
/// Task maps:
///  - JointAffineMap (from the root): x_k = s_k (q[dof_k] − o_k) — identity, selections, normalised joint coordinates.
///  - LinkPointMap (from the root): x = p_WP of a point fixed on a link (3-D); J = J_WP, J̇q̇ exact.
///  - CapsuleObstacleDistanceMap (from the root): x = signed distance between a robot capsule (shape 1) and obstacle
///    slot k of the Scene (math::CapsuleSphereDistance / CapsuleBoxDistance); J = g n_Wᵀ J_WP1 with J_WP1 the
///    Jacobian of the capsule's witness point p_W1 taken as fixed on its link and g the distance's gradient_norm (1
///    except in box penetration); ẋ = g n_Wᵀ (J_WP1 q̇ − v_obstacle).
///  - CapsuleCapsuleDistanceMap (from the root): self distance between two robot capsules, J = n_Wᵀ (J_WP1 − J_WP2),
///    ẋ = J q̇.
///  - AffineMap (from any node): x = A y + b, J = A, J̇ẏ = 0.
/// Curvature terms kept for the distance maps: J̇q̇ = g n_Wᵀ (a_P1 − a_P2), the velocity-product accelerations of
/// the witness points as material points of their links (a_P2 = 0 for an obstacle, which moves at constant
/// velocity). Dropped: the rotation of n_W and the sliding of the witness points over the surfaces (curvature of
/// the shapes), as RMPflow implementations do (they are quadratic in the velocities as well, but need the shapes'
/// curvature at the witness points).
///
/// Distance nodes are skipped (marked inactive, J not computed, nothing pulled back) when the obstacle slot is empty
/// in the Scene or the distance exceeds the node's `cutoff` (use the RMP's deactivation radius r, beyond which its
/// metric is exactly 0). Before computing the exact distance a bounding-sphere lower bound is tested against the
/// cutoff; for a node skipped that way x holds the lower bound (> cutoff) instead of the distance.
#include <Eigen/Core>
#include <limits>
#include <string>
#include <variant>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/rmp/rmp.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::rmp {

/// x_k = scale[k] · (q[dofs[k]] − offset[k]); empty scale/offset mean 1/0.
struct JointAffineMap {
  std::vector<int> dofs;
  std::vector<double> scale;
  std::vector<double> offset;
};

/// x = p_WP, the world position of point P fixed on `link` at p_LP.
struct LinkPointMap {
  int link = -1;
  Eigen::Vector3d p_LP = Eigen::Vector3d::Zero();
};

/// x = signed distance between robot.capsules[capsule] and scene.obstacles[obstacle].
struct CapsuleObstacleDistanceMap {
  int capsule = -1;
  int obstacle = -1;  ///< slot in Scene::obstacles; the node is inactive while the slot is empty
  double cutoff = std::numeric_limits<double>::infinity();  ///< [m] inactive beyond this distance
};

/// x = signed distance between robot.capsules[capsule1] and robot.capsules[capsule2] (on different links).
struct CapsuleCapsuleDistanceMap {
  int capsule1 = -1;
  int capsule2 = -1;
  double cutoff = std::numeric_limits<double>::infinity();  ///< [m] inactive beyond this distance
};

/// x = A y + b where y is the parent's coordinate.
struct AffineMap {
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
};

using TaskMap = std::variant<JointAffineMap, LinkPointMap, CapsuleObstacleDistanceMap, CapsuleCapsuleDistanceMap,
                             AffineMap>;

/// One node of a tree description: a unique non-empty name, the parent's name ("" for the root = C-space) and the map.
struct NodeSpec {
  std::string name;
  std::string parent;
  TaskMap map;
};

/// The type of a node's task map (index of TaskMap's alternative).
enum class TaskMapType { kJointAffine, kLinkPoint, kCapsuleObstacleDistance, kCapsuleCapsuleDistance, kAffine };

class TreeData;

/// An immutable RMPflow tree over a robot.
class Tree {
 public:
  /// builds and validates the tree; throws InputError for empty or duplicate names, a missing parent, a cycle, a
  /// kinematic map whose parent is not the root, wrong dimensions (A's columns vs the parent's dimension, sizes of
  /// scale/offset), out-of-range links/capsules/dofs or a negative obstacle slot.
  Tree(const kinematics::Robot& robot, std::vector<NodeSpec> nodes);

  const kinematics::Robot& robot() const { return robot_; }
  int nq() const { return robot_.model.nq(); }
  int num_nodes() const { return static_cast<int>(nodes_.size()); }
  /// node index of `name`, or -1.
  int FindNode(std::string_view name) const;
  const std::string& name(int node) const { return nodes_[node].spec.name; }
  /// parent node index, -1 for the root.
  int parent(int node) const { return nodes_[node].parent; }
  int dim(int node) const { return nodes_[node].dim; }
  /// dimension of the parent's space (nq for children of the root).
  int parent_dim(int node) const { return nodes_[node].parent_dim; }
  TaskMapType type(int node) const { return static_cast<TaskMapType>(nodes_[node].spec.map.index()); }
  const TaskMap& map(int node) const { return nodes_[node].spec.map; }
  /// node indices with parents before children.
  const std::vector<int>& topological_order() const { return order_; }

 private:
  friend void PushForward(const Tree&, const Eigen::Ref<const Eigen::VectorXd>&,
                          const Eigen::Ref<const Eigen::VectorXd>&, const Scene&, TreeData*);
  friend void Pullback(const Tree&, TreeData*);

  struct Node {
    NodeSpec spec;
    int parent = -1;
    int dim = 0;
    int parent_dim = 0;
  };
  // what the evaluation loops read, packed (one cache line per node), in topological order
  struct Flat {
    int node = -1;
    int parent = -1;
    TaskMapType type = TaskMapType::kJointAffine;
    int dim = 0;
    int capsule1 = -1, capsule2 = -1, link1 = -1, link2 = -1, obstacle = -1;
    double cutoff = 0.0;
  };
  kinematics::Robot robot_;
  std::vector<Node> nodes_;
  std::vector<int> order_;
  std::vector<Flat> flat_;
};

void PushForward(const Tree& tree, const Eigen::Ref<const Eigen::VectorXd>& q,
                 const Eigen::Ref<const Eigen::VectorXd>& qd, const Scene& scene, TreeData* data);
void Pullback(const Tree& tree, TreeData* data);
void PullbackAndResolve(const Tree& tree, TreeData* data, Eigen::Ref<Eigen::VectorXd> qdd);

/// Every buffer of a tree evaluation, sized once from a Tree. Node quantities are views into one arena.
class TreeData {
 public:
  /// sizes every buffer for `tree`; `resolve` configures PullbackAndResolve's regulariser.
  explicit TreeData(const Tree& tree, const ResolveOptions& resolve = {});

  kinematics::Data kinematics;  ///< computed once per evaluation by PushForward (CalcVelocityKinematics)

  /// node coordinate x (PushForward).
  Eigen::Map<Eigen::VectorXd> x(int node) { return Vec(node_[node].x_off, node_[node].dim); }
  /// node velocity ẋ (PushForward).
  Eigen::Map<Eigen::VectorXd> xd(int node) { return Vec(node_[node].xd_off, node_[node].dim); }
  /// curvature term J̇ẏ of the node's map, ẏ the parent's velocity (PushForward).
  Eigen::Map<Eigen::VectorXd> Jdot_qd(int node) { return Vec(node_[node].jdqd_off, node_[node].dim); }
  /// Jacobian of the node's map w.r.t. its parent's coordinate, dim × parent_dim (PushForward; not computed for
  /// inactive nodes, and for JointAffine nodes only the selected entries are meaningful — the others stay zero).
  Eigen::Map<Eigen::MatrixXd> J(int node) { return Mat(node_[node].J_off, node_[node].dim, node_[node].parent_dim); }
  /// the node's RMP force f (natural form), zeroed by PushForward, written by the caller, accumulated by Pullback.
  Eigen::Map<Eigen::VectorXd> f(int node) { return Vec(node_[node].f_off, node_[node].dim); }
  /// the node's RMP metric M, zeroed by PushForward, written by the caller, accumulated by Pullback.
  Eigen::Map<Eigen::MatrixXd> M(int node) { return Mat(node_[node].M_off, node_[node].dim, node_[node].dim); }
  Eigen::Map<const Eigen::VectorXd> x(int node) const { return CVec(node_[node].x_off, node_[node].dim); }
  Eigen::Map<const Eigen::VectorXd> xd(int node) const { return CVec(node_[node].xd_off, node_[node].dim); }
  Eigen::Map<const Eigen::VectorXd> Jdot_qd(int node) const { return CVec(node_[node].jdqd_off, node_[node].dim); }
  Eigen::Map<const Eigen::MatrixXd> J(int node) const {
    return CMat(node_[node].J_off, node_[node].dim, node_[node].parent_dim);
  }
  Eigen::Map<const Eigen::VectorXd> f(int node) const { return CVec(node_[node].f_off, node_[node].dim); }
  Eigen::Map<const Eigen::MatrixXd> M(int node) const {
    return CMat(node_[node].M_off, node_[node].dim, node_[node].dim);
  }
  /// false when the node was skipped this evaluation (empty obstacle slot, beyond cutoff, inactive parent, or
  /// disabled).
  bool active(int node) const { return active_[node] != 0; }
  /// a disabled node and its subtree are skipped by PushForward (inactive) until enabled again: nothing of them is
  /// computed or pulled back, as for a leaf whose RMP is zero. Every node starts enabled.
  void set_enabled(int node, bool enabled) { enabled_[node] = enabled ? 1 : 0; }
  /// witness points and normal of a distance node (PushForward; meaningful while the node is active).
  const math::DistanceResult& distance(int node) const { return distance_[node]; }

  Eigen::VectorXd f_root;  ///< Σ pulled-back forces in C-space (Pullback)
  Eigen::MatrixXd M_root;  ///< Σ pulled-back metrics in C-space (Pullback)
  double lambda = 0.0;     ///< regulariser of the last resolve

 private:
  friend void PushForward(const Tree&, const Eigen::Ref<const Eigen::VectorXd>&,
                          const Eigen::Ref<const Eigen::VectorXd>&, const Scene&, TreeData*);
  friend void Pullback(const Tree&, TreeData*);
  friend void PullbackAndResolve(const Tree&, TreeData*, Eigen::Ref<Eigen::VectorXd>);

  Eigen::Map<Eigen::VectorXd> Vec(int off, int n) { return Eigen::Map<Eigen::VectorXd>(arena_.data() + off, n); }
  Eigen::Map<Eigen::MatrixXd> Mat(int off, int r, int c) {
    return Eigen::Map<Eigen::MatrixXd>(arena_.data() + off, r, c);
  }
  Eigen::Map<const Eigen::VectorXd> CVec(int off, int n) const {
    return Eigen::Map<const Eigen::VectorXd>(arena_.data() + off, n);
  }
  Eigen::Map<const Eigen::MatrixXd> CMat(int off, int r, int c) const {
    return Eigen::Map<const Eigen::MatrixXd>(arena_.data() + off, r, c);
  }

  struct NodeLayout {
    int dim = 0, parent_dim = 0;
    int x_off = 0, xd_off = 0, jdqd_off = 0, f_off = 0, M_off = 0, J_off = 0;
  };
  std::vector<NodeLayout> node_;
  std::vector<double> arena_;  // [x, ẋ, J̇ẏ of every node][f, M of every node (zeroed at once)][J of every node]
  int fm_begin_ = 0, fm_end_ = 0;
  std::vector<char> active_;
  std::vector<char> enabled_;
  // per node: a distance node's 1-D Jacobian row is zero from this dof on (past the last dof that moves one of its
  // links); nq for every other node
  std::vector<int> row_end_;
  std::vector<math::DistanceResult> distance_;
  // per evaluation: world capsules with bounding spheres, obstacle bounding spheres (broad phase)
  std::vector<math::Capsule> capsule_W_;
  std::vector<Eigen::Vector4d> capsule_sphere_;   // centre, radius
  std::vector<Eigen::Vector4d> obstacle_sphere_;  // centre, radius, per obstacle slot
  std::vector<int> used_capsules_;
  int num_slots_ = 0;
  Eigen::Matrix3Xd dof_origin_W_;     // per evaluation: origin of every dof's joint in W
  std::vector<char> dof_prismatic_;   // per dof: prismatic joint
  RmpResolver resolver_;
};

/// forward pass: kinematics (CalcVelocityKinematics) once, then x, ẋ, J, J̇ẏ of every node, parents first; zeroes
/// every node's (f, M). Allocates nothing.  \pre q, qd have nq entries (debug-checked); scene.obstacles holds valid
/// obstacles (ValidateScene; not rechecked here).
void PushForward(const Tree& tree, const Eigen::Ref<const Eigen::VectorXd>& q,
                 const Eigen::Ref<const Eigen::VectorXd>& qd, const Scene& scene, TreeData* data);

/// backward pass: pulls every active node's (f, M) back into its parent (children first), ending in data->f_root,
/// data->M_root. Allocates nothing.  \pre PushForward, then the RMPs written.
void Pullback(const Tree& tree, TreeData* data);

/// Pullback, then q̈ = (M_root + λI)⁻¹ f_root (rmp.h's regulariser, the resolve options given at TreeData
/// construction). Allocates nothing.  \pre PushForward, then the RMPs written.
void PullbackAndResolve(const Tree& tree, TreeData* data, Eigen::Ref<Eigen::VectorXd> qdd);

}  // namespace rmpmarl::rmp
