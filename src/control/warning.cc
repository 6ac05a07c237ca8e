// The warning contacts of a robot's capsules from geometry: obstacles, floor and self pairs within a margin.
#include "rmpmarl/control/warning.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::control {
WarningSensor::WarningSensor(const kinematics::Robot& robot, const WarningSensorOptions& options)
    : robot_(&robot), options_(options), checker_(robot, {/*check_floor=*/false, 0.0}), placed_(checker_) {
  if (!std::isfinite(options.margin) || !(options.margin > 0.0)) {
    throw InputError(fmt::format("WarningSensorOptions.margin: expected a finite distance > 0 m, got {}",
                                 options.margin));
  }
  if (options.max_obstacles < 0) {
    throw InputError(fmt::format("WarningSensorOptions.max_obstacles: expected >= 0, got {}", options.max_obstacles));
  }
  const int nc = static_cast<int>(robot.capsules.size());
  const int nq = robot.model.nq();
  on_moving_link_.assign(nc, 0);
  for (int c = 0; c < nc; ++c) {
    for (int i = 0; i < nq; ++i) on_moving_link_[c] |= robot.model.DofMovesLink(i, robot.capsules[c].link) ? 1 : 0;
  }
  contacts_.reserve(static_cast<size_t>(nc) * (options.max_obstacles + 1) + checker_.self_pairs().size());
}

void WarningSensor::Sense(const kinematics::Data& kin, const rmp::Scene& scene) {
  const kinematics::Robot& robot = *robot_;
  const double margin = options_.margin;
  // a pair whose bounding spheres are farther apart than this is not within the margin (the slack keeps a pair at
  // the margin's edge to the exact test)
  const double reach = margin + 1e-9;
  contacts_.clear();
  min_clearance_ = min_self_clearance_ = std::numeric_limits<double>::infinity();
  auto add = [&](int capsule, PartnerKind kind, int index, int other_capsule, const math::DistanceResult& r) {
    if (!(r.distance < margin)) return;
    WarningContact c;
    c.link = checker_.capsule(capsule).link;
    c.capsule = capsule;
    c.other_kind = kind;
    c.other_index = index;
    c.other_capsule = other_capsule;
    c.distance = r.distance;
    c.p_W1 = r.p_W1;
    c.p_W2 = r.p_W2;
    c.n_W = r.n_W;
    contacts_.push_back(c);
    double& slot = kind == PartnerKind::kLink ? min_self_clearance_ : min_clearance_;
    slot = std::min(slot, r.distance);
  };
  collision::PlaceRobot(checker_, kin, &placed_);
  const std::vector<math::Capsule>& world_capsules = placed_.capsule_W;
  const std::vector<Eigen::Vector4d>& spheres = placed_.capsule_sphere;
  const int nc = static_cast<int>(robot.capsules.size());
  const int no = static_cast<int>(scene.obstacles.size());
  for (int c = 0; c < nc; ++c) {
    const math::Capsule& cap = world_capsules[c];
    for (int j = 0; j < no; ++j) {
      const Eigen::Vector4d obstacle = rmp::BoundingSphere(scene.obstacles[j]);
      if ((spheres[c].head<3>() - obstacle.head<3>()).norm() - spheres[c][3] - obstacle[3] >= reach) continue;
      add(c, PartnerKind::kObstacle, j, -1, rmp::CapsuleObstacleDistance(cap, scene.obstacles[j]));
    }
    if (std::isfinite(options_.floor_height) && on_moving_link_[c]) {
      // the capsule's lowest axis end point against the plane z = floor_height
      const bool a_lower = cap.p_WA.z() <= cap.p_WB.z();
      math::DistanceResult r;
      const Eigen::Vector3d& axis_point = a_lower ? cap.p_WA : cap.p_WB;
      r.distance = axis_point.z() - options_.floor_height - cap.radius;
      r.n_W = Eigen::Vector3d::UnitZ();
      r.p_W1 = axis_point - cap.radius * r.n_W;
      r.p_W2 = Eigen::Vector3d(axis_point.x(), axis_point.y(), options_.floor_height);
      add(c, PartnerKind::kFloor, -1, -1, r);
    }
  }
  for (const auto& [c, d] : checker_.self_pairs()) {
    if ((spheres[c].head<3>() - spheres[d].head<3>()).norm() - spheres[c][3] - spheres[d][3] >= reach) continue;
    add(c, PartnerKind::kLink, checker_.capsule(d).link, d,
        math::CapsuleCapsuleDistance(world_capsules[c], world_capsules[d]));
  }
}

}  // namespace rmpmarl::control
