// The robot collision checker: capsules placed at a configuration against obstacles, the floor and each other.
#include "rmpmarl/collision/checker.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::collision {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// the broad phase's spheres are this much larger than what they bound [m], so that rounding in moving them with
// their links never leaves a capsule poking out of its sphere
constexpr double kSphereSlack = 1e-9;
// a remembered self-pair bound is lowered by this much more [m], far above the rounding of the distances and poses
// it compares (the bound holds for exact arithmetic)
constexpr double kBoundSlack = 1e-9;

// a pair whose distance is bounded below by `lower_bound` cannot lower the smallest distance d found so far, nor, in a
// check with a threshold (a finite stop_below), make the answer <= stop_below when the bound exceeds stop_below
bool CannotMatter(double lower_bound, double d, double stop_below) {
  return lower_bound >= d || (std::isfinite(stop_below) && lower_bound > stop_below);
}

// a lower bound of the distance between the bounding sphere (centre, radius) `a` and a sphere of `centre` and `radius`
// (both helpers sit in the check's innermost loops: inlined, as the copies they replace were)
__attribute__((always_inline)) inline double SphereGap(const Eigen::Vector4d& a, const Eigen::Vector3d& centre, double radius) {
  return (a.head<3>() - centre).norm() - a[3] - radius;
}

// a sphere (centre, radius) fixed in a link's frame, moved with the link to X_WL
__attribute__((always_inline)) inline Eigen::Vector4d MovedSphere(const Eigen::Vector4d& s_L, const Eigen::Isometry3d& X_WL) {
  Eigen::Vector4d s_W;
  s_W << X_WL * Eigen::Vector3d(s_L.head<3>()), s_L[3];
  return s_W;
}

// the bounding spheres of the link groups: their link-frame spheres moved with the links
template <typename Pose>
void GroupSpheres(const RobotCollisionModel& model, const Pose& X_WL, RobotCollisionData* data) {
  const auto& groups = model.link_groups();
  for (size_t g = 0; g < groups.size(); ++g) {
    data->group_sphere[g] = MovedSphere(model.group_sphere_L(static_cast<int>(g)), X_WL(groups[g].link));
  }
}

// the bounding spheres of the placed capsules and of each link group
template <typename Pose>
void BoundingSpheres(const RobotCollisionModel& model, const Pose& X_WL, RobotCollisionData* data) {
  for (int c = 0; c < model.num_placed_capsules(); ++c) {
    data->capsule_sphere[c] = MovedSphere(model.capsule_sphere_L(c), X_WL(model.capsule(c).link));
  }
  GroupSpheres(model, X_WL, data);
  const auto& clusters = model.clusters();
  for (size_t k = 0; k < clusters.size(); ++k) {
    data->cluster_sphere[k] =
        MovedSphere(model.cluster_sphere_L(static_cast<int>(k)), X_WL(model.link_groups()[clusters[k].group].link));
  }
}

// The placed capsules as a query reads them. Eager: PlaceRobot placed every one. Lazy: the forward kinematics and
// the group spheres are computed, a capsule's sphere and the capsule itself on first use (the same arithmetic as
// PlaceRobot's, so the same values).
struct EagerPlacement {
  const RobotCollisionData& data;
  // self pairs: nothing remembered
  bool SkipSelfPair(size_t /*pair*/, double /*d*/, double /*stop_below*/) const { return false; }
  void RememberSelfPair(size_t /*pair*/, double /*lower_bound*/) const {}
  const Eigen::Vector4d& group(size_t g) const { return data.group_sphere[g]; }
  const Eigen::Vector4d& cluster(int k) const { return data.cluster_sphere[k]; }
  const Eigen::Vector4d& sphere(int c) const { return data.capsule_sphere[c]; }
  const math::Capsule& capsule(int c) const { return data.capsule_W[c]; }
};

