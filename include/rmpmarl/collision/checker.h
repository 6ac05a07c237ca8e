#pragma once
/// The robot collision checker: one place for what the robot's capsules touch. Check a configuration, check a
/// straight edge between two, the robot's clearance to the obstacles and its self-clearance, the pair that attains
/// it (the shape of Drake's CollisionChecker: CheckConfigCollisionFree, CheckEdgeCollisionFree, CalcRobotClearance).
/// The planner, the plan follower, the scenarios, the viewer, the warning sensor and the benchmark call it.
///
/// Model/Data split: a RobotCollisionModel is built once from a robot (its capsules grouped per link, the link pairs
/// checked for self-collision, which capsules can reach the floor); a RobotCollisionData holds the capsules placed at
/// one configuration and their bounding spheres, preallocated so that no query allocates.
///
/// What is checked. Obstacles: every capsule against every obstacle (rmp::CapsuleObstacleDistance). The floor plane
/// z = floor_height, when options.check_floor: every capsule whose height can change (not on a link fixed to the base
/// nor moved only by revolute joints about a vertical axis hanging from the fixed base — the Panda's joint-1 column
/// rests on its mounting plate by design). Self: every capsule pair of two different links that the robot does not
/// exclude (adjacent links, its SRDF's disabled pairs, the pairs setup-robot found never close) — on the robot's
/// self-collision capsules when it has a separate set (kinematics::Robot::self_capsules), else on its capsules. The
/// checker places both sets: capsule indices 0 … num_capsules() − 1 are the robot's capsules, the rest its
/// self-collision capsules (capsule(c) names either).
///
/// Broad phase. Each link's capsules share a bounding sphere; a link (then a capsule) whose sphere cannot come closer
/// to an obstacle than what was found is skipped, and for a box (or a cylinder's enclosing box) the box's own distance
/// at the sphere's centre, a tighter bound, decides. The spheres are fixed in their links' frames (built once, 1 nm
/// larger than the capsules so that rounding never makes one too small) and only moved with the link. Skipping only
/// pairs bounded below by the smallest distance found keeps the clearance exact; a check with a threshold (stop_below)
/// also skips pairs bounded above it and returns as soon as one distance is at or below it. A collision check first
/// tries the pair the last failing check on the same data failed on (a path's neighbouring configurations usually fail
/// on the same pair); the answer does not depend on that order.
#include <Eigen/Core>
#include <cstdint>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/math/geometry.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::collision {

/// Options of RobotCollisionModel.
struct RobotCollisionOptions {
  /// check the capsules against the floor plane z = floor_height (off for planar arms in the z = 0 plane).
  bool check_floor = true;
  double floor_height = 0.0;  ///< [m]
};

/// The pair of shapes that attains a clearance: which capsule came closest to what.
struct ClearancePair {
  enum class Kind {
    kNone,      ///< nothing was checked (a robot without capsules, a scene without obstacles and self pairs)
    kObstacle,  ///< a capsule of `link` and obstacles[obstacle]
    kFloor,     ///< a capsule of `link` and the floor plane
    kSelf,      ///< a capsule of `link` and one of `other_link`
  };
  double distance = std::numeric_limits<double>::infinity();  ///< the clearance [m]
  Kind kind = Kind::kNone;
  int link = -1;        ///< the link of the capsule attaining it (-1 for kNone)
  int other_link = -1;  ///< kSelf: the other capsule's link
  int obstacle = -1;    ///< kObstacle: its index in the obstacles given
  int capsule = -1;        ///< the capsule attaining it (RobotCollisionModel::capsule's index; -1 for kNone)
  int other_capsule = -1;  ///< kSelf: the other capsule
};

/// What the checker knows of a robot (immutable once built).
class RobotCollisionModel {
 public:
  /// the checker of (a copy of) `robot`. Throws InputError for a non-finite floor height.
  explicit RobotCollisionModel(const kinematics::Robot& robot, const RobotCollisionOptions& options = {});

  const kinematics::Robot& robot() const { return robot_; }
  const RobotCollisionOptions& options() const { return options_; }
  /// the robot's capsules (checked against obstacles and the floor): indices 0 … num_capsules() − 1
  int num_capsules() const { return static_cast<int>(robot_.capsules.size()); }
  /// every capsule placed: the robot's capsules, then its separate self-collision capsules (none without a set)
  int num_placed_capsules() const { return static_cast<int>(capsules_.size()); }
  const kinematics::LinkCapsule& capsule(int c) const { return capsules_[c]; }
  /// link_groups()[0, num_obstacle_groups()) hold the robot's capsules; the rest the self-collision set's
  int num_obstacle_groups() const { return num_obstacle_groups_; }

