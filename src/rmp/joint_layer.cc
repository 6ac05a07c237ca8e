// The basic movement layer at one joint (or at every joint at once): paper RMPs pulled back through one Jacobian
// column.
#include "rmpmarl/rmp/joint_layer.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>

#include "collision_leaf_simd.h"
#include "point_kinematics.h"
#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {

Eigen::Vector3d ScaledTargetAccel(const BasicRmpParams& params, const Eigen::Vector3d& a,
                                  const Eigen::Vector3d& attraction, double accel_scale) {
  if (params.target_scale == TargetScale::kAcceleration) return accel_scale * a;
  return a + (accel_scale - 1.0) * attraction;
}

namespace {

/// eq (5)'s attraction where ScaledTargetAccel reads it (rmp.target_scale stiffness); zero in the acceleration mode,
/// which ignores it, so the paper's default pays nothing for it in a control step.
Eigen::Vector3d AttractionForScale(const BasicRmpParams& params, const Eigen::Vector3d& p_WE,
                                   const Eigen::Vector3d& p_WT) {
  return params.target_scale == TargetScale::kStiffness ? TargetAttraction(params.target, p_WE, p_WT)
                                                        : Eigen::Vector3d::Zero();
}

/// the collision RMP with its acceleration length scales l_p, l_d of eq (8) multiplied by `length_scale`
CollisionRmpParams LengthScaled(const CollisionRmpParams& params, double length_scale) {
  CollisionRmpParams p = params;
  p.repulsion_std_dev *= length_scale;  // l_p
  p.damping_std_dev *= length_scale;    // l_d
  return p;
}

}  // namespace

Rmp1 EvalScaledCollisionRmp(const CollisionRmpParams& params, double x, double xd, double length_scale) {
  RMPMARL_DASSERT(length_scale > 0.0, "EvalScaledCollisionRmp: length_scale must be > 0");
  if (length_scale == 1.0) return EvalCollisionRmp(params, x, xd);
  return EvalCollisionRmp(LengthScaled(params, length_scale), x, xd);
}
using kinematics::CalcPointJdotQdotAtWorldPoint;
using kinematics::CalcPointVelocityAtWorldPoint;
using kinematics::CalcPointJacobianColumn;

JointLayerResult EvaluateJointLayer(const kinematics::Robot& robot, const kinematics::Data& kin, int dof,
                                    const Scene& scene, const BasicRmpParams& params,
                                    const JointLayerWeights& weights, double relative_regularizer) {
  const kinematics::Model& model = robot.model;
  RMPMARL_DASSERT(dof >= 0 && dof < model.nq(), "EvaluateJointLayer: dof out of range");
  RMPMARL_DASSERT(kin.has_velocities, "EvaluateJointLayer: CalcVelocityKinematics must run first");
  JointLayerResult result;
  result.min_distance = std::numeric_limits<double>::infinity();
  double force = 0.0, metric = 0.0;

  if (weights.use_target && scene.has_target && model.DofMovesLink(dof, robot.end_effector.link)) {
    const int link = robot.end_effector.link;
    const Eigen::Vector3d p_WE = kin.X_WL[link] * robot.end_effector.X_LE.translation();
    const Eigen::Vector3d v_rel = CalcPointVelocityAtWorldPoint(kin, link, p_WE) - scene.v_WT;
    const Rmp3 rmp = EvalTargetRmp(params.target, p_WE, v_rel, scene.p_WT);
    const Eigen::Matrix3d M = weights.target_metric_scale * rmp.M;
    const Eigen::Vector3d attraction = AttractionForScale(params, p_WE, scene.p_WT);
    const Eigen::Vector3d f = M * ScaledTargetAccel(params, rmp.a, attraction, weights.target_accel_scale);
    const Eigen::Vector3d j = CalcPointJacobianColumn(model, kin, dof, link, p_WE);
    const Eigen::Vector3d jdqd = CalcPointJdotQdotAtWorldPoint(kin, link, p_WE);
    force += j.dot(f - M * jdqd);
    metric += j.dot(M * j);
  }

  if (weights.use_collision) {
    const double r = params.collision.metric_modulation_radius;
    for (const kinematics::LinkCapsule& lc : robot.capsules) {
      if (!model.DofMovesLink(dof, lc.link)) continue;
      const Eigen::Isometry3d& X_WL = kin.X_WL[lc.link];
      const math::Capsule capsule{X_WL * lc.p_LA, X_WL * lc.p_LB, lc.radius};
      const Eigen::Vector3d centre = 0.5 * (capsule.p_WA + capsule.p_WB);
      const double bound = 0.5 * (capsule.p_WB - capsule.p_WA).norm() + capsule.radius;
      for (const Obstacle& obstacle : scene.obstacles) {
        const double lower = (centre - Centre(obstacle)).norm() - bound - BoundingRadius(obstacle);
        if (lower > r) {
          result.min_distance = std::min(result.min_distance, lower);  // a lower bound, > r
          continue;
        }
        const math::DistanceResult res = CapsuleObstacleDistance(capsule, obstacle);
        result.min_distance = std::min(result.min_distance, res.distance);
        if (res.distance > r) continue;
        const Eigen::Vector3d n = res.gradient_norm * res.n_W;
        const double xd = n.dot(CalcPointVelocityAtWorldPoint(kin, lc.link, res.p_W1) - obstacle.v_WO);
        const Rmp1 rmp = EvalScaledCollisionRmp(params.collision, res.distance, xd, weights.collision_length_scale);
        const double m = weights.collision_metric_scale * rmp.m;
        const double f = m * weights.collision_accel_scale * rmp.a;
        const double j = n.dot(CalcPointJacobianColumn(model, kin, dof, lc.link, res.p_W1));
        const double jdqd = n.dot(CalcPointJdotQdotAtWorldPoint(kin, lc.link, res.p_W1));
        force += j * (f - m * jdqd);
        metric += j * m * j;
        ++result.collision_terms;
      }
    }
  }

  result.force = force;
  result.metric = metric;
  result.lambda = relative_regularizer * (1.0 + metric);
  result.qdd = force / (metric + result.lambda);
  return result;
}