struct LazyPlacement {
  const RobotCollisionModel& model;
  RobotCollisionData& data;
  const double* q;  // the configuration placed
  // the link pair's remembered lower bound, less how far its links can have moved since, cannot matter
  bool SkipSelfPair(size_t pair, double d, double stop_below) const {
    double bound = data.self_bound[pair];
    if (bound == -kInf) return false;
    const std::span<const RobotCollisionModel::DofReach> motion = model.self_pair_motion(pair);
    const double* q_then = &data.self_bound_q[model.self_pair_motion_begin(pair)];
    for (size_t k = 0; k < motion.size(); ++k) bound -= motion[k].reach * std::abs(q[motion[k].dof] - q_then[k]);
    return CannotMatter(bound - kBoundSlack, d, stop_below);
  }
  void RememberSelfPair(size_t pair, double lower_bound) const {
    data.self_bound[pair] = lower_bound;
    const std::span<const RobotCollisionModel::DofReach> motion = model.self_pair_motion(pair);
    double* q_now = &data.self_bound_q[model.self_pair_motion_begin(pair)];
    for (size_t k = 0; k < motion.size(); ++k) q_now[k] = q[motion[k].dof];
  }
  const Eigen::Vector4d& group(size_t g) const { return data.group_sphere[g]; }
  const Eigen::Vector4d& cluster(int k) const {
    if (data.cluster_stamp[k] != data.stamp) {
      const int link = model.link_groups()[model.clusters()[k].group].link;
      data.cluster_sphere[k] = MovedSphere(model.cluster_sphere_L(k), data.kin.X_WL[link]);
      data.cluster_stamp[k] = data.stamp;
    }
    return data.cluster_sphere[k];
  }
  const Eigen::Vector4d& sphere(int c) const {
    if (data.sphere_stamp[c] != data.stamp) {
      data.capsule_sphere[c] = MovedSphere(model.capsule_sphere_L(c), data.kin.X_WL[model.capsule(c).link]);
      data.sphere_stamp[c] = data.stamp;
    }
    return data.capsule_sphere[c];
  }
  const math::Capsule& capsule(int c) const {
    if (data.capsule_stamp[c] != data.stamp) {
      data.capsule_W[c] = kinematics::WorldCapsule(model.capsule(c), data.kin);
      data.capsule_stamp[c] = data.stamp;
    }
    return data.capsule_W[c];
  }
};

// whether the bounding spheres of a pair as ClearancePair names it come within `margin` (the floor: always)
template <typename Placement>
bool PairMayCollide(const Placement& placed, std::span<const rmp::Obstacle> obstacles, const ClearancePair& pair,
                    double margin) {
  const Eigen::Vector4d& a = placed.sphere(pair.capsule);
  if (pair.kind == ClearancePair::Kind::kObstacle) {
    if (pair.obstacle < 0 || pair.obstacle >= static_cast<int>(obstacles.size())) return false;
    const rmp::Obstacle& o = obstacles[pair.obstacle];
    return SphereGap(a, rmp::Centre(o), rmp::BoundingRadius(o)) <= margin;
  }
  if (pair.kind == ClearancePair::Kind::kSelf) {
    const Eigen::Vector4d& b = placed.sphere(pair.other_capsule);
    return SphereGap(a, b.head<3>(), b[3]) <= margin;
  }
  return pair.kind == ClearancePair::Kind::kFloor;
}

// the distance of one pair as ClearancePair names it, on the placed capsules; +inf when it names nothing it can
// measure (kNone, or an obstacle index beyond those given)
template <typename Placement>
double PairDistance(const RobotCollisionModel& model, const Placement& placed,
                    std::span<const rmp::Obstacle> obstacles, const ClearancePair& pair) {
  switch (pair.kind) {
    case ClearancePair::Kind::kObstacle:
      if (pair.obstacle < 0 || pair.obstacle >= static_cast<int>(obstacles.size())) return kInf;
      return rmp::CapsuleObstacleDistance(placed.capsule(pair.capsule), obstacles[pair.obstacle]).distance;
    case ClearancePair::Kind::kFloor: {
      const math::Capsule& w = placed.capsule(pair.capsule);
      return std::min(w.p_WA.z(), w.p_WB.z()) - w.radius - model.options().floor_height;
    }
    case ClearancePair::Kind::kSelf:
      return math::CapsuleCapsuleDistance(placed.capsule(pair.capsule), placed.capsule(pair.other_capsule)).distance;
    case ClearancePair::Kind::kNone:
      break;
  }
  return kInf;
}

