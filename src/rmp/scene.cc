// Scene: obstacles and target as plain data.
#include "rmpmarl/rmp/scene.h"

#include <fmt/format.h>

#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rmp {

Obstacle Obstacle::MakeSphere(const Eigen::Vector3d& p_WC, double radius, const Eigen::Vector3d& v_WO) {
  Obstacle o;
  o.shape = ObstacleShape::kSphere;
  o.sphere.p_WC = p_WC;
  o.sphere.radius = radius;
  o.v_WO = v_WO;
  return o;
}

Obstacle Obstacle::MakeBox(const Eigen::Isometry3d& X_WB, const Eigen::Vector3d& half_size,
                           const Eigen::Vector3d& v_WO) {
  Obstacle o;
  o.shape = ObstacleShape::kBox;
  o.box.X_WB = X_WB;
  o.box.half_size = half_size;
  o.v_WO = v_WO;
  return o;
}

Obstacle Obstacle::MakeCylinder(const Eigen::Isometry3d& X_WC, double radius, double half_length,
                                const Eigen::Vector3d& v_WO) {
  Obstacle o;
  o.shape = ObstacleShape::kCylinder;
  o.cylinder.X_WC = X_WC;
  o.cylinder.radius = radius;
  o.cylinder.half_length = half_length;
  o.v_WO = v_WO;
  return o;
}

Obstacle Obstacle::MakePoints(const math::PointCloudIndex& index, double point_radius, const Eigen::Vector3d& v_WO) {
  Obstacle o;
  o.shape = ObstacleShape::kPoints;
  o.points = &index;
  o.point_radius = point_radius;
  o.v_WO = v_WO;
  return o;
}

void ValidateScene(const Scene& scene, std::string_view what) {
  // beyond a kilometre (or a kilometre per second) a value is a unit or sign error, not a scene
  constexpr double kLimit = 1e3;
  auto in_range = [&](const Eigen::Vector3d& v) { return v.allFinite() && v.cwiseAbs().maxCoeff() <= kLimit; };
  auto text = [](const Eigen::Vector3d& v) { return fmt::format("[{}, {}, {}]", v.x(), v.y(), v.z()); };
  for (size_t i = 0; i < scene.obstacles.size(); ++i) {
    const Obstacle& o = scene.obstacles[i];
    if (o.shape == ObstacleShape::kPoints) {
      if (o.points == nullptr || o.points->empty()) {
        throw InputError(fmt::format("{}: obstacles[{}] (points) needs a non-empty point index, got {}", what, i,
                                     o.points == nullptr ? "none" : "an empty one"));
      }
      if (!(o.point_radius >= 0.0) || !(o.point_radius <= kLimit)) {
        throw InputError(fmt::format("{}: obstacles[{}] (points): expected a point radius in [0, {}] m, got {}", what,
                                     i, kLimit, o.point_radius));
      }
      const Eigen::AlignedBox3d& b = o.points->bounds();
      if (!in_range(b.min()) || !in_range(b.max()) || !in_range(o.v_WO)) {
        throw InputError(fmt::format("{}: obstacles[{}] (points): expected points and velocity within ±{} m (m/s), "
                                     "got bounds {} … {}, velocity {}", what, i, kLimit, text(b.min()), text(b.max()),
                                     text(o.v_WO)));
      }
      continue;
    }
    const Eigen::Vector3d p = Centre(o);
    Eigen::Vector3d size = Eigen::Vector3d::Constant(o.sphere.radius);
    if (o.shape == ObstacleShape::kBox) size = o.box.half_size;
    if (o.shape == ObstacleShape::kCylinder) size = Eigen::Vector3d(o.cylinder.radius, o.cylinder.radius,
                                                                    o.cylinder.half_length);
    if (p.allFinite() && o.v_WO.allFinite() && size.allFinite() &&
        !(in_range(p) && in_range(o.v_WO) && in_range(size))) {
      throw InputError(fmt::format("{}: obstacles[{}]: expected a position, velocity and size within ±{} m (m/s), got "
                                   "position {}, velocity {}, size {}", what, i, kLimit, text(p), text(o.v_WO),
                                   text(size)));
    }
    if (!o.v_WO.allFinite()) throw InputError(fmt::format("{}: obstacles[{}].v_WO must be finite", what, i));
    auto is_rotation = [](const Eigen::Isometry3d& X) {
      const Eigen::Matrix3d R = X.linear();
      return X.matrix().allFinite() && (R.transpose() * R).isIdentity(1e-9) && R.determinant() > 0.0;
    };
    switch (o.shape) {
      case ObstacleShape::kSphere:
        if (!o.sphere.p_WC.allFinite() || !(o.sphere.radius > 0.0) || !std::isfinite(o.sphere.radius)) {
          throw InputError(fmt::format("{}: obstacles[{}] (sphere) needs a finite centre and a finite radius > 0, "
                                       "got radius {}", what, i, o.sphere.radius));
        }
        break;
      case ObstacleShape::kBox:
        if (!is_rotation(o.box.X_WB) || !o.box.half_size.allFinite() || !(o.box.half_size.minCoeff() > 0.0)) {
          throw InputError(fmt::format("{}: obstacles[{}] (box) needs a finite pose with a rotation matrix and half "
                                       "sizes > 0", what, i));
        }
        break;
      case ObstacleShape::kCylinder:
        if (!is_rotation(o.cylinder.X_WC) || !size.allFinite() || !(size.minCoeff() > 0.0)) {
          throw InputError(fmt::format("{}: obstacles[{}] (cylinder) needs a finite pose with a rotation matrix, a "
                                       "radius > 0 and a half length > 0, got radius {}, half length {}", what, i,
                                       o.cylinder.radius, o.cylinder.half_length));
        }
        break;
      case ObstacleShape::kPoints: break;
    }
  }
  if (!scene.q_T.allFinite()) throw InputError(fmt::format("{}: q_T (the C-space target) must be finite", what));
  if (scene.qd_T.size() > 0 && (scene.qd_T.size() != scene.q_T.size() || !scene.qd_T.allFinite())) {
    throw InputError(fmt::format("{}: qd_T (the C-space target's velocity): expected {} finite values (one per entry "
                                 "of q_T), got {}{}", what, scene.q_T.size(), scene.qd_T.size(),
                                 scene.qd_T.allFinite() ? "" : " with a non-finite one"));
  }
  if (scene.qdd_T.size() > 0 && (scene.qdd_T.size() != scene.qd_T.size() || !scene.qdd_T.allFinite())) {
    throw InputError(fmt::format("{}: qdd_T (the C-space target's acceleration): expected {} finite values (one per "
                                 "entry of qd_T; only with qd_T), got {}{}", what, scene.qd_T.size(),
                                 scene.qdd_T.size(), scene.qdd_T.allFinite() ? "" : " with a non-finite one"));
  }
  if (!(scene.q_T_metric >= 0.0) || !std::isfinite(scene.q_T_metric)) {
    throw InputError(fmt::format("{}: q_T_metric: expected a finite metric >= 0, got {}", what, scene.q_T_metric));
  }
  if (!scene.p_WT.allFinite() || !scene.v_WT.allFinite()) {
    throw InputError(fmt::format("{}: target position and velocity must be finite", what));
  }
  if (!in_range(scene.p_WT) || !in_range(scene.v_WT)) {
    throw InputError(fmt::format("{}: target: expected a position and velocity within ±{} m (m/s), got position {}, "
                                 "velocity {}", what, kLimit, text(scene.p_WT), text(scene.v_WT)));
  }
}

