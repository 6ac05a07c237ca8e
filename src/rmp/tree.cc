// RMPflow tree: validated build, allocation-free pushforward, pullback and resolve.
#include "rmpmarl/rmp/tree.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include "point_kinematics.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {
namespace {

[[noreturn]] void Fail(const NodeSpec& node, const std::string& message) {
  throw InputError(fmt::format("RMP tree: node '{}': {}", node.name, message));
}

bool AllFinite(const std::vector<double>& v) {
  return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
}

// validates a map that reads q (its parent must be the root); returns its dimension.
int CheckKinematicMap(const NodeSpec& node, int parent, const kinematics::Robot& robot) {
  if (parent != -1) Fail(node, fmt::format("a kinematic task map takes q: its parent must be the root (\"\"), got '{}'",
                                           node.parent));
  const int nq = robot.model.nq();
  const int num_capsules = static_cast<int>(robot.capsules.size());
  auto check_capsule = [&](int c, std::string_view key) {
    if (c < 0 || c >= num_capsules) {
      Fail(node, fmt::format("{} {} out of range (robot '{}' has {} capsules)", key, c, robot.name, num_capsules));
    }
  };
  auto check_cutoff = [&](double cutoff) {
    if (!(cutoff > 0.0)) Fail(node, fmt::format("cutoff must be > 0 (or +inf), got {}", cutoff));
  };
  if (const auto* m = std::get_if<JointAffineMap>(&node.map)) {
    if (m->dofs.empty()) Fail(node, "joint map needs at least one dof");
    for (int d : m->dofs) {
      if (d < 0 || d >= nq) Fail(node, fmt::format("dof {} out of range (robot '{}' has nq = {})", d, robot.name, nq));
    }
    if (!m->scale.empty() && m->scale.size() != m->dofs.size()) {
      Fail(node, fmt::format("wrong dimensions: {} dofs but {} scales", m->dofs.size(), m->scale.size()));
    }
    if (!m->offset.empty() && m->offset.size() != m->dofs.size()) {
      Fail(node, fmt::format("wrong dimensions: {} dofs but {} offsets", m->dofs.size(), m->offset.size()));
    }
    if (!AllFinite(m->scale) || !AllFinite(m->offset)) Fail(node, "scale and offset must be finite");
    return static_cast<int>(m->dofs.size());
  }
  if (const auto* m = std::get_if<LinkPointMap>(&node.map)) {
    if (m->link < 0 || m->link >= robot.model.num_links()) {
      Fail(node, fmt::format("link {} out of range (robot '{}' has {} links)", m->link, robot.name,
                             robot.model.num_links()));
    }
    if (!m->p_LP.allFinite()) Fail(node, "p_LP must be finite");
    return 3;
  }
  if (const auto* m = std::get_if<CapsuleObstacleDistanceMap>(&node.map)) {
    check_capsule(m->capsule, "capsule");
    if (m->obstacle < 0) Fail(node, fmt::format("obstacle slot must be >= 0, got {}", m->obstacle));
    check_cutoff(m->cutoff);
    return 1;
  }
  const auto& m = std::get<CapsuleCapsuleDistanceMap>(node.map);
  check_capsule(m.capsule1, "capsule1");
  check_capsule(m.capsule2, "capsule2");
  if (robot.capsules[m.capsule1].link == robot.capsules[m.capsule2].link) {
    Fail(node, fmt::format("capsules {} and {} are on the same link (their distance is constant)", m.capsule1,
                           m.capsule2));
  }
  check_cutoff(m.cutoff);
  return 1;
}

}  // namespace