template <typename Placement>
double ObstacleClearance(const RobotCollisionModel& model, const Placement& placed, const rmp::Obstacle& o,
                         const ObstacleBounds& bounds, int index, double stop_below, double d, ClearancePair* pair) {
  auto cannot_matter = [&d, stop_below](double lower_bound) { return CannotMatter(lower_bound, d, stop_below); };
  const math::Box& box = bounds.box;
  // a sphere (centre, radius) that cannot come closer to the obstacle than what was found; for a box (or a
  // cylinder's enclosing box) the box's distance to the sphere, far tighter than the bounding spheres for a shelf's
  // board
  auto sphere_out = [&](const Eigen::Vector4d& sphere) {
    if (cannot_matter(SphereGap(sphere, bounds.centre, bounds.radius))) return true;
    if (!bounds.boxed) return false;
    // the box's signed distance at the sphere's centre, less the sphere's radius (1-Lipschitz: a lower bound)
    const Eigen::Vector3d p = (bounds.X_BW * Eigen::Vector3d(sphere.head<3>())).cwiseAbs() - box.half_size;
    return cannot_matter(p.cwiseMax(0.0).norm() + std::min(p.maxCoeff(), 0.0) - sphere[3]);
  };
  const auto& groups = model.link_groups();
  const auto& capsules = model.robot().capsules;
  const auto& clusters = model.clusters();
  for (size_t g = 0; g < static_cast<size_t>(model.num_obstacle_groups()); ++g) {
    if (sphere_out(placed.group(g))) continue;
    // a group of one cluster: the cluster's sphere is the group's
    const bool one_cluster = groups[g].clusters.size() == 1;
    for (int k : groups[g].clusters) {
      if (!one_cluster && sphere_out(placed.cluster(k))) continue;
      for (int c : clusters[k].capsules) {
        if (sphere_out(placed.sphere(c))) continue;
        const math::Capsule& w = placed.capsule(c);
        // a cylinder's enclosing box bounds it below
        if (o.shape == rmp::ObstacleShape::kCylinder && cannot_matter(math::CapsuleBoxDistance(w, box).distance)) {
          continue;
        }
        const double distance = rmp::CapsuleObstacleDistance(w, o).distance;
        if (distance < d) {
          d = distance;
          if (pair != nullptr) *pair = {d, ClearancePair::Kind::kObstacle, capsules[c].link, -1, index, c, -1};
        }
        if (d <= stop_below) return d;
      }
    }
  }
  return d;
}

// over every obstacle; `prepared` holds their bounds, or is empty (computed here)
template <typename Placement>
double ObstaclesClearance(const RobotCollisionModel& model, const Placement& placed,
                          std::span<const rmp::Obstacle> obstacles, std::span<const ObstacleBounds> prepared,
                          double stop_below, double d, ClearancePair* pair) {
  for (size_t k = 0; k < obstacles.size(); ++k) {
    ObstacleBounds computed;
    const ObstacleBounds& bounds = prepared.empty() ? (computed = BoundsOf(obstacles[k])) : prepared[k];
    d = ObstacleClearance(model, placed, obstacles[k], bounds, static_cast<int>(k), stop_below, d, pair);
    if (d <= stop_below) return d;
  }
  return d;
}