math::DistanceResult CapsuleObstacleDistance(const math::Capsule& capsule, const Obstacle& obstacle) {
  switch (obstacle.shape) {
    case ObstacleShape::kSphere:
      return math::CapsuleSphereDistance(capsule, obstacle.sphere);
    case ObstacleShape::kBox:
      return math::CapsuleBoxDistance(capsule, obstacle.box);
    case ObstacleShape::kCylinder:
      return math::CapsuleCylinderDistance(capsule, obstacle.cylinder);
    case ObstacleShape::kPoints:
      break;
  }
  return math::CapsulePointCloudDistance(capsule, *obstacle.points, obstacle.point_radius);
}

double BoundingRadius(const Obstacle& obstacle) {
  switch (obstacle.shape) {
    case ObstacleShape::kSphere:
      return obstacle.sphere.radius;
    case ObstacleShape::kBox:
      return obstacle.box.half_size.norm();
    case ObstacleShape::kCylinder:
      return std::hypot(obstacle.cylinder.radius, obstacle.cylinder.half_length);
    case ObstacleShape::kPoints:
      break;
  }
  return 0.5 * obstacle.points->bounds().diagonal().norm() + obstacle.point_radius;
}

Eigen::Vector3d Centre(const Obstacle& obstacle) {
  switch (obstacle.shape) {
    case ObstacleShape::kSphere:
      return obstacle.sphere.p_WC;
    case ObstacleShape::kBox:
      return obstacle.box.X_WB.translation();
    case ObstacleShape::kCylinder:
      return obstacle.cylinder.X_WC.translation();
    case ObstacleShape::kPoints:
      break;
  }
  return obstacle.points->bounds().center();
}

}  // namespace rmpmarl::rmp