  /// The capsules of one link with capsules (a link's cover can hold many), split into clusters of at most
  /// kClusterSize neighbouring capsules, each with its own bounding sphere: a tight cover holds dozens of capsules
  /// per link, and a cluster far from an obstacle or from another link's cluster rules out all of its capsules at once.
  struct LinkGroup {
    int link = -1;
    std::vector<int> capsules;
    std::vector<int> clusters;  ///< indices into clusters(); one (all its capsules) when it holds ≤ kClusterSize
  };
  static constexpr int kClusterSize = 8;
  /// A cluster of one link group's capsules (recursive halving of the group along the widest spread of their
  /// spheres' centres; the group's own order when it is a single cluster).
  struct Cluster {
    int group = -1;
    std::vector<int> capsules;
  };
  const std::vector<Cluster>& clusters() const { return clusters_; }
  /// per cluster: a sphere around its capsules' spheres in the link's frame (centre, radius)
  const Eigen::Vector4d& cluster_sphere_L(int cluster) const { return cluster_sphere_L_[cluster]; }
  /// A checked pair of link groups and its capsule pairs, the range [begin, end) of grouped_self_pairs().
  struct LinkPair {
    int group_a = 0, group_b = 0;
    size_t begin = 0, end = 0;
  };
  const std::vector<LinkGroup>& link_groups() const { return link_groups_; }
  const std::vector<LinkPair>& self_link_pairs() const { return self_link_pairs_; }
  /// the checked capsule pairs grouped by their pair of links (self_link_pairs' ranges)
  const std::vector<std::pair<int, int>>& grouped_self_pairs() const { return grouped_self_pairs_; }
  /// the same pairs (a < b) in the order of the capsules: (0, 1), (0, 2), … — the simulated worlds' order (indices of
  /// capsule(); the self-collision set's when the robot has one)
  const std::vector<std::pair<int, int>>& self_pairs() const { return self_pairs_; }
  /// per capsule: checked against the floor (its height can change)
  bool floor_checked(int capsule) const { return floor_checked_[capsule] != 0; }
  /// per capsule: its bounding sphere in its link's frame (centre, radius)
  const Eigen::Vector4d& capsule_sphere_L(int capsule) const { return capsule_sphere_L_[capsule]; }
  /// per link group: a sphere around its capsules' spheres in the link's frame (centre, radius)
  const Eigen::Vector4d& group_sphere_L(int group) const { return group_sphere_L_[group]; }
  /// Per checked link pair p (self_link_pairs' order), the dofs i that move its two links relative to each other and
  /// their reach: how fast the two links' capsule segments can move relative to each other with q[i] [m/rad, m/m],
  /// for every configuration — the distance from the joint's axis to the farthest segment point of the link it moves,
  /// bounded along the chain (1 for a prismatic joint; joints above the pair's common ancestor move both alike and are
  /// not listed). The pair's distance at q' is then at least its distance at q less Σ reach |q'_i − q_i|. In dof
  /// order.
  struct DofReach {
    int dof = 0;
    double reach = 0.0;
  };
  std::span<const DofReach> self_pair_motion(size_t pair) const {
    return std::span<const DofReach>(self_pair_motion_)
        .subspan(self_pair_motion_begin_[pair], self_pair_motion_begin_[pair + 1] - self_pair_motion_begin_[pair]);
  }
  /// where pair's entries start in the flat list of every pair's (the layout of RobotCollisionData::self_bound_q)
  size_t self_pair_motion_begin(size_t pair) const { return self_pair_motion_begin_[pair]; }
  /// the flat list's length
  size_t self_pair_motion_size() const { return self_pair_motion_.size(); }

 private:
  kinematics::Robot robot_;
  RobotCollisionOptions options_;
  std::vector<kinematics::LinkCapsule> capsules_;
  int num_obstacle_groups_ = 0;
  std::vector<LinkGroup> link_groups_;
  std::vector<LinkPair> self_link_pairs_;
  std::vector<std::pair<int, int>> grouped_self_pairs_;
  std::vector<std::pair<int, int>> self_pairs_;
  std::vector<char> floor_checked_;
  std::vector<Cluster> clusters_;
  std::vector<Eigen::Vector4d> capsule_sphere_L_, group_sphere_L_, cluster_sphere_L_;
  std::vector<DofReach> self_pair_motion_;
  std::vector<size_t> self_pair_motion_begin_;
};