template <typename Placement>
double SelfClearance(const RobotCollisionModel& model, const Placement& placed, int num_capsules, double stop_below,
                     double d, ClearancePair* pair) {
  const RobotCollisionOptions& options = model.options();
  const auto& capsules = model.robot().capsules;
  if (options.check_floor) {
    for (int c = 0; c < num_capsules; ++c) {
      if (!model.floor_checked(c)) continue;
      const math::Capsule& w = placed.capsule(c);
      const double z = std::min(w.p_WA.z(), w.p_WB.z()) - w.radius;
      if (z - options.floor_height < d) {
        d = z - options.floor_height;
        if (pair != nullptr) *pair = {d, ClearancePair::Kind::kFloor, capsules[c].link, -1, -1, c, -1};
      }
      if (d <= stop_below) return d;
    }
  }
  const auto& pairs = model.grouped_self_pairs();
  const auto& link_pairs = model.self_link_pairs();
  const auto& groups = model.link_groups();
  const auto& clusters = model.clusters();
  auto sphere_gap = [](const Eigen::Vector4d& a, const Eigen::Vector4d& b) { return SphereGap(a, b.head<3>(), b[3]); };
  for (size_t p = 0; p < link_pairs.size(); ++p) {
    const RobotCollisionModel::LinkPair& links = link_pairs[p];
    if (placed.SkipSelfPair(p, d, stop_below)) continue;
    const double group_gap = sphere_gap(placed.group(links.group_a), placed.group(links.group_b));
    if (CannotMatter(group_gap, d, stop_below)) {
      placed.RememberSelfPair(p, group_gap);
      continue;
    }
    // of the link pair's distance: each capsule pair's distance, its spheres' gap or its clusters' gap
    double lower_bound = kInf;
    // one capsule pair; true when the check is decided
    auto capsule_pair = [&](int a, int b) {
      const double gap = sphere_gap(placed.sphere(a), placed.sphere(b));
      if (CannotMatter(gap, d, stop_below)) {
        lower_bound = std::min(lower_bound, gap);
        return false;
      }
      const double distance = math::CapsuleCapsuleDistance(placed.capsule(a), placed.capsule(b)).distance;
      lower_bound = std::min(lower_bound, distance);
      if (distance < d) {
        d = distance;
        if (pair != nullptr) {
          *pair = {d, ClearancePair::Kind::kSelf, model.capsule(a).link, model.capsule(b).link, -1, a, b};
        }
      }
      return d <= stop_below;
    };
    const std::vector<int>& clusters_a = groups[links.group_a].clusters;
    const std::vector<int>& clusters_b = groups[links.group_b].clusters;
    if (clusters_a.size() == 1 && clusters_b.size() == 1) {
      // one cluster each: their spheres are the groups' (already tested); the pairs in their flat list
      for (size_t i = links.begin; i < links.end; ++i) {
        if (capsule_pair(pairs[i].first, pairs[i].second)) return d;
      }
    } else {
      for (int ka : clusters_a) {
        for (int kb : clusters_b) {
          const double gap = sphere_gap(placed.cluster(ka), placed.cluster(kb));
          if (CannotMatter(gap, d, stop_below)) {
            lower_bound = std::min(lower_bound, gap);
            continue;
          }
          for (int a : clusters[ka].capsules) {
            for (int b : clusters[kb].capsules) {
              if (capsule_pair(a, b)) return d;
            }
          }
        }
      }
    }
    placed.RememberSelfPair(p, lower_bound);
  }
  return d;
}

template <typename Placement>
bool PlacedCollisionFree(const RobotCollisionModel& model, const Placement& placed,
                         std::span<const rmp::Obstacle> obstacles, std::span<const ObstacleBounds> prepared,
                         double obstacle_margin, double self_margin, bool obstacles_only, ClearancePair* last_hit) {
  ClearancePair& hit = *last_hit;
  if (hit.kind != ClearancePair::Kind::kNone && !(obstacles_only && hit.kind != ClearancePair::Kind::kObstacle)) {
    const double margin = hit.kind == ClearancePair::Kind::kObstacle ? obstacle_margin : self_margin;
    if (PairMayCollide(placed, obstacles, hit, margin) && PairDistance(model, placed, obstacles, hit) <= margin) {
      return false;
    }
  }
  ClearancePair pair;
  if (ObstaclesClearance(model, placed, obstacles, prepared, obstacle_margin, kInf, &pair) <= obstacle_margin ||
      (!obstacles_only &&
       SelfClearance(model, placed, model.num_capsules(), self_margin, kInf, &pair) <= self_margin)) {
    hit = pair;
    return false;
  }
  return true;
}

}  // namespace