namespace {

/// One collision leaf (eqs 8–9): a capsule–obstacle pair within the deactivation radius r.
struct CollisionLeaf {
  const kinematics::LinkCapsule* capsule;  ///< the robot capsule
  const std::vector<int>* dofs;            ///< the dofs that move its link
  math::DistanceResult distance;           ///< witness points and distance
  Eigen::Vector3d n;                       ///< ∂d/∂p_W1 (gradient_norm · n_W)
  double xd;                               ///< ḋ relative to the obstacle
  Rmp1 rmp;  ///< the unscaled RMP (its acceleration only where a joint reads it at length scale 1, else 0)
  double sigma;                            ///< its velocity gate σ(ẋ), which no length scale changes
  double jdqd;                             ///< J̇q̇ of the distance
};

/// every capsule × obstacle pair of the capsules some joint selecting collision RMPs moves, each distance computed
/// once: on_distance(dofs, d) with the distance or, past a bounding-sphere test, its lower bound (> r); then
/// on_leaf(leaf) for the pairs within r. Without kReportDistances, on_distance is not called and the pairs whose
/// bounding spheres are certainly farther apart than r are skipped before the square root of their lower bound.
/// Without kEvaluateRmp the leaf's sigma and rmp are left unset (the caller evaluates them).
template <bool kReportDistances, bool kEvaluateRmp, class OnDistance, class OnLeaf>
void ForEachCollisionLeaf(const kinematics::Robot& robot, const kinematics::Data& kin, const Scene& scene,
                          const BasicRmpParams& params, std::span<const JointLayerWeights> weights,
                          OnDistance&& on_distance, OnLeaf&& on_leaf) {
  if (scene.obstacles.empty()) return;
  const double r = params.collision.metric_modulation_radius;
  // the obstacles' bounding spheres (centre, radius), once per evaluation (for the first kCachedSpheres) when a
  // capsule needs them
  constexpr int kCachedSpheres = 32;
  std::array<Eigen::Vector4d, kCachedSpheres> spheres;
  const int num_obstacles = static_cast<int>(scene.obstacles.size());
  const int cached = std::min(num_obstacles, kCachedSpheres);
  bool spheres_ready = false;
  // squared sphere gaps beyond (1 + 1e-9) (r + radii)² are beyond r after every rounding of the lower bound below
  // (r > 0 and the radii ≥ 0, so the margin of about 5e-10 of the gap dwarfs the rounding of a few ulps)
  constexpr double kCertainlyBeyond = 1.0 + 1e-9;
  CollisionLeaf leaf;
  for (const kinematics::LinkCapsule& lc : robot.capsules) {
    const std::vector<int>& dofs = robot.model.link_dofs(lc.link);
    if (std::none_of(dofs.begin(), dofs.end(), [&](int dof) { return weights[dof].use_collision; })) continue;
    if (!spheres_ready) {
      for (int j = 0; j < cached; ++j) spheres[j] = BoundingSphere(scene.obstacles[j]);
      spheres_ready = true;
    }
    // the RMP's acceleration at length scale 1 only where some joint reads it (ScaledCollisionAccel)
    const bool unit_scale = kEvaluateRmp && std::any_of(dofs.begin(), dofs.end(), [&](int dof) {
      return weights[dof].use_collision && weights[dof].collision_length_scale == 1.0;
    });
    const Eigen::Isometry3d& X_WL = kin.X_WL[lc.link];
    const math::Capsule capsule{X_WL * lc.p_LA, X_WL * lc.p_LB, lc.radius};
    const Eigen::Vector3d centre = 0.5 * (capsule.p_WA + capsule.p_WB);
    const double bound = 0.5 * (capsule.p_WB - capsule.p_WA).norm() + capsule.radius;
    for (int j = 0; j < num_obstacles; ++j) {
      const Obstacle& obstacle = scene.obstacles[j];
      const Eigen::Vector4d sphere = j < cached ? spheres[j] : BoundingSphere(obstacle);
      const double gap2 = (centre - sphere.head<3>()).squaredNorm();
      if constexpr (!kReportDistances) {
        const double reach = r + bound + sphere[3];
        if (gap2 > kCertainlyBeyond * (reach * reach)) continue;
      }
      const double lower = std::sqrt(gap2) - bound - sphere[3];
      if (lower > r) {
        if constexpr (kReportDistances) on_distance(dofs, lower);
        continue;
      }
      leaf.distance = CapsuleObstacleDistance(capsule, obstacle);
      if constexpr (kReportDistances) on_distance(dofs, leaf.distance.distance);
      if (leaf.distance.distance > r) continue;
      leaf.capsule = &lc;
      leaf.dofs = &dofs;
      leaf.rmp = Rmp1{};
      leaf.n = leaf.distance.gradient_norm * leaf.distance.n_W;
      leaf.xd = leaf.n.dot(CalcPointVelocityAtWorldPoint(kin, lc.link, leaf.distance.p_W1) - obstacle.v_WO);
      if constexpr (kEvaluateRmp) {
        leaf.sigma = CollisionVelocityGate(leaf.xd, params.collision.damping_velocity_gate_length_scale);
        if (unit_scale) leaf.rmp.a = CollisionRmpAccel(params.collision, leaf.distance.distance, leaf.xd, leaf.sigma);
        leaf.rmp.m = CollisionRmpMetric(params.collision, leaf.distance.distance, leaf.sigma);
      }
      leaf.jdqd = leaf.n.dot(CalcPointJdotQdotAtWorldPoint(kin, lc.link, leaf.distance.p_W1));
      on_leaf(leaf);
    }
  }
}

/// the collision RMP's acceleration at a joint's length scale (rmp.a itself at scale 1): EvalScaledCollisionRmp's
/// acceleration, with the leaf's velocity gate; `scaled` is LengthScaled(params.collision, length_scale)
double ScaledCollisionAccel(const CollisionRmpParams& scaled, const CollisionLeaf& leaf, double length_scale) {
  if (length_scale == 1.0) return leaf.rmp.a;
  return CollisionRmpAccel(scaled, leaf.distance.distance, leaf.xd, leaf.sigma);
}

}  // namespace