Tree::Tree(const kinematics::Robot& robot, std::vector<NodeSpec> nodes) : robot_(robot) {
  const int n = static_cast<int>(nodes.size());
  std::unordered_map<std::string, int> index;
  for (int i = 0; i < n; ++i) {
    if (nodes[i].name.empty()) throw InputError(fmt::format("RMP tree: node {} has an empty name", i));
    if (!index.emplace(nodes[i].name, i).second) {
      throw InputError(fmt::format("RMP tree: duplicate node name '{}'", nodes[i].name));
    }
  }
  nodes_.resize(n);
  for (int i = 0; i < n; ++i) {
    nodes_[i].spec = std::move(nodes[i]);
    const std::string& parent = nodes_[i].spec.parent;
    if (parent.empty()) {
      nodes_[i].parent = -1;
    } else {
      const auto it = index.find(parent);
      if (it == index.end()) Fail(nodes_[i].spec, fmt::format("parent '{}' not found", parent));
      if (it->second == i) Fail(nodes_[i].spec, "a node cannot be its own parent");
      nodes_[i].parent = it->second;
    }
  }
  // depth of every node; a walk up that revisits a node of the current walk is a cycle
  std::vector<int> depth(n, -1), on_walk(n, 0);
  std::vector<int> walk;
  for (int i = 0; i < n; ++i) {
    walk.clear();
    int k = i;
    while (k >= 0 && depth[k] < 0) {
      if (on_walk[k]) Fail(nodes_[k].spec, "the parent links form a cycle");
      on_walk[k] = 1;
      walk.push_back(k);
      k = nodes_[k].parent;
    }
    int d = k < 0 ? 0 : depth[k] + 1;
    for (auto it = walk.rbegin(); it != walk.rend(); ++it) {
      depth[*it] = d++;
      on_walk[*it] = 0;
    }
  }
  order_.resize(n);
  for (int i = 0; i < n; ++i) order_[i] = i;
  std::stable_sort(order_.begin(), order_.end(), [&](int a, int b) { return depth[a] < depth[b]; });

  const int nq = robot_.model.nq();
  for (int i : order_) {
    Node& node = nodes_[i];
    node.parent_dim = node.parent < 0 ? nq : nodes_[node.parent].dim;
    if (auto* m = std::get_if<AffineMap>(&node.spec.map)) {
      if (m->A.rows() < 1) Fail(node.spec, "affine map needs at least one row");
      if (m->A.cols() != node.parent_dim) {
        Fail(node.spec, fmt::format("wrong dimensions: A has {} columns but the parent '{}' has dimension {}",
                                    m->A.cols(), node.spec.parent.empty() ? "root" : node.spec.parent,
                                    node.parent_dim));
      }
      if (m->b.size() != m->A.rows()) {
        Fail(node.spec, fmt::format("wrong dimensions: A has {} rows but b has {} entries", m->A.rows(), m->b.size()));
      }
      if (!m->A.allFinite() || !m->b.allFinite()) Fail(node.spec, "A and b must be finite");
      node.dim = static_cast<int>(m->A.rows());
    } else {
      node.dim = CheckKinematicMap(node.spec, node.parent, robot_);
      if (auto* j = std::get_if<JointAffineMap>(&node.spec.map)) {
        if (j->scale.empty()) j->scale.assign(j->dofs.size(), 1.0);
        if (j->offset.empty()) j->offset.assign(j->dofs.size(), 0.0);
      }
    }
  }
  flat_.reserve(n);
  for (int i : order_) {
    const Node& node = nodes_[i];
    Flat f;
    f.node = i;
    f.parent = node.parent;
    f.type = static_cast<TaskMapType>(node.spec.map.index());
    f.dim = node.dim;
    if (const auto* m = std::get_if<CapsuleObstacleDistanceMap>(&node.spec.map)) {
      f.capsule1 = m->capsule;
      f.link1 = robot_.capsules[m->capsule].link;
      f.obstacle = m->obstacle;
      f.cutoff = m->cutoff;
    } else if (const auto* c = std::get_if<CapsuleCapsuleDistanceMap>(&node.spec.map)) {
      f.capsule1 = c->capsule1;
      f.capsule2 = c->capsule2;
      f.link1 = robot_.capsules[c->capsule1].link;
      f.link2 = robot_.capsules[c->capsule2].link;
      f.cutoff = c->cutoff;
    }
    flat_.push_back(f);
  }
}

int Tree::FindNode(std::string_view name) const {
  for (int i = 0; i < num_nodes(); ++i) {
    if (nodes_[i].spec.name == name) return i;
  }
  return -1;
}