/// What the broad phase needs of an obstacle: its bounding sphere and, for a box or a cylinder, the box bounding it
/// (the box itself, or the cylinder's) with its inverse pose.
struct ObstacleBounds {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0.0;
  bool boxed = false;
  math::Box box;
  Eigen::Isometry3d X_BW = Eigen::Isometry3d::Identity();
};
/// the bounds of one obstacle.
ObstacleBounds BoundsOf(const rmp::Obstacle& obstacle);

/// Obstacles prepared for many checks (a planner's scene): a copy of them and their bounds, computed once instead of
/// at every check.
class PreparedObstacles {
 public:
  PreparedObstacles() = default;
  explicit PreparedObstacles(std::span<const rmp::Obstacle> obstacles) { Assign(obstacles); }
  /// prepares `obstacles`, reusing this object's storage (no allocation once it has held as many)
  void Assign(std::span<const rmp::Obstacle> obstacles);
  /// storage for n obstacles
  void Reserve(size_t n) {
    obstacles_.reserve(n);
    bounds_.reserve(n);
  }
  std::span<const rmp::Obstacle> obstacles() const { return obstacles_; }
  std::span<const ObstacleBounds> bounds() const { return bounds_; }

 private:
  std::vector<rmp::Obstacle> obstacles_;
  std::vector<ObstacleBounds> bounds_;
};

/// The robot's capsules placed at one configuration (preallocated for a model).
struct RobotCollisionData {
  explicit RobotCollisionData(const RobotCollisionModel& model);
  kinematics::Data kin;                       ///< the forward kinematics of the last PlaceRobot(q)
  std::vector<math::Capsule> capsule_W;        ///< per capsule, in world
  std::vector<Eigen::Vector4d> capsule_sphere;  ///< per capsule: bounding sphere (centre, radius)
  std::vector<Eigen::Vector4d> group_sphere;    ///< per link group: a sphere around its capsules' spheres
  std::vector<Eigen::Vector4d> cluster_sphere;  ///< per cluster: a sphere around its capsules' spheres
  ClearancePair last_hit;  ///< the pair the last failing CheckPlacedCollisionFree failed on (kNone: none yet)
  /// CheckConfigCollisionFree's lazy placement: a capsule's sphere and the capsule itself are up to date when their
  /// stamp equals `stamp`, which each such check advances
  std::vector<std::uint32_t> sphere_stamp, capsule_stamp, cluster_stamp;
  std::uint32_t stamp = 0;
  /// CheckConfigCollisionFree's memory of the self pairs: per checked link pair, a lower bound of its distance
  /// (−inf: none yet) at the configuration stored beside it (self_bound_q: the values of the pair's dofs,
  /// RobotCollisionModel::self_pair_motion, in the same flat layout); a later check skips the pair when that bound,
  /// less how far the links can have moved since, cannot matter
  std::vector<double> self_bound, self_bound_q;
};

/// places the capsules at q (forward kinematics into data->kin). \pre q of the model's size (checked by callers at
/// their boundary: kinematics::CheckJointVector).
void PlaceRobot(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q, RobotCollisionData* data);
/// places the capsules at the link poses of forward kinematics already computed (`kin` of the model's robot).
void PlaceRobot(const RobotCollisionModel& model, const kinematics::Data& kin, RobotCollisionData* data);
/// places the capsules at given link poses X_WL (one per link of the model, e.g. a simulator's bodies).
void PlaceRobot(const RobotCollisionModel& model, std::span<const Eigen::Isometry3d> X_WL, RobotCollisionData* data);

/// the smallest signed distance [m] between the placed capsules and `obstacles`, continuing from d (the smallest found
/// so far). Exact for stop_below = −inf; otherwise returns as soon as a distance is at or below stop_below (a value at
/// or below it exactly when the clearance is). `pair` (optional) receives the pair attaining the value returned, left
/// as it is unless a pair here comes closer than d.
double CalcObstacleClearance(const RobotCollisionModel& model, const RobotCollisionData& data,
                             std::span<const rmp::Obstacle> obstacles,
                             double stop_below = -std::numeric_limits<double>::infinity(),
                             double d = std::numeric_limits<double>::infinity(), ClearancePair* pair = nullptr);