void EvaluateJointLayers(const kinematics::Robot& robot, const kinematics::Data& kin, const Scene& scene,
                         const BasicRmpParams& params, std::span<const JointLayerWeights> weights,
                         std::span<JointLayerResult> results, double relative_regularizer) {
  const kinematics::Model& model = robot.model;
  const int nq = model.nq();
  if (static_cast<int>(weights.size()) != nq || static_cast<int>(results.size()) != nq) {
    throw InputError(fmt::format("EvaluateJointLayers: robot '{}' has {} joints but got {} weights and {} results",
                                 robot.name, nq, weights.size(), results.size()));
  }
  RMPMARL_DASSERT(kin.has_velocities, "EvaluateJointLayers: CalcVelocityKinematics must run first");
  for (JointLayerResult& r : results) {
    r = JointLayerResult{};
    r.min_distance = std::numeric_limits<double>::infinity();
  }

  if (scene.has_target) {
    const int link = robot.end_effector.link;
    const Eigen::Vector3d p_WE = kin.X_WL[link] * robot.end_effector.X_LE.translation();
    const Eigen::Vector3d v_rel = CalcPointVelocityAtWorldPoint(kin, link, p_WE) - scene.v_WT;
    const Rmp3 rmp = EvalTargetRmp(params.target, p_WE, v_rel, scene.p_WT);
    const Eigen::Vector3d jdqd = CalcPointJdotQdotAtWorldPoint(kin, link, p_WE);
    const Eigen::Vector3d attraction = AttractionForScale(params, p_WE, scene.p_WT);
    for (int dof : model.link_dofs(link)) {
      const JointLayerWeights& w = weights[dof];
      if (!w.use_target) continue;
      const Eigen::Matrix3d M = w.target_metric_scale * rmp.M;
      const Eigen::Vector3d f = M * ScaledTargetAccel(params, rmp.a, attraction, w.target_accel_scale);
      const Eigen::Vector3d j = CalcPointJacobianColumn(model, kin, dof, link, p_WE);
      results[dof].force += j.dot(f - M * jdqd);
      results[dof].metric += j.dot(M * j);
    }
  }

  // each capsule–obstacle distance once, shared by every joint that moves the capsule
  ForEachCollisionLeaf</*kReportDistances=*/true, /*kEvaluateRmp=*/true>(
      robot, kin, scene, params, weights,
      [&](const std::vector<int>& dofs, double d) {
        for (int dof : dofs) {
          if (weights[dof].use_collision) results[dof].min_distance = std::min(results[dof].min_distance, d);
        }
      },
      [&](const CollisionLeaf& leaf) {
        for (int dof : *leaf.dofs) {
          const JointLayerWeights& w = weights[dof];
          if (!w.use_collision) continue;
          const double m = w.collision_metric_scale * leaf.rmp.m;
          const double a = ScaledCollisionAccel(LengthScaled(params.collision, w.collision_length_scale), leaf,
                                                w.collision_length_scale);
          const double f = m * w.collision_accel_scale * a;
          const double j =
              leaf.n.dot(internal::PointJacobianColumn(model, kin, dof, leaf.capsule->link, leaf.distance.p_W1));
          results[dof].force += j * (f - m * leaf.jdqd);
          results[dof].metric += j * m * j;
          ++results[dof].collision_terms;
        }
      });

  for (JointLayerResult& res : results) {
    res.lambda = relative_regularizer * (1.0 + res.metric);
    res.qdd = res.force / (res.metric + res.lambda);
  }
}