TreeData::TreeData(const Tree& tree, const ResolveOptions& resolve)
    : kinematics(tree.robot().model),
      f_root(Eigen::VectorXd::Zero(tree.nq())),
      M_root(Eigen::MatrixXd::Zero(tree.nq(), tree.nq())),
      resolver_(tree.nq(), resolve) {
  const int n = tree.num_nodes();
  node_.resize(n);
  int off = 0;
  for (int i = 0; i < n; ++i) {
    NodeLayout& l = node_[i];
    l.dim = tree.dim(i);
    l.parent_dim = tree.parent_dim(i);
    l.x_off = off;
    l.xd_off = off + l.dim;
    l.jdqd_off = off + 2 * l.dim;
    off += 3 * l.dim;
  }
  fm_begin_ = off;
  for (int i = 0; i < n; ++i) {
    NodeLayout& l = node_[i];
    l.f_off = off;
    l.M_off = off + l.dim;
    off += l.dim + l.dim * l.dim;
  }
  fm_end_ = off;
  for (int i = 0; i < n; ++i) {
    node_[i].J_off = off;
    off += node_[i].dim * node_[i].parent_dim;
  }
  arena_.assign(off, 0.0);
  active_.assign(n, 0);
  enabled_.assign(n, 1);
  distance_.resize(n);
  const kinematics::Robot& robot = tree.robot();
  capsule_W_.resize(robot.capsules.size());
  capsule_sphere_.resize(robot.capsules.size());
  std::vector<char> used(robot.capsules.size(), 0);
  for (int i = 0; i < n; ++i) {
    if (const auto* m = std::get_if<JointAffineMap>(&tree.map(i))) {
      // constant Jacobians of the affine maps
      for (size_t k = 0; k < m->dofs.size(); ++k) J(i)(static_cast<int>(k), m->dofs[k]) = m->scale[k];
    } else if (const auto* a = std::get_if<AffineMap>(&tree.map(i))) {
      J(i) = a->A;
    } else if (const auto* d = std::get_if<CapsuleObstacleDistanceMap>(&tree.map(i))) {
      used[d->capsule] = 1;
      num_slots_ = std::max(num_slots_, d->obstacle + 1);
    } else if (const auto* c = std::get_if<CapsuleCapsuleDistanceMap>(&tree.map(i))) {
      used[c->capsule1] = used[c->capsule2] = 1;
    }
  }
  for (int c = 0; c < static_cast<int>(used.size()); ++c) {
    if (used[c]) used_capsules_.push_back(c);
  }
  row_end_.assign(n, tree.nq());
  auto end_of = [&](int link) {  // one past the last dof that moves the link (link_dofs is ascending)
    const std::vector<int>& dofs = robot.model.link_dofs(link);
    return dofs.empty() ? 0 : dofs.back() + 1;
  };
  for (int i = 0; i < n; ++i) {
    if (const auto* d = std::get_if<CapsuleObstacleDistanceMap>(&tree.map(i))) {
      row_end_[i] = end_of(robot.capsules[d->capsule].link);
    } else if (const auto* c = std::get_if<CapsuleCapsuleDistanceMap>(&tree.map(i))) {
      row_end_[i] = std::max(end_of(robot.capsules[c->capsule1].link), end_of(robot.capsules[c->capsule2].link));
    }
  }
  obstacle_sphere_.resize(num_slots_);
  const kinematics::Model& model = robot.model;
  dof_origin_W_.setZero(3, model.nq());
  dof_prismatic_.resize(model.nq());
  for (int i = 0; i < model.nq(); ++i) {
    dof_prismatic_[i] = model.link(model.dof_link(i)).joint_type == kinematics::JointType::kPrismatic;
  }
}