ObstacleBounds BoundsOf(const rmp::Obstacle& o) {
  ObstacleBounds b;
  b.centre = rmp::Centre(o);
  b.radius = rmp::BoundingRadius(o);
  b.boxed = o.shape == rmp::ObstacleShape::kBox || o.shape == rmp::ObstacleShape::kCylinder;
  b.box = o.box;
  if (o.shape == rmp::ObstacleShape::kCylinder) {
    b.box = {o.cylinder.X_WC, Eigen::Vector3d(o.cylinder.radius, o.cylinder.radius, o.cylinder.half_length)};
  }
  b.X_BW = b.boxed ? b.box.X_WB.inverse() : Eigen::Isometry3d::Identity();
  return b;
}

void PreparedObstacles::Assign(std::span<const rmp::Obstacle> obstacles) {
  obstacles_.assign(obstacles.begin(), obstacles.end());
  bounds_.resize(obstacles.size());
  for (size_t k = 0; k < obstacles.size(); ++k) bounds_[k] = BoundsOf(obstacles[k]);
}

RobotCollisionModel::RobotCollisionModel(const kinematics::Robot& robot, const RobotCollisionOptions& options)
    : robot_(robot), options_(options) {
  if (!std::isfinite(options.floor_height)) {
    throw InputError(fmt::format("RobotCollisionOptions.floor_height: expected a finite height, got {}",
                                 options.floor_height));
  }
  const kinematics::Model& model = robot_.model;
  // a capsule's height is fixed when every dof moving its link is a revolute joint about a vertical axis whose parent
  // link is fixed to the base (axes taken at q = 0; they cannot move since the parent does not)
  capsules_ = robot_.capsules;
  capsules_.insert(capsules_.end(), robot_.self_capsules.begin(), robot_.self_capsules.end());
  kinematics::Data kin(model);
  kinematics::CalcForwardKinematics(model, Eigen::VectorXd::Zero(model.nq()), &kin);
  for (const kinematics::LinkCapsule& c : capsules_) {
    bool fixed_height = true;
    for (int i : model.link_dofs(c.link)) {
      const kinematics::Link& joint_link = model.link(model.dof_link(i));
      const bool revolute = joint_link.joint_type != kinematics::JointType::kPrismatic;
      const bool parent_fixed = model.link_dofs(joint_link.parent).empty();
      const bool vertical = std::abs(std::abs(kin.axis_W.col(i).z()) - 1.0) < 1e-9;
      fixed_height = fixed_height && revolute && parent_fixed && vertical;
    }
    floor_checked_.push_back(fixed_height ? 0 : 1);
  }
  // link groups of the capsules [begin, end), appended
  auto add_groups = [&](int begin, int end) {
    std::vector<int> group_of_link(model.num_links(), -1);
    for (int c = begin; c < end; ++c) {
      const int link = capsules_[c].link;
      if (group_of_link[link] < 0) {
        group_of_link[link] = static_cast<int>(link_groups_.size());
        link_groups_.push_back({link, {}, {}});
      }
      link_groups_[group_of_link[link]].capsules.push_back(c);
    }
  };
  const int num_capsules = static_cast<int>(robot_.capsules.size());
  const int num_placed = static_cast<int>(capsules_.size());
  add_groups(0, num_capsules);
  num_obstacle_groups_ = static_cast<int>(link_groups_.size());
  add_groups(num_capsules, num_placed);
  // the self pairs: of the self-collision set when there is one
  const bool separate = num_placed > num_capsules;
  const int self_begin = separate ? num_capsules : 0, self_end = separate ? num_placed : num_capsules;
  const int group_begin = separate ? num_obstacle_groups_ : 0;
  const int group_end = separate ? static_cast<int>(link_groups_.size()) : num_obstacle_groups_;
  for (int ga = group_begin; ga < group_end; ++ga) {
    for (int gb = ga + 1; gb < group_end; ++gb) {
      if (robot_.IsExcludedPair(link_groups_[ga].link, link_groups_[gb].link)) continue;
      LinkPair pair{ga, gb, grouped_self_pairs_.size(), 0};
      for (int a : link_groups_[ga].capsules) {
        for (int b : link_groups_[gb].capsules) grouped_self_pairs_.emplace_back(a, b);
      }
      pair.end = grouped_self_pairs_.size();
      self_link_pairs_.push_back(pair);
    }
  }
  for (int a = self_begin; a < self_end; ++a) {
    for (int b = a + 1; b < self_end; ++b) {
      const int la = capsules_[a].link, lb = capsules_[b].link;
      if (la != lb && !robot_.IsExcludedPair(la, lb)) self_pairs_.emplace_back(a, b);
    }
  }
  for (const kinematics::LinkCapsule& c : capsules_) {
    capsule_sphere_L_.emplace_back();
    capsule_sphere_L_.back() << 0.5 * (c.p_LA + c.p_LB), 0.5 * (c.p_LB - c.p_LA).norm() + c.radius + kSphereSlack;
  }
  // a sphere around the spheres of `members`: at their centres' mean, reaching the farthest
  auto sphere_around = [&](const std::vector<int>& members) {
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (int c : members) centre += capsule_sphere_L_[c].head<3>();
    centre /= static_cast<double>(members.size());
    double radius = 0.0;
    for (int c : members) {
      radius = std::max(radius, (capsule_sphere_L_[c].head<3>() - centre).norm() + capsule_sphere_L_[c][3]);
    }
    Eigen::Vector4d sphere;
    sphere << centre, radius + kSphereSlack;
    return sphere;
  };
  for (const LinkGroup& g : link_groups_) group_sphere_L_.push_back(sphere_around(g.capsules));
  // clusters: each group halved recursively along the widest spread of its capsules' sphere centres
  for (size_t g = 0; g < link_groups_.size(); ++g) {
    std::vector<std::vector<int>> pending = {link_groups_[g].capsules};
    while (!pending.empty()) {
      std::vector<int> members = std::move(pending.back());
      pending.pop_back();
      if (static_cast<int>(members.size()) <= kClusterSize) {
        link_groups_[g].clusters.push_back(static_cast<int>(clusters_.size()));
        cluster_sphere_L_.push_back(sphere_around(members));
        clusters_.push_back({static_cast<int>(g), std::move(members)});
        continue;
      }
      Eigen::AlignedBox3d box;
      for (int c : members) box.extend(Eigen::Vector3d(capsule_sphere_L_[c].head<3>()));
      int axis = 0;
      box.sizes().maxCoeff(&axis);
      std::stable_sort(members.begin(), members.end(), [&](int a, int b) {
        return capsule_sphere_L_[a][axis] < capsule_sphere_L_[b][axis];
      });
      const auto half = members.begin() + static_cast<long>(members.size() / 2);
      pending.emplace_back(half, members.end());
      pending.emplace_back(members.begin(), half);
    }
  }
  // how far each dof can move a link's capsule segments: walking up from the link, a joint's axis passes through its
  // link's origin, whose distance to every segment point is at most the farthest segment end point from the link's own
  // origin plus the joint offsets in between (triangle inequality, for every configuration)
  const int nq = model.nq();
  const int num_links = model.num_links();
  std::vector<double> segment_reach(num_links, 0.0);
  for (const kinematics::LinkCapsule& c : capsules_) {
    segment_reach[c.link] = std::max({segment_reach[c.link], c.p_LA.norm(), c.p_LB.norm()});
  }
  // reach of the dofs moving `link` relative to `ancestor` (its ancestor or itself), added into `out`
  auto add_reach = [&](int link, int ancestor, double* out) {
    double r = segment_reach[link];
    for (int m = link; m != ancestor && m > 0; m = model.link(m).parent) {
      const kinematics::Link& joint = model.link(m);
      const int dof = joint.q_index >= 0 ? joint.q_index : joint.mimic_dof;
      if (joint.moving() && dof >= 0) {
        const double factor = joint.q_index >= 0 ? 1.0 : std::abs(joint.mimic_multiplier);
        out[dof] += factor * (joint.joint_type == kinematics::JointType::kPrismatic ? 1.0 : r);
      }
      r += joint.X_PJ.translation().norm();
    }
  };
  auto ancestors = [&](int link) {
    std::vector<int> chain;
    for (int m = link; m >= 0; m = m > 0 ? model.link(m).parent : -1) chain.push_back(m);
    return chain;
  };
  self_pair_motion_begin_.assign(1, 0);
  std::vector<double> reach(nq);
  for (size_t p = 0; p < self_link_pairs_.size(); ++p) {
    const int la = link_groups_[self_link_pairs_[p].group_a].link, lb = link_groups_[self_link_pairs_[p].group_b].link;
    const std::vector<int> up_a = ancestors(la), up_b = ancestors(lb);
    int common = 0;
    for (int m : up_a) {
      if (std::find(up_b.begin(), up_b.end(), m) != up_b.end()) {
        common = m;
        break;
      }
    }
    std::fill(reach.begin(), reach.end(), 0.0);
    add_reach(la, common, reach.data());
    add_reach(lb, common, reach.data());
    // rounding of the sums above must not make a reach too small
    for (int i = 0; i < nq; ++i) {
      if (reach[i] > 0.0) self_pair_motion_.push_back({i, reach[i] * (1.0 + 1e-12)});
    }
    self_pair_motion_begin_.push_back(self_pair_motion_.size());
  }
}