namespace {

// the vectorised leaves' per-joint arrays in CoupledLayerWorkspace::lanes, lane_stride entries each
enum Lane : int {
  kRepulsionStdDev, kDampingStdDev, kMetricScale, kAccelScale, kSqrtMetricScale, kActive,
  kAxisX, kAxisY, kAxisZ, kOriginX, kOriginY, kOriginZ, kB, kGX, kGY, kGZ, kNumLanes
};

// true where the vectorised leaf kernel may run on this robot: every dof a revolute joint of its own, and every
// capsule moved by dofs 0..k-1 (a serial chain), so that a leaf's lanes are its dofs
bool VectorisableRobot(const kinematics::Robot& robot) {
  const kinematics::Model& model = robot.model;
  if (model.has_mimic_joints()) return false;
  for (int i = 0; i < model.nq(); ++i) {
    const kinematics::JointType type = model.link(model.dof_link(i)).joint_type;
    if (type != kinematics::JointType::kRevolute && type != kinematics::JointType::kContinuous) return false;
  }
  for (const kinematics::LinkCapsule& lc : robot.capsules) {
    const std::vector<int>& dofs = model.link_dofs(lc.link);  // ascending
    if (!dofs.empty() && dofs.back() != static_cast<int>(dofs.size()) - 1) return false;
  }
  return true;
}

}  // namespace