void PushForward(const Tree& tree, const Eigen::Ref<const Eigen::VectorXd>& q,
                 const Eigen::Ref<const Eigen::VectorXd>& qd, const Scene& scene, TreeData* data) {
  const kinematics::Robot& robot = tree.robot();
  const kinematics::Model& model = robot.model;
  RMPMARL_DASSERT(q.size() == model.nq() && qd.size() == model.nq(), "PushForward: q or qd has the wrong size");
  kinematics::Data& kin = data->kinematics;
  kinematics::CalcVelocityKinematics(model, q, qd, &kin);
  std::fill(data->arena_.begin() + data->fm_begin_, data->arena_.begin() + data->fm_end_, 0.0);
  for (int i = 0; i < model.nq(); ++i) data->dof_origin_W_.col(i) = kin.X_WL[model.dof_link(i)].translation();

  // broad phase: bounding spheres of the capsules in use and of the obstacles in the scene's slots
  for (int c : data->used_capsules_) {
    const kinematics::LinkCapsule& lc = robot.capsules[c];
    const Eigen::Isometry3d& X_WL = kin.X_WL[lc.link];
    math::Capsule& capsule = data->capsule_W_[c];
    capsule = {X_WL * lc.p_LA, X_WL * lc.p_LB, lc.radius};
    data->capsule_sphere_[c] << 0.5 * (capsule.p_WA + capsule.p_WB),
        0.5 * (capsule.p_WB - capsule.p_WA).norm() + capsule.radius;
  }
  const int num_obstacles = std::min(static_cast<int>(scene.obstacles.size()), data->num_slots_);
  for (int s = 0; s < num_obstacles; ++s) data->obstacle_sphere_[s] = BoundingSphere(scene.obstacles[s]);
  // a pair is skipped when its bounding spheres are farther apart than the cutoff (compared squared, so that the
  // branch does not wait for the square root; the root only feeds x, a lower bound of the distance)
  auto beyond = [](const Eigen::Vector4d& a, const Eigen::Vector4d& b, double cutoff, double* lower) {
    const double d2 = (a.head<3>() - b.head<3>()).squaredNorm();
    const double reach = cutoff + a[3] + b[3];
    if (!(d2 > reach * reach)) return false;
    *lower = std::sqrt(d2) - a[3] - b[3];
    return true;
  };

  // row += sign · nᵀ J_WP of world point p_W on `link`
  auto add_row = [&](int link, const Eigen::Vector3d& p_W, const Eigen::Vector3d& n, double sign, double* row) {
    internal::AddDistanceJacobianRow(model, kin, data->dof_origin_W_, data->dof_prismatic_, link, p_W, n, sign, row);
  };

  for (const Tree::Flat& node : tree.flat_) {
    const int i = node.node;
    const int parent = node.parent;
    data->active_[i] = 0;
    if (!data->enabled_[i] || (parent >= 0 && !data->active_[parent])) continue;
    double* x = data->arena_.data() + data->node_[i].x_off;
    double* xd = data->arena_.data() + data->node_[i].xd_off;
    double* jdqd = data->arena_.data() + data->node_[i].jdqd_off;
    double* J = data->arena_.data() + data->node_[i].J_off;
    switch (node.type) {
      case TaskMapType::kJointAffine: {
        const auto& m = *std::get_if<JointAffineMap>(&tree.map(i));
        for (size_t k = 0; k < m.dofs.size(); ++k) {
          x[k] = m.scale[k] * (q[m.dofs[k]] - m.offset[k]);
          xd[k] = m.scale[k] * qd[m.dofs[k]];
          jdqd[k] = 0.0;
        }
        break;
      }
      case TaskMapType::kLinkPoint: {
        const auto& m = *std::get_if<LinkPointMap>(&tree.map(i));
        const Eigen::Vector3d p_W = kin.X_WL[m.link] * m.p_LP;
        Eigen::Map<Eigen::Vector3d> x3(x), xd3(xd), jdqd3(jdqd);
        x3 = p_W;
        Eigen::Map<Eigen::Matrix3Xd> J3(J, 3, model.nq());
        J3.setZero();
        for (int dof : model.link_dofs(m.link)) J3.col(dof) = kinematics::CalcPointJacobianColumn(model, kin, dof, m.link, p_W);
        xd3 = kinematics::CalcPointVelocityAtWorldPoint(kin, m.link, p_W);
        jdqd3 = kinematics::CalcPointJdotQdotAtWorldPoint(kin, m.link, p_W);
        break;
      }
      case TaskMapType::kCapsuleObstacleDistance: {
        if (node.obstacle >= num_obstacles) continue;
        if (beyond(data->capsule_sphere_[node.capsule1], data->obstacle_sphere_[node.obstacle], node.cutoff, x)) {
          continue;
        }
        const Obstacle& obstacle = scene.obstacles[node.obstacle];
        const math::DistanceResult& res = data->distance_[i] =
            CapsuleObstacleDistance(data->capsule_W_[node.capsule1], obstacle);
        x[0] = res.distance;
        if (res.distance > node.cutoff) continue;
        const Eigen::Vector3d n = res.gradient_norm * res.n_W;
        std::fill(J, J + model.nq(), 0.0);
        add_row(node.link1, res.p_W1, n, 1.0, J);
        xd[0] = n.dot(kinematics::CalcPointVelocityAtWorldPoint(kin, node.link1, res.p_W1) - obstacle.v_WO);
        jdqd[0] = n.dot(kinematics::CalcPointJdotQdotAtWorldPoint(kin, node.link1, res.p_W1));
        break;
      }
      case TaskMapType::kCapsuleCapsuleDistance: {
        if (beyond(data->capsule_sphere_[node.capsule1], data->capsule_sphere_[node.capsule2], node.cutoff, x)) {
          continue;
        }
        const math::DistanceResult& res = data->distance_[i] =
            math::CapsuleCapsuleDistance(data->capsule_W_[node.capsule1], data->capsule_W_[node.capsule2]);
        x[0] = res.distance;
        if (res.distance > node.cutoff) continue;
        const Eigen::Vector3d n = res.gradient_norm * res.n_W;
        std::fill(J, J + model.nq(), 0.0);
        add_row(node.link1, res.p_W1, n, 1.0, J);
        add_row(node.link2, res.p_W2, n, -1.0, J);
        xd[0] = n.dot(kinematics::CalcPointVelocityAtWorldPoint(kin, node.link1, res.p_W1) -
                      kinematics::CalcPointVelocityAtWorldPoint(kin, node.link2, res.p_W2));
        jdqd[0] = n.dot(kinematics::CalcPointJdotQdotAtWorldPoint(kin, node.link1, res.p_W1) -
                        kinematics::CalcPointJdotQdotAtWorldPoint(kin, node.link2, res.p_W2));
        break;
      }
      case TaskMapType::kAffine: {
        const auto& m = *std::get_if<AffineMap>(&tree.map(i));
        auto xv = data->x(i);
        xv.noalias() = m.A * data->x(parent);
        xv += m.b;
        data->xd(i).noalias() = m.A * data->xd(parent);
        data->Jdot_qd(i).setZero();
        break;
      }
    }
    data->active_[i] = 1;
  }
}