RobotCollisionData::RobotCollisionData(const RobotCollisionModel& model)
    : kin(model.robot().model),
      capsule_W(model.num_placed_capsules()),
      capsule_sphere(model.num_placed_capsules()),
      group_sphere(model.link_groups().size()),
      cluster_sphere(model.clusters().size()),
      sphere_stamp(model.num_placed_capsules(), 0),
      capsule_stamp(model.num_placed_capsules(), 0),
      cluster_stamp(model.clusters().size(), 0),
      self_bound(model.self_link_pairs().size(), -kInf),
      self_bound_q(model.self_pair_motion_size(), 0.0) {}

void PlaceRobot(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                RobotCollisionData* data) {
  kinematics::CalcForwardKinematics(model.robot().model, q, &data->kin);
  PlaceRobot(model, data->kin, data);
}

void PlaceRobot(const RobotCollisionModel& model, const kinematics::Data& kin, RobotCollisionData* data) {
  for (int c = 0; c < model.num_placed_capsules(); ++c) data->capsule_W[c] = kinematics::WorldCapsule(model.capsule(c), kin);
  BoundingSpheres(model, [&kin](int link) -> const Eigen::Isometry3d& { return kin.X_WL[link]; }, data);
}

void PlaceRobot(const RobotCollisionModel& model, std::span<const Eigen::Isometry3d> X_WL, RobotCollisionData* data) {
  RMPMARL_ASSERT(static_cast<int>(X_WL.size()) == model.robot().model.num_links(), "PlaceRobot: one pose per link");
  for (int c = 0; c < model.num_placed_capsules(); ++c) {
    const kinematics::LinkCapsule& capsule = model.capsule(c);
    const Eigen::Isometry3d& X = X_WL[capsule.link];
    data->capsule_W[c] = {X * capsule.p_LA, X * capsule.p_LB, capsule.radius};
  }
  BoundingSpheres(model, [&X_WL](int link) -> const Eigen::Isometry3d& { return X_WL[link]; }, data);
}