static_assert(CoupledLayerWorkspace::kLeafBatch == internal::CollisionLeafBatch::kCapacity,
              "the workspace's leaf scratch holds one batch");

CoupledLayerWorkspace::CoupledLayerWorkspace(int nq)
    : A(nq, nq), b(nq), g(nq), G(3, nq), MG(3, nq), ldlt(nq), collision_active(nq, 0), sqrt_collision_metric(nq),
      scaled_collision(nq), mg(nq), lane_stride((nq + 3) / 4 * 4),
      lanes(static_cast<size_t>(kNumLanes) * lane_stride, 0.0), lane_A(static_cast<size_t>(lane_stride) * nq, 0.0),
      leaf_scratch(static_cast<size_t>(3 * kLeafBatch) * lane_stride, 0.0) {
  // the padding lanes' length scales stay 1, so that their (discarded) arithmetic stays finite
  for (int i = nq; i < lane_stride; ++i) {
    lanes[kRepulsionStdDev * lane_stride + i] = 1.0;
    lanes[kDampingStdDev * lane_stride + i] = 1.0;
  }
  internal::CollisionLeafKernelAvailable();  // its one-time self-check here, not in the first control step
}

bool CoupledLayerWorkspace::robot_vectorisable(const kinematics::Robot& robot) {
  if (checked_robot_ != &robot) {
    checked_robot_ = &robot;
    robot_vectorisable_ = VectorisableRobot(robot);
  }
  return robot_vectorisable_;
}

