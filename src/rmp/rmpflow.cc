// RMPflow baseline: the manipulator leaf set on an rmp::Tree, evaluated without allocation.
#include "rmpmarl/rmp/rmpflow.h"

#include <fmt/format.h>

#include <cmath>
#include <limits>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"

namespace rmpmarl::rmp {
namespace {

// a C-space target's velocity: only beside a target posture, one finite value per joint; its acceleration only beside
// its velocity
void CheckPostureMotion(const kinematics::Model& model, const Eigen::VectorXd& posture,
                        const Eigen::VectorXd& posture_velocity, const Eigen::VectorXd& posture_acceleration) {
  if (posture_velocity.size() > 0) {
    if (posture.size() == 0) {
      throw InputError("RMPflow: qd_T (the C-space target's velocity) is given without q_T (the C-space target)");
    }
    kinematics::CheckJointVector(model, posture_velocity, "qd_T (the C-space target's velocity)");
  }
  if (posture_acceleration.size() > 0) {
    if (posture_velocity.size() == 0) {
      throw InputError("RMPflow: qdd_T (the C-space target's acceleration) is given without qd_T (its velocity)");
    }
    kinematics::CheckJointVector(model, posture_acceleration, "qdd_T (the C-space target's acceleration)");
  }
}

}  // namespace

RmpflowOptions::RmpflowOptions() {
  // RMPflow (Lula) target RMP: linear damping −k_d ẋ with k_d = 85 1/s (Lula's Franka value)
  target.damping = TargetDamping::kLinear;
  target.accel_d_gain = 85.0;
  // obstacle avoidance at Lula's priority (the paper's μ = 1 is for its learned basic layer, not for RMPflow)
  collision.metric_scalar = 10000.0;
  // self collision: same law, shorter reach (link capsules of an arm sit close to each other by design)
  self_collision = collision;
  self_collision.metric_modulation_radius = 0.1;
  self_collision.repulsion_gain = 200.0;
  self_collision.metric_scalar = 1000.0;
}

void ValidateRmpflowOptions(const RmpflowOptions& o, std::string_view where) {
  const std::string w(where);
  ValidateCSpaceTargetRmpParams(o.cspace_target, w + ": rmp_params.cspace_target_rmp");
  ValidateCSpaceDampingRmpParams(o.cspace_damping, w + ": rmp_params.cspace_damping_rmp");
  ValidateJointLimitRmpParams(o.joint_limit, w + ": rmp_params.joint_limit_rmp");
  ValidateJointVelocityCapRmpParams(o.joint_velocity_cap, w + ": rmp_params.joint_velocity_cap_rmp");
  ValidateTargetRmpParams(o.target, w + ": rmp_params.target_rmp");
  ValidateCollisionRmpParams(o.collision, w + ": rmp_params.collision_rmp");
  ValidateCollisionRmpParams(o.self_collision, w + ": rmp_params.self_collision_rmp");
  if (!std::isfinite(o.joint_limit_buffer) || o.joint_limit_buffer < 0.0) {
    throw InputError(fmt::format("{}: joint_limit_buffer: expected a finite number >= 0, got {}", w,
                                 o.joint_limit_buffer));
  }
  if (!std::isfinite(o.max_acceleration_norm) || !(o.max_acceleration_norm > 0.0)) {
    throw InputError(fmt::format("{}: canonical_resolve.max_acceleration_norm: expected a finite number > 0, got {}",
                                 w, o.max_acceleration_norm));
  }
  if (!std::isfinite(o.resolve.relative_regularizer) || !(o.resolve.relative_regularizer > 0.0)) {
    throw InputError(fmt::format("{}: canonical_resolve.relative_regularizer: expected a finite number > 0, got {}",
                                 w, o.resolve.relative_regularizer));
  }
  for (size_t i = 0; i < o.home.size(); ++i) {
    if (!std::isfinite(o.home[i])) throw InputError(fmt::format("{}: home[{}]: expected a finite number", w, i));
  }
}

RmpflowPolicy::RmpflowPolicy(const kinematics::Robot& robot, const RmpflowOptions& options, int max_obstacles)
    : options_((ValidateRmpflowOptions(options, "RMPflow options"), options)),
      max_obstacles_(max_obstacles),
      tree_([&] {
        if (max_obstacles < 0) {
          throw InputError(fmt::format("RMPflow: max_obstacles must be >= 0, got {}", max_obstacles));
        }
        const kinematics::Model& model = robot.model;
        if (robot.end_effector.link < 0 || robot.end_effector.link >= model.num_links()) {
          throw InputError(fmt::format("RMPflow: robot '{}' has no end effector", robot.name));
        }
        std::vector<NodeSpec> nodes;
        nodes.push_back({"ee", "", LinkPointMap{robot.end_effector.link, robot.end_effector.X_LE.translation()}});
        JointAffineMap all;
        for (int i = 0; i < model.nq(); ++i) all.dofs.push_back(i);
        nodes.push_back({"cspace", "", all});
        for (int i = 0; i < model.nq(); ++i) {
          const kinematics::DofLimits& lim = model.limits()[i];
          if (!std::isfinite(lim.lower) || !std::isfinite(lim.upper)) continue;
          const double lo = lim.lower + options.joint_limit_buffer, hi = lim.upper - options.joint_limit_buffer;
          if (!(hi > lo)) {
            throw InputError(fmt::format("RMPflow: joint_limit_buffer {} leaves no range for joint '{}' of robot '{}' "
                                         "(limits [{}, {}])", options.joint_limit_buffer, model.dof_name(i),
                                         robot.name, lim.lower, lim.upper));
          }
          const double scale = 1.0 / (hi - lo);
          nodes.push_back({"joint_limit_lower/" + model.dof_name(i), "", JointAffineMap{{i}, {scale}, {lo}}});
          nodes.push_back({"joint_limit_upper/" + model.dof_name(i), "", JointAffineMap{{i}, {-scale}, {hi}}});
        }
        for (int i = 0; i < model.nq(); ++i) {
          nodes.push_back({"velocity_cap/" + model.dof_name(i), "", JointAffineMap{{i}, {}, {}}});
        }
        const int num_capsules = static_cast<int>(robot.capsules.size());
        for (int c = 0; c < num_capsules; ++c) {
          if (model.link_dofs(robot.capsules[c].link).empty()) continue;  // never moves
          for (int s = 0; s < max_obstacles; ++s) {
            nodes.push_back({fmt::format("obstacle/{}/{}", c, s), "",
                             CapsuleObstacleDistanceMap{c, s, options.collision.metric_modulation_radius}});
          }
        }
        if (options.self_collision_enabled) {
          for (int c1 = 0; c1 < num_capsules; ++c1) {
            for (int c2 = c1 + 1; c2 < num_capsules; ++c2) {
              const int l1 = robot.capsules[c1].link, l2 = robot.capsules[c2].link;
              if (l1 == l2 || robot.IsExcludedPair(l1, l2)) continue;
              // the same dofs move both links: their relative pose, hence their distance, is constant
              if (model.link_dofs(l1) == model.link_dofs(l2)) continue;
              nodes.push_back({fmt::format("self/{}/{}", c1, c2), "",
                               CapsuleCapsuleDistanceMap{c1, c2, options.self_collision.metric_modulation_radius}});
            }
          }
        }
        return Tree(robot, std::move(nodes));
      }()),
      data_(tree_, options.resolve) {
  const kinematics::Model& model = tree_.robot().model;
  const int nq = model.nq();
  home_.resize(nq);
  if (!options_.home.empty()) {
    if (static_cast<int>(options_.home.size()) != nq) {
      throw InputError(fmt::format("RMPflow options: home has {} entries but robot '{}' has {} joints",
                                   options_.home.size(), robot.name, nq));
    }
    for (int i = 0; i < nq; ++i) home_[i] = options_.home[i];
  } else {
    for (int i = 0; i < nq; ++i) {
      const kinematics::DofLimits& lim = model.limits()[i];
      home_[i] = std::isfinite(lim.lower) && std::isfinite(lim.upper) ? 0.5 * (lim.lower + lim.upper) : 0.0;
    }
  }
  v_max_.resize(nq);
  for (int i = 0; i < nq; ++i) {
    const double urdf = model.limits()[i].velocity;
    v_max_[i] = urdf > 0.0 ? std::min(options_.joint_velocity_cap.max_velocity, urdf)
                           : options_.joint_velocity_cap.max_velocity;
  }
  for (int node = 0; node < tree_.num_nodes(); ++node) {
    const std::string& name = tree_.name(node);
    if (name == "ee") {
      ee_node_ = node;
    } else if (name == "cspace") {
      cspace_node_ = node;
    } else if (name.starts_with("joint_limit_")) {
      joint_limit_nodes_.push_back({node, std::get<JointAffineMap>(tree_.map(node)).dofs[0]});
    } else if (name.starts_with("velocity_cap/")) {
      velocity_cap_nodes_.push_back(node);
    } else if (name.starts_with("obstacle/")) {
      obstacle_nodes_.push_back(node);
    } else if (name.starts_with("self/")) {
      self_nodes_.push_back(node);
    }
  }
}

void RmpflowPolicy::set_home(const Eigen::Ref<const Eigen::VectorXd>& home) {
  kinematics::CheckJointVector(tree_.robot().model, home, "RMPflow home");
  home_ = home;
}

Eigen::Vector3d RmpflowPolicy::end_effector_position() const { return data_.x(ee_node_); }

void RmpflowPolicy::Evaluate(const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Ref<const Eigen::VectorXd>& qd,
                             const Scene& scene, Eigen::Ref<Eigen::VectorXd> qdd) {
  const kinematics::Model& model = tree_.robot().model;
  kinematics::CheckJointVector(model, q, "q");
  kinematics::CheckJointVector(model, qd, "qd");
  if (qdd.size() != model.nq()) {
    throw InputError(fmt::format("RMPflow: qdd must have {} entries, got {}", model.nq(), qdd.size()));
  }
  const int num_obstacles = static_cast<int>(scene.obstacles.size());
  if (num_obstacles > max_obstacles_) {
    throw InputError(fmt::format("RMPflow: scene has {} obstacles but the policy was built for at most {}",
                                 num_obstacles, max_obstacles_));
  }
  const Eigen::VectorXd& posture = PostureTarget(scene.q_T);
  if (ee_node_ >= 0) data_.set_enabled(ee_node_, true);
  PushForward(tree_, q, qd, scene, &data_);
  CheckPostureMotion(model, scene.q_T, scene.qd_T, scene.qdd_T);
  WriteLeaves(q, qd, scene, posture, scene.q_T_metric, scene.qd_T, scene.qdd_T, /*task_leaves=*/true);
  PullbackAndResolve(tree_, &data_, qdd);
  diagnostics_.lambda = data_.lambda;
  const double norm = qdd.norm();
  if (norm > options_.max_acceleration_norm) {
    qdd *= options_.max_acceleration_norm / norm;
    diagnostics_.clipped = true;
  }
}

void RmpflowPolicy::EvaluateStructure(const Eigen::Ref<const Eigen::VectorXd>& q,
                                      const Eigen::Ref<const Eigen::VectorXd>& qd, const Eigen::VectorXd& posture,
                                      double posture_metric, const Eigen::VectorXd& posture_velocity,
                                      const Eigen::VectorXd& posture_acceleration) {
  const kinematics::Model& model = tree_.robot().model;
  kinematics::CheckJointVector(model, q, "q");
  kinematics::CheckJointVector(model, qd, "qd");
  const Eigen::VectorXd& target = PostureTarget(posture);
  if (ee_node_ >= 0) data_.set_enabled(ee_node_, false);  // the target leaf is the caller's (its RMP would be zero)
  PushForward(tree_, q, qd, no_task_, &data_);
  CheckPostureMotion(model, posture, posture_velocity, posture_acceleration);
  WriteLeaves(q, qd, no_task_, target, posture_metric, posture_velocity, posture_acceleration, /*task_leaves=*/false);
  Pullback(tree_, &data_);
}

const Eigen::VectorXd& RmpflowPolicy::PostureTarget(const Eigen::VectorXd& posture) const {
  if (posture.size() == 0) return home_;
  kinematics::CheckJointVector(tree_.robot().model, posture, "q_T (C-space target)");
  return posture;
}

void RmpflowPolicy::WriteLeaves(const Eigen::Ref<const Eigen::VectorXd>& q,
                                const Eigen::Ref<const Eigen::VectorXd>& qd, const Scene& scene,
                                const Eigen::VectorXd& posture, double posture_metric,
                                const Eigen::VectorXd& posture_velocity,
                                const Eigen::VectorXd& posture_acceleration, bool task_leaves) {
  const int num_obstacles = static_cast<int>(scene.obstacles.size());
  RmpflowDiagnostics& diag = diagnostics_;
  diag = RmpflowDiagnostics{};
  constexpr double kInf = std::numeric_limits<double>::infinity();
  diag.min_obstacle_distance = kInf;
  diag.min_self_distance = kInf;

  // end-effector target, fed with the velocity relative to the target
  if (task_leaves && scene.has_target) {
    const Eigen::Vector3d x = data_.x(ee_node_);
    const Eigen::Vector3d xd_rel = Eigen::Vector3d(data_.xd(ee_node_)) - scene.v_WT;
    const Rmp3 rmp = EvalTargetRmp(options_.target, x, xd_rel, scene.p_WT);
    data_.M(ee_node_) = rmp.M;
    data_.f(ee_node_) = rmp.M * rmp.a;
    diag.target_distance = (scene.p_WT - x).norm();
  }

  // C-space target + inertia + damping, all with metrics proportional to I
  {
    auto f = data_.f(cspace_node_);
    // toward the posture, moving with its velocity and acceleration where given
    auto target = [&](const CSpaceTargetRmpParams& params) {
      if (posture_acceleration.size() > 0) {
        return EvalCSpaceTargetRmp(params, q, qd, posture, posture_velocity, posture_acceleration, f);
      }
      if (posture_velocity.size() > 0) return EvalCSpaceTargetRmp(params, q, qd, posture, posture_velocity, f);
      return EvalCSpaceTargetRmp(params, q, qd, posture, f);
    };
    double s = 0.0;
    if (posture_metric > 0.0) {
      CSpaceTargetRmpParams params = options_.cspace_target;
      params.metric_scalar = posture_metric;
      s = target(params);
    } else {
      s = target(options_.cspace_target);
    }
    const CSpaceDampingRmpParams& damping = options_.cspace_damping;
    f.noalias() -= (damping.metric_scalar * damping.accel_d_gain) * qd;
    data_.M(cspace_node_).diagonal().setConstant(s + damping.metric_scalar);
  }

  for (const JointLimitLeaf& leaf : joint_limit_nodes_) {
    const Rmp1 rmp = EvalJointLimitRmp(options_.joint_limit, data_.x(leaf.node)[0], data_.xd(leaf.node)[0]);
    data_.M(leaf.node)(0, 0) = rmp.m;
    data_.f(leaf.node)[0] = rmp.m * rmp.a;
  }
  for (int i = 0; i < static_cast<int>(velocity_cap_nodes_.size()); ++i) {
    const int node = velocity_cap_nodes_[i];
    const Rmp1 rmp = EvalJointVelocityCapRmp(options_.joint_velocity_cap, v_max_[i], qd[i]);
    data_.M(node)(0, 0) = rmp.m;
    data_.f(node)[0] = rmp.m * rmp.a;
  }
  if (task_leaves) {
    for (int node : obstacle_nodes_) {
      if (std::get<CapsuleObstacleDistanceMap>(tree_.map(node)).obstacle >= num_obstacles) continue;
      const double x = data_.x(node)[0];
      diag.min_obstacle_distance = std::min(diag.min_obstacle_distance, x);
      if (!data_.active(node)) continue;
      ++diag.active_obstacle_pairs;
      const Rmp1 rmp = EvalCollisionRmp(options_.collision, x, data_.xd(node)[0]);
      data_.M(node)(0, 0) = rmp.m;
      data_.f(node)[0] = rmp.m * rmp.a;
    }
  }
  for (int node : self_nodes_) {
    const double x = data_.x(node)[0];
    diag.min_self_distance = std::min(diag.min_self_distance, x);
    if (!data_.active(node)) continue;
    ++diag.active_self_pairs;
    const Rmp1 rmp = EvalCollisionRmp(options_.self_collision, x, data_.xd(node)[0]);
    data_.M(node)(0, 0) = rmp.m;
    data_.f(node)[0] = rmp.m * rmp.a;
  }
}

}  // namespace rmpmarl::rmp