/// the same for one obstacle (its index in `pair` is `index`).
double CalcObstacleClearance(const RobotCollisionModel& model, const RobotCollisionData& data,
                             const rmp::Obstacle& obstacle, int index = 0,
                             double stop_below = -std::numeric_limits<double>::infinity(),
                             double d = std::numeric_limits<double>::infinity(), ClearancePair* pair = nullptr);
/// the floor and self-collision part on the placed capsules, with the same conventions.
double CalcSelfClearance(const RobotCollisionModel& model, const RobotCollisionData& data,
                         double stop_below = -std::numeric_limits<double>::infinity(),
                         double d = std::numeric_limits<double>::infinity(), ClearancePair* pair = nullptr);
/// the smallest distance between capsules of checked link pairs alone (no floor), exact.
double CalcSelfCapsuleClearance(const RobotCollisionModel& model, const RobotCollisionData& data);

/// the placed capsules are clear of the obstacles by more than obstacle_margin and, unless obstacles_only, of the floor
/// and each other by more than self_margin. Tries data->last_hit first and records there the pair a failing check
/// failed on.
bool CheckPlacedCollisionFree(const RobotCollisionModel& model, std::span<const rmp::Obstacle> obstacles,
                              double obstacle_margin, double self_margin, bool obstacles_only, RobotCollisionData* data);

/// the robot's clearance at q: obstacles, floor and self pairs, exact, with the pair attaining it.
ClearancePair CalcRobotClearance(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                                 std::span<const rmp::Obstacle> obstacles, RobotCollisionData* data);
/// every checked distance at q exceeds `margin` (joint limits are the caller's).
bool CheckConfigCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                              std::span<const rmp::Obstacle> obstacles, double margin, RobotCollisionData* data);
/// the answer of PlaceRobot(q) then CheckPlacedCollisionFree, placing only what the check reaches: the forward
/// kinematics and the link groups' spheres first, a capsule's sphere when its group's sphere does not rule it out,
/// the capsule itself when its sphere does not (the same arithmetic, so the same answer, bit for bit). A pair of
/// links whose distance at an earlier check on the same data, less how far they can have moved since, exceeds the
/// self margin is skipped (RobotCollisionData::self_bound): it cannot fail the check, so the answer is the same.
/// Afterwards data->capsule_W and data->capsule_sphere hold only the capsules the check reached; PlaceRobot places
/// them all.
bool CheckConfigCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                              std::span<const rmp::Obstacle> obstacles, double obstacle_margin, double self_margin,
                              bool obstacles_only, RobotCollisionData* data);
/// the same against prepared obstacles (the same answer).
bool CheckConfigCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q,
                              const PreparedObstacles& obstacles, double obstacle_margin, double self_margin,
                              bool obstacles_only, RobotCollisionData* data);
/// calls visit(k) for every k in 1..n once, coarse to fine — n first, then the multiples of the largest power of two
/// not above n, then the odd multiples of each smaller power of two — and stops, returning false, as soon as visit
/// does. An edge through an obstacle usually fails at one of its first, far apart states; a free one visits them all.
template <typename Visit>
bool VisitEdgeStatesCoarseToFine(int n, Visit&& visit) {
  if (n < 1) return true;
  if (!visit(n)) return false;
  int top = 1;
  while (top <= n / 2) top *= 2;
  for (int stride = top; stride >= 1; stride /= 2) {
    for (int k = stride; k < n; k += stride) {
      if (stride != top && (k / stride) % 2 == 0) continue;  // visited at twice this stride
      if (!visit(k)) return false;
    }
  }
  return true;
}

/// every configuration of the straight edge q0 → q1 at most `resolution` apart in joint space (q0 excluded, q1
/// included) is collision-free with `margin`; they are checked coarse to fine (VisitEdgeStatesCoarseToFine).
/// \pre resolution > 0.
bool CheckEdgeCollisionFree(const RobotCollisionModel& model, const Eigen::Ref<const Eigen::VectorXd>& q0,
                            const Eigen::Ref<const Eigen::VectorXd>& q1, std::span<const rmp::Obstacle> obstacles,
                            double margin, double resolution, RobotCollisionData* data, Eigen::VectorXd* scratch);

}  // namespace rmpmarl::collision