namespace {

// the collision leaves' terms added to ws.A and ws.b, leaf by leaf and joint by joint (the scalar loop)
void AddCollisionLeaves(const kinematics::Robot& robot, const kinematics::Data& kin, const Scene& scene,
                        const BasicRmpParams& params, std::span<const JointLayerWeights> weights,
                        CoupledLayerWorkspace& ws) {
  const kinematics::Model& model = robot.model;
  ForEachCollisionLeaf</*kReportDistances=*/false, /*kEvaluateRmp=*/true>(
      robot, kin, scene, params, weights, [](const std::vector<int>&, double) {},
      [&](const CollisionLeaf& leaf) {
        for (int dof : *leaf.dofs) {
          ws.g[dof] = 0.0;
          if (ws.collision_active[dof]) {
            const JointLayerWeights& w = weights[dof];
            const double a = ScaledCollisionAccel(ws.scaled_collision[dof], leaf, w.collision_length_scale);
            const double j =
                leaf.n.dot(internal::PointJacobianColumn(model, kin, dof, leaf.capsule->link, leaf.distance.p_W1));
            ws.g[dof] = ws.sqrt_collision_metric[dof] * j;
            ws.b[dof] += w.collision_metric_scale * j * leaf.rmp.m * (w.collision_accel_scale * a - leaf.jdqd);
          }
          ws.mg[dof] = leaf.rmp.m * ws.g[dof];
        }
        // A += m g gᵀ over the leaf's dofs, the only non-zero entries of g
        for (int j : *leaf.dofs) {
          const double g_j = ws.g[j];
          for (int i : *leaf.dofs) ws.A(i, j) += g_j * ws.mg[i];
        }
      });
}

// the target leaf's A += Gᵀ (M G) (ws.G, ws.MG), then AddCollisionLeaves' terms, four joints or leaves at a time
// (internal::AddGramAvx2, internal::CollisionLeavesAvx2)
// \pre internal::CollisionLeafKernelAvailable(), VectorisableRobot(robot)
void AddTargetGramAndCollisionLeavesAvx2(const kinematics::Robot& robot, const kinematics::Data& kin,
                                         const Scene& scene, const BasicRmpParams& params,
                                         std::span<const JointLayerWeights> weights, bool target_gram,
                                         CoupledLayerWorkspace& ws) {
  const kinematics::Model& model = robot.model;
  const int nq = model.nq();
  const int stride = ws.lane_stride;
  auto lane = [&](Lane l) { return ws.lanes.data() + static_cast<size_t>(l) * stride; };
  // A and b with columns padded to the lanes (the padding rows are never read back)
  for (int c = 0; c < nq; ++c) std::copy_n(ws.A.col(c).data(), nq, ws.lane_A.data() + static_cast<size_t>(c) * stride);
  std::copy_n(ws.b.data(), nq, lane(kB));
  if (target_gram) {
    const double* const g[3] = {lane(kGX), lane(kGY), lane(kGZ)};
    for (int i = 0; i < nq; ++i) {
      for (int r = 0; r < 3; ++r) lane(static_cast<Lane>(kGX + r))[i] = ws.G(r, i);
    }
    internal::AddGramAvx2(g, ws.MG.data(), nq, ws.lane_A.data(), stride);
  }
  // the joints' lanes
  for (int i = 0; i < nq; ++i) {
    const JointLayerWeights& w = weights[i];
    lane(kRepulsionStdDev)[i] = ws.scaled_collision[i].repulsion_std_dev;
    lane(kDampingStdDev)[i] = ws.scaled_collision[i].damping_std_dev;
    lane(kMetricScale)[i] = w.collision_metric_scale;
    lane(kAccelScale)[i] = w.collision_accel_scale;
    lane(kSqrtMetricScale)[i] = ws.sqrt_collision_metric[i];
    const std::uint64_t all = ws.collision_active[i] ? ~std::uint64_t{0} : 0;
    std::memcpy(lane(kActive) + i, &all, sizeof(double));
    const Eigen::Vector3d& o_W = kin.X_WL[model.dof_link(i)].translation();
    for (int c = 0; c < 3; ++c) {
      lane(static_cast<Lane>(kAxisX + c))[i] = kin.axis_W(c, i);
      lane(static_cast<Lane>(kOriginX + c))[i] = o_W[c];
    }
  }
  const internal::CollisionLeafLanes lanes{lane(kRepulsionStdDev), lane(kDampingStdDev), lane(kMetricScale),
                                           lane(kAccelScale),      lane(kSqrtMetricScale), lane(kActive),
                                           {lane(kAxisX), lane(kAxisY), lane(kAxisZ)},
                                           {lane(kOriginX), lane(kOriginY), lane(kOriginZ)}};
  const CollisionRmpParams& c = params.collision;
  const internal::CollisionLeafConstants constants{c.repulsion_gain, c.damping_gain, c.damping_robustness_eps,
                                                   c.damping_velocity_gate_length_scale, c.metric_modulation_radius,
                                                   c.metric_scalar, c.metric_exploder_std_dev, c.metric_exploder_eps};
  // the leaves in batches, each batch's gates, metrics and per-joint terms at once, summed in the leaves' order
  internal::CollisionLeafBatch batch;
  auto flush = [&] {
    internal::CollisionLeavesAvx2(&batch, constants, lanes, stride, ws.leaf_scratch.data(), lane(kB),
                                  ws.lane_A.data(), stride);
    batch.count = 0;
  };
  ForEachCollisionLeaf</*kReportDistances=*/false, /*kEvaluateRmp=*/false>(
      robot, kin, scene, params, weights, [](const std::vector<int>&, double) {},
      [&](const CollisionLeaf& leaf) {  // the leaf's dofs are 0..k-1: the lanes
        const int l = batch.count;
        batch.k[l] = static_cast<int>(leaf.dofs->size());
        batch.xc[l] = std::max(leaf.distance.distance, 0.0);
        batch.xd[l] = leaf.xd;
        batch.jdqd[l] = leaf.jdqd;
        for (int i = 0; i < 3; ++i) {
          batch.n[i][l] = leaf.n[i];
          batch.p[i][l] = leaf.distance.p_W1[i];
        }
        if (++batch.count == internal::CollisionLeafBatch::kCapacity) flush();
      });
  if (batch.count > 0) flush();
  for (int c = 0; c < nq; ++c) std::copy_n(ws.lane_A.data() + static_cast<size_t>(c) * stride, nq, ws.A.col(c).data());
  std::copy_n(lane(kB), nq, ws.b.data());
}

}  // namespace