void Pullback(const Tree& tree, TreeData* data) {
  const int nq = tree.nq();
  data->f_root.setZero();
  data->M_root.setZero();
  double* f_root = data->f_root.data();
  double* M_root = data->M_root.data();  // column-major nq × nq
  for (auto it = tree.flat_.rbegin(); it != tree.flat_.rend(); ++it) {
    const int i = it->node;
    if (!data->active_[i]) continue;
    const int parent = it->parent;
    const TreeData::NodeLayout& layout = data->node_[i];
    if (parent < 0 && it->dim == 1 && it->type != TaskMapType::kJointAffine) {
      // 1-D leaf of the root (distances): f_q += (f − m J̇q̇) Jᵀ and the lower triangle of M_q += m JᵀJ, over the
      // dofs before the row's zero tail (whose terms would add zeros)
      const double* arena = data->arena_.data();
      const double f = arena[layout.f_off], mm = arena[layout.M_off];
      if (mm == 0.0 && f == 0.0) continue;
      const double* J = arena + layout.J_off;
      const double g = f - mm * arena[layout.jdqd_off];
      const int end = data->row_end_[i];
      for (int c = 0; c < end; ++c) {
        const double Jc = J[c];
        f_root[c] += g * Jc;
        const double s = mm * Jc;
        double* col = M_root + c * nq;
        for (int r = c; r < end; ++r) col[r] += s * J[r];
      }
      continue;
    }
    const auto f = data->f(i);
    const auto M = data->M(i);
    Eigen::Ref<Eigen::VectorXd> f_parent = parent < 0 ? Eigen::Ref<Eigen::VectorXd>(data->f_root)
                                                      : Eigen::Ref<Eigen::VectorXd>(data->f(parent));
    Eigen::Ref<Eigen::MatrixXd> M_parent = parent < 0 ? Eigen::Ref<Eigen::MatrixXd>(data->M_root)
                                                      : Eigen::Ref<Eigen::MatrixXd>(data->M(parent));
    if (it->type == TaskMapType::kJointAffine) {
      // sparse selection Jacobian: f_q[d_k] += s_k f_k, M_q[d_k, d_l] += s_k s_l M_kl (J̇q̇ = 0)
      const auto& m = *std::get_if<JointAffineMap>(&tree.map(i));
      const int dim = static_cast<int>(m.dofs.size());
      for (int k = 0; k < dim; ++k) {
        f_parent[m.dofs[k]] += m.scale[k] * f[k];
        for (int l = 0; l < dim; ++l) M_parent(m.dofs[k], m.dofs[l]) += m.scale[k] * m.scale[l] * M(k, l);
      }
    } else {
      PullbackAccumulate(data->J(i), data->Jdot_qd(i), f, M, f_parent, M_parent);
    }
  }
  // the 1-D leaves filled only the lower triangle: mirror it (every other pullback kept M_root symmetric)
  for (int c = 0; c < nq; ++c) {
    for (int r = c + 1; r < nq; ++r) M_root[r * nq + c] = M_root[c * nq + r];
  }
}

void PullbackAndResolve(const Tree& tree, TreeData* data, Eigen::Ref<Eigen::VectorXd> qdd) {
  Pullback(tree, data);
  data->lambda = data->resolver_.Solve(data->M_root, data->f_root, qdd);
}

}  // namespace rmpmarl::rmp