double CalcObstacleClearance(const RobotCollisionModel& model, const RobotCollisionData& data,
                             const rmp::Obstacle& o, int index, double stop_below, double d, ClearancePair* pair) {
  return ObstacleClearance(model, EagerPlacement{data}, o, BoundsOf(o), index, stop_below, d, pair);
}

double CalcObstacleClearance(const RobotCollisionModel& model, const RobotCollisionData& data,
                             std::span<const rmp::Obstacle> obstacles, double stop_below, double d,
                             ClearancePair* pair) {
  return ObstaclesClearance(model, EagerPlacement{data}, obstacles, {}, stop_below, d, pair);
}

double CalcSelfClearance(const RobotCollisionModel& model, const RobotCollisionData& data, double stop_below,
                         double d, ClearancePair* pair) {
  return SelfClearance(model, EagerPlacement{data}, model.num_capsules(), stop_below, d, pair);
}

double CalcSelfCapsuleClearance(const RobotCollisionModel& model, const RobotCollisionData& data) {
  double d = kInf;
  for (const auto& [a, b] : model.self_pairs()) {
    d = std::min(d, math::CapsuleCapsuleDistance(data.capsule_W[a], data.capsule_W[b]).distance);
  }
  return d;
}

ClearancePair CalcRobotClearance(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                                 std::span<const rmp::Obstacle> obstacles, RobotCollisionData* data) {
  PlaceRobot(model, q, data);
  ClearancePair pair;
  const double d = CalcObstacleClearance(model, *data, obstacles, -kInf, kInf, &pair);
  CalcSelfClearance(model, *data, -kInf, d, &pair);
  return pair;
}