void EvaluateCoupledLayer(const kinematics::Robot& robot, const kinematics::Data& kin, const Scene& scene,
                          const BasicRmpParams& params, std::span<const JointLayerWeights> weights,
                          const Eigen::Ref<const Eigen::VectorXd>& f0, const Eigen::Ref<const Eigen::MatrixXd>& M0,
                          double relative_regularizer,
                          CoupledLayerWorkspace* workspace, Eigen::Ref<Eigen::VectorXd> qdd) {
  const kinematics::Model& model = robot.model;
  const int nq = model.nq();
  if (static_cast<int>(weights.size()) != nq || qdd.size() != nq) {
    throw InputError(fmt::format("EvaluateCoupledLayer: robot '{}' has {} joints but got {} weights and {} outputs",
                                 robot.name, nq, weights.size(), qdd.size()));
  }
  RMPMARL_ASSERT(workspace != nullptr && workspace->A.rows() == nq, "EvaluateCoupledLayer: workspace size");
  RMPMARL_DASSERT(kin.has_velocities, "EvaluateCoupledLayer: CalcVelocityKinematics must run first");
  CoupledLayerWorkspace& ws = *workspace;
  RMPMARL_ASSERT(f0.size() == nq && M0.rows() == nq && M0.cols() == nq, "EvaluateCoupledLayer: structure size");
  ws.A = M0;  // the structure's leaves, already pulled back
  ws.b = f0;

  bool target_gram = false;  // A += Gᵀ (M G) of the target leaf due
  if (scene.has_target) {  // the target leaf (eqs 5–7), columns weighted by √s_m of each joint
    const int link = robot.end_effector.link;
    const Eigen::Vector3d p_WE = kin.X_WL[link] * robot.end_effector.X_LE.translation();
    const Eigen::Vector3d v_rel = CalcPointVelocityAtWorldPoint(kin, link, p_WE) - scene.v_WT;
    const Rmp3 rmp = EvalTargetRmp(params.target, p_WE, v_rel, scene.p_WT);
    const Eigen::Vector3d Mjdqd = rmp.M * CalcPointJdotQdotAtWorldPoint(kin, link, p_WE);
    const Eigen::Vector3d Ma = rmp.M * rmp.a;
    const Eigen::Vector3d M_attraction = rmp.M * AttractionForScale(params, p_WE, scene.p_WT);
    ws.G.setZero();
    bool any = false;
    for (int dof : model.link_dofs(link)) {
      const JointLayerWeights& w = weights[dof];
      if (!w.use_target || w.target_metric_scale <= 0.0) continue;
      const Eigen::Vector3d j = internal::PointJacobianColumn(model, kin, dof, link, p_WE);
      ws.G.col(dof) = std::sqrt(w.target_metric_scale) * j;
      const Eigen::Vector3d Ma_scaled = ScaledTargetAccel(params, Ma, M_attraction, w.target_accel_scale);
      ws.b[dof] += w.target_metric_scale * j.dot(Ma_scaled - Mjdqd);
      any = true;
    }
    if (any) ws.MG.noalias() = rmp.M * ws.G;
    target_gram = any;
  }

  // the collision leaves (eqs 8–9), one per capsule–obstacle pair within r; what depends on the joint alone first
  for (int i = 0; i < nq; ++i) {
    const JointLayerWeights& w = weights[i];
    // as the leaf loop skipped before: a NaN scale stays in, and shows in q̈
    ws.collision_active[i] = w.use_collision && !(w.collision_metric_scale <= 0.0);
    ws.sqrt_collision_metric[i] = ws.collision_active[i] ? std::sqrt(w.collision_metric_scale) : 0.0;
    ws.scaled_collision[i] = LengthScaled(params.collision, w.collision_length_scale);
  }
  const bool vectorised = ws.vectorised && internal::CollisionLeafKernelAvailable() && ws.robot_vectorisable(robot);
  if (vectorised) {
    AddTargetGramAndCollisionLeavesAvx2(robot, kin, scene, params, weights, target_gram, ws);
  } else {
    if (target_gram) ws.A.noalias() += ws.G.transpose() * ws.MG;  // A += Gᵀ (M G)
    AddCollisionLeaves(robot, kin, scene, params, weights, ws);
  }

  const double lambda = relative_regularizer * (1.0 + ws.A.trace() / nq);
  ws.A.diagonal().array() += lambda;
  ws.ldlt.compute(ws.A);
  qdd = ws.ldlt.solve(ws.b);
}

}  // namespace rmpmarl::rmp