bool CheckPlacedCollisionFree(const RobotCollisionModel& model, std::span<const rmp::Obstacle> obstacles,
                              double obstacle_margin, double self_margin, bool obstacles_only,
                              RobotCollisionData* data) {
  return PlacedCollisionFree(model, EagerPlacement{*data}, obstacles, {}, obstacle_margin, self_margin,
                             obstacles_only, &data->last_hit);
}

bool CheckConfigCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                              std::span<const rmp::Obstacle> obstacles, double margin, RobotCollisionData* data) {
  return CheckConfigCollisionFree(model, q, obstacles, margin, margin, false, data);
}

namespace {

// the forward kinematics and the link groups' spheres at q, every capsule's sphere and the capsule left to first use
LazyPlacement PlaceLazily(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                          RobotCollisionData* data) {
  kinematics::CalcForwardKinematics(model.robot().model, q, &data->kin);
  GroupSpheres(model, [data](int link) -> const Eigen::Isometry3d& { return data->kin.X_WL[link]; }, data);
  if (++data->stamp == 0) {  // wrapped around: no stamp may look current
    std::fill(data->sphere_stamp.begin(), data->sphere_stamp.end(), 0);
    std::fill(data->capsule_stamp.begin(), data->capsule_stamp.end(), 0);
    std::fill(data->cluster_stamp.begin(), data->cluster_stamp.end(), 0);
    data->stamp = 1;
  }
  return LazyPlacement{model, *data, q.data()};
}

}  // namespace

bool CheckConfigCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                              std::span<const rmp::Obstacle> obstacles, double obstacle_margin, double self_margin,
                              bool obstacles_only, RobotCollisionData* data) {
  return PlacedCollisionFree(model, PlaceLazily(model, q, data), obstacles, {}, obstacle_margin, self_margin,
                             obstacles_only, &data->last_hit);
}

bool CheckConfigCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                              const PreparedObstacles& obstacles, double obstacle_margin, double self_margin,
                              bool obstacles_only, RobotCollisionData* data) {
  return PlacedCollisionFree(model, PlaceLazily(model, q, data), obstacles.obstacles(), obstacles.bounds(),
                             obstacle_margin, self_margin, obstacles_only, &data->last_hit);
}

bool CheckEdgeCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q0,
                            const Eigen::Ref<const Eigen::VectorXd>& q1, std::span<const rmp::Obstacle> obstacles,
                            double margin, double resolution, RobotCollisionData* data, Eigen::VectorXd* scratch) {
  RMPMARL_ASSERT(resolution > 0.0, "CheckEdgeCollisionFree: resolution > 0");
  const int n = std::max(1, static_cast<int>(std::ceil((q1 - q0).norm() / resolution)));
  return VisitEdgeStatesCoarseToFine(n, [&](int k) {
    *scratch = q0 + (static_cast<double>(k) / n) * (q1 - q0);
    return CheckConfigCollisionFree(model, *scratch, obstacles, margin, data);
  });
}

}  // namespace rmpmarl::collision
