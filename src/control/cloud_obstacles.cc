// Point-cloud obstacles: filter, downsample, self-filter, cluster, track (see the header for the steps).
#include "rmpmarl/control/cloud_obstacles.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "rmpmarl/common/error.h"

namespace rmpmarl::control {
namespace {

constexpr std::int64_t kEmpty = -1;
constexpr int kKeyBits = 21;
constexpr std::int64_t kKeyOffset = std::int64_t{1} << (kKeyBits - 1);

std::int64_t PackKey(std::int64_t ix, std::int64_t iy, std::int64_t iz) {
  return ((ix + kKeyOffset) << (2 * kKeyBits)) | ((iy + kKeyOffset) << kKeyBits) | (iz + kKeyOffset);
}

size_t HashSlot(std::int64_t key, size_t mask) {
  std::uint64_t h = static_cast<std::uint64_t>(key) * 0x9E3779B97F4A7C15ull;
  return static_cast<size_t>(h >> 17) & mask;
}

std::string Vec(const Eigen::Vector3d& v) { return fmt::format("[{:g}, {:g}, {:g}]", v.x(), v.y(), v.z()); }

}  // namespace

std::int64_t VoxelKey(const Eigen::Vector3d& p_W, double inv_voxel_size) {
  return PackKey(static_cast<std::int64_t>(std::floor(p_W.x() * inv_voxel_size)),
                 static_cast<std::int64_t>(std::floor(p_W.y() * inv_voxel_size)),
                 static_cast<std::int64_t>(std::floor(p_W.z() * inv_voxel_size)));
}

void ValidateCloudObstacleOptions(const CloudObstacleOptions& o) {
  auto fail = [](std::string_view field, std::string_view expected, const std::string& got) {
    throw InputError(fmt::format("CloudObstacleOptions.{}: expected {}, got {}", field, expected, got));
  };
  if (!(o.voxel_size >= 0.001 && o.voxel_size <= 0.5)) fail("voxel_size", "a size in [0.001, 0.5] m", fmt::format("{}", o.voxel_size));
  if (o.workspace) {
    const Eigen::Vector3d lo = o.workspace->min(), hi = o.workspace->max();
    if (!lo.allFinite() || !hi.allFinite() || !(hi.array() > lo.array()).all()) {
      fail("workspace", "a finite box with min < max", fmt::format("min {} max {}", Vec(lo), Vec(hi)));
    }
    if (((hi - lo) / o.voxel_size).maxCoeff() >= static_cast<double>(kKeyOffset) ||
        (lo.cwiseAbs().cwiseMax(hi.cwiseAbs()) / o.voxel_size).maxCoeff() >= static_cast<double>(kKeyOffset)) {
      fail("workspace", fmt::format("a box within ±{} voxels of the origin", kKeyOffset),
           fmt::format("min {} max {} at voxel size {}", Vec(lo), Vec(hi), o.voxel_size));
    }
  }
  if (!(o.self_filter_margin >= 0.0 && o.self_filter_margin <= 0.5)) {
    fail("self_filter_margin", "a margin in [0, 0.5] m", fmt::format("{}", o.self_filter_margin));
  }
  if (!(o.point_margin >= 0.0 && o.point_margin <= 0.2)) {
    fail("point_margin", "a margin in [0, 0.2] m", fmt::format("{}", o.point_margin));
  }
  if (o.min_cluster_voxels < 1) fail("min_cluster_voxels", "at least 1", fmt::format("{}", o.min_cluster_voxels));
  if (o.max_obstacles < 1 || o.max_obstacles > 256) {
    fail("max_obstacles", "a count in [1, 256]", fmt::format("{}", o.max_obstacles));
  }
  if (o.max_points < 1) fail("max_points", "at least 1", fmt::format("{}", o.max_points));
  if (!(o.unit_check_distance > 0.0)) fail("unit_check_distance", "a distance > 0 m", fmt::format("{}", o.unit_check_distance));
  if (!(o.track_gate > 0.0 && std::isfinite(o.track_gate))) fail("track_gate", "a finite distance > 0 m", fmt::format("{}", o.track_gate));
  if (o.velocity_window < 2 || o.velocity_window > 16) {
    fail("velocity_window", "a number of updates in [2, 16]", fmt::format("{}", o.velocity_window));
  }
  if (!(o.max_speed > 0.0 && std::isfinite(o.max_speed))) fail("max_speed", "a finite speed > 0 m/s", fmt::format("{}", o.max_speed));
  if (!(o.min_speed >= 0.0 && o.min_speed < o.max_speed)) {
    fail("min_speed", fmt::format("a speed in [0, max_speed = {}) m/s", o.max_speed), fmt::format("{}", o.min_speed));
  }
}

Eigen::AlignedBox3d ReachCrop(const kinematics::Robot& robot, double margin) {
  // the farthest any link frame gets from its parent's, summed along the longest chain, plus the capsules' extent
  const kinematics::Model& m = robot.model;
  std::vector<double> reach(m.num_links(), 0.0);
  double most = 0.0;
  for (int k = 0; k < m.num_links(); ++k) {  // parents come before children
    const kinematics::Link& link = m.link(k);
    double r = link.parent >= 0 ? reach[link.parent] + link.X_PJ.translation().norm() : 0.0;
    if (link.joint_type == kinematics::JointType::kPrismatic && link.q_index >= 0) {
      const kinematics::DofLimits& lim = m.limits()[link.q_index];
      r += std::max(std::abs(lim.lower), std::abs(lim.upper));
    }
    reach[k] = r;
    most = std::max(most, r);
  }
  for (const kinematics::LinkCapsule& c : robot.capsules) {
    most = std::max(most, reach[c.link] + std::max(c.p_LA.norm(), c.p_LB.norm()) + c.radius);
  }
  const Eigen::Vector3d half = Eigen::Vector3d::Constant(most + margin);
  return {-half, half};
}

Eigen::AlignedBox3d FloorCrop(double floor_height) {
  return {Eigen::Vector3d(-2.0, -2.0, floor_height + 0.03), Eigen::Vector3d(2.0, 2.0, floor_height + 2.5)};
}

CloudObstacles::CloudObstacles(const kinematics::Robot& robot, CloudObstacleOptions options)
    : robot_(robot), options_(std::move(options)), kin_(robot_.model) {
  ValidateCloudObstacleOptions(options_);
  workspace_ = options_.workspace ? *options_.workspace : ReachCrop(robot_);
  if (!options_.workspace) {
    CloudObstacleOptions resolved = options_;
    resolved.workspace = workspace_;
    ValidateCloudObstacleOptions(resolved);  // an arm of kilometres' reach: refused as any box that large
  }
  capsules_W_.resize(robot_.capsules.size());
  indices_.resize(options_.max_obstacles);
  slot_points_.resize(options_.max_obstacles);
  slot_counts_.resize(options_.max_obstacles);
  clusters_.reserve(options_.max_obstacles);
}

void CloudObstacles::Reset() {
  tracks_.clear();
  clusters_.clear();
  kept_.resize(3, 0);
  last_time_ = -1.0;
  has_update_ = false;
  stats_ = {};
}

const CloudUpdateStats& CloudObstacles::UpdateInBaseFrame(const Eigen::Ref<const Eigen::Matrix3Xd>& p_B, double time,
                                                          const Eigen::Ref<const Eigen::VectorXd>& q) {
  // the root link is fixed to the world: its pose does not depend on q
  kinematics::CalcForwardKinematics(robot_.model, Eigen::VectorXd::Zero(robot_.model.nq()), &kin_);
  const Eigen::Isometry3d X_WB = kin_.X_WL[0];
  Eigen::Matrix3Xd p_W = (X_WB.linear() * p_B).colwise() + X_WB.translation();
  return Update(p_W, time, q);
}

const CloudUpdateStats& CloudObstacles::Update(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, double time,
                                               const Eigen::Ref<const Eigen::VectorXd>& q) {
  static const Eigen::Matrix3Xd kNone(3, 0);
  static const std::vector<int> kNoCounts;
  return Update(p_W, time, q, kNone, kNoCounts);
}

const CloudUpdateStats& CloudObstacles::Update(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, double time,
                                               const Eigen::Ref<const Eigen::VectorXd>& q,
                                               const Eigen::Matrix3Xd& remembered_W,
                                               const std::vector<int>& remembered_counts) {
  const auto start = std::chrono::steady_clock::now();
  const long n = p_W.cols();
  if (static_cast<size_t>(remembered_W.cols()) != remembered_counts.size()) {
    throw InputError(fmt::format("point cloud update: expected one count per remembered point ({}), got {}",
                                 remembered_W.cols(), remembered_counts.size()));
  }
  for (int c : remembered_counts) {
    if (c < 1) throw InputError(fmt::format("point cloud update: expected remembered counts ≥ 1, got {}", c));
  }
  if (n > options_.max_points) {
    throw InputError(fmt::format("point cloud: expected at most {} points (CloudObstacleOptions.max_points), got {}; "
                                 "downsample it first or raise the limit", options_.max_points, n));
  }
  if (q.size() != robot_.model.nq() || !q.allFinite()) {
    throw InputError(fmt::format("point cloud update: expected a finite configuration of {} joints, got {} entries{}",
                                 robot_.model.nq(), q.size(), q.allFinite() ? "" : " (not finite)"));
  }
  if (!std::isfinite(time) || (has_update_ && time < last_time_)) {
    throw InputError(fmt::format("point cloud update: expected a finite time ≥ the last update's {} s, got {}",
                                 last_time_, time));
  }
  kinematics::CalcForwardKinematics(robot_.model, q, &kin_);
  // a cloud in millimetres: its median distance from the base is a thousand times a room's
  sample_.clear();
  const Eigen::Vector3d p_WB = kin_.X_WL[0].translation();
  const long stride = std::max(1L, n / 512);
  for (long i = 0; i < n; i += stride) {
    if (p_W.col(i).allFinite()) sample_.push_back((p_W.col(i) - p_WB).norm());
  }
  if (!sample_.empty()) {
    auto mid = sample_.begin() + static_cast<long>(sample_.size() / 2);
    std::nth_element(sample_.begin(), mid, sample_.end());
    if (*mid > options_.unit_check_distance) {
      throw InputError(fmt::format("point cloud: the median point is {:.1f} m from the robot's base, more than {} m "
                                   "(CloudObstacleOptions.unit_check_distance): is the cloud in millimetres? Scale it "
                                   "by 0.001 to metres", *mid, options_.unit_check_distance));
    }
  }
  stats_ = {};
  stats_.input_points = n;
  auto lap = [last = start]() mutable {
    const auto now = std::chrono::steady_clock::now();
    const double us = std::chrono::duration<double, std::micro>(now - last).count();
    last = now;
    return us;
  };
  Downsample(p_W, remembered_W, remembered_counts);
  stats_.downsample_us = lap();
  SelfFilter(q);
  stats_.filter_us = lap();
  Cluster();
  stats_.cluster_us = lap();
  UpdateTracks(time);
  stats_.track_us = lap();
  last_time_ = time;
  has_update_ = true;
  stats_.time_us = std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
  return stats_;
}

void CloudObstacles::Downsample(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, const Eigen::Matrix3Xd& remembered_W,
                                const std::vector<int>& remembered_counts) {
  const long n = p_W.cols(), m = remembered_W.cols();
  size_t size = 64;
  while (size < 2 * static_cast<size_t>(n + m)) size <<= 1;
  table_keys_.assign(size, kEmpty);
  table_voxel_.resize(size);
  voxel_key_.clear();
  voxel_sum_.clear();
  voxel_count_.clear();
  const size_t mask = size - 1;
  const double inv = 1.0 / options_.voxel_size;
  const Eigen::AlignedBox3d& box = workspace_;
  // a point standing for `count` points of the cloud
  auto add = [&](const Eigen::Vector3d& p, int count) {
    if (!p.allFinite()) {
      ++stats_.nonfinite_points;
      return;
    }
    if (!box.contains(p)) {
      ++stats_.outside_points;
      return;
    }
    const std::int64_t key = VoxelKey(p, inv);
    size_t slot = HashSlot(key, mask);
    while (table_keys_[slot] != kEmpty && table_keys_[slot] != key) slot = (slot + 1) & mask;
    if (table_keys_[slot] == kEmpty) {
      table_keys_[slot] = key;
      table_voxel_[slot] = static_cast<int>(voxel_key_.size());
      voxel_key_.push_back(key);
      voxel_sum_.push_back(count * p);
      voxel_count_.push_back(count);
    } else {
      const int v = table_voxel_[slot];
      voxel_sum_[v] += count * p;
      voxel_count_[v] += count;
    }
  };
  for (long i = 0; i < n; ++i) add(p_W.col(i), 1);
  for (long i = 0; i < m; ++i) add(remembered_W.col(i), remembered_counts[i]);
  stats_.voxels = static_cast<long>(voxel_key_.size());
  // voxel_sum_ becomes the centroid
  for (size_t v = 0; v < voxel_sum_.size(); ++v) voxel_sum_[v] /= voxel_count_[v];
}

void CloudObstacles::SelfFilter(const Eigen::Ref<const Eigen::VectorXd>&) {
  const int nc = static_cast<int>(robot_.capsules.size());
  Eigen::AlignedBox3d robot_box;
  double reach = 0.0;
  for (int c = 0; c < nc; ++c) {
    const kinematics::LinkCapsule& lc = robot_.capsules[c];
    capsules_W_[c] = {kin_.X_WL[lc.link] * lc.p_LA, kin_.X_WL[lc.link] * lc.p_LB, lc.radius};
    robot_box.extend(capsules_W_[c].p_WA);
    robot_box.extend(capsules_W_[c].p_WB);
    reach = std::max(reach, lc.radius);
  }
  const double margin = options_.self_filter_margin;
  robot_box = Eigen::AlignedBox3d(robot_box.min().array() - (reach + margin),
                                  robot_box.max().array() + (reach + margin));
  const size_t nv = voxel_key_.size();
  voxel_robot_.assign(nv, 0);
  for (size_t v = 0; v < nv; ++v) {
    const Eigen::Vector3d& p = voxel_sum_[v];
    if (nc == 0 || !robot_box.contains(p)) continue;
    for (int c = 0; c < nc; ++c) {
      const math::Capsule& cap = capsules_W_[c];
      const Eigen::Vector3d d = cap.p_WB - cap.p_WA;
      const double dd = d.squaredNorm();
      const double t = dd > 0.0 ? std::clamp((p - cap.p_WA).dot(d) / dd, 0.0, 1.0) : 0.0;
      const double r = cap.radius + margin;
      if ((p - cap.p_WA - t * d).squaredNorm() <= r * r) {
        voxel_robot_[v] = 1;
        ++stats_.robot_voxels;
        break;
      }
    }
  }
}

int CloudObstacles::Find(int v) {
  while (parent_[v] != v) {
    parent_[v] = parent_[parent_[v]];
    v = parent_[v];
  }
  return v;
}

void CloudObstacles::Cluster() {
  const int nv = static_cast<int>(voxel_key_.size());
  parent_.resize(nv);
  std::iota(parent_.begin(), parent_.end(), 0);
  const size_t mask = table_keys_.size() - 1;
  auto lookup = [&](std::int64_t key) {
    size_t slot = HashSlot(key, mask);
    while (table_keys_[slot] != kEmpty) {
      if (table_keys_[slot] == key) return table_voxel_[slot];
      slot = (slot + 1) & mask;
    }
    return -1;
  };
  const std::int64_t sx = std::int64_t{1} << (2 * kKeyBits), sy = std::int64_t{1} << kKeyBits;
  for (int v = 0; v < nv; ++v) {
    if (voxel_robot_[v]) continue;
    // the 13 neighbours "after" v in lexicographic order: each touching pair is joined once
    for (int dx = 0; dx <= 1; ++dx) {
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dz = -1; dz <= 1; ++dz) {
          if (dx == 0 && (dy < 0 || (dy == 0 && dz <= 0))) continue;
          const int u = lookup(voxel_key_[v] + dx * sx + dy * sy + dz);
          if (u < 0 || voxel_robot_[u]) continue;
          const int a = Find(u), b = Find(v);
          if (a != b) parent_[std::max(a, b)] = std::min(a, b);
        }
      }
    }
  }
  // components: sizes and centroids, in order of their first voxel (deterministic)
  voxel_cluster_.assign(nv, -1);
  std::vector<CloudCluster>& all = clusters_;
  all.clear();
  std::vector<int>& root_cluster = root_cluster_;
  root_cluster.assign(nv, -1);
  for (int v = 0; v < nv; ++v) {
    if (voxel_robot_[v]) continue;
    const int root = Find(v);
    if (root_cluster[root] < 0) {
      root_cluster[root] = static_cast<int>(all.size());
      all.emplace_back();
    }
    CloudCluster& c = all[root_cluster[root]];
    // weighted by the voxel's points: the centroid of the raw points, which moves with the object rather than in
    // voxel-sized steps
    c.centroid_W += voxel_count_[v] * voxel_sum_[v];
    ++c.voxels;
    c.points += voxel_count_[v];
    voxel_cluster_[v] = root_cluster[root];
  }
  // drop speckle, measure each cluster's clearance from the arm, order nearest first
  std::vector<int> order;
  order.reserve(all.size());
  for (int k = 0; k < static_cast<int>(all.size()); ++k) {
    CloudCluster& c = all[k];
    c.centroid_W /= static_cast<double>(c.points);
    if (c.voxels < options_.min_cluster_voxels) {
      ++stats_.speckle_clusters;
      continue;
    }
    c.clearance = std::numeric_limits<double>::infinity();
    for (const math::Capsule& cap : capsules_W_) {
      const Eigen::Vector3d d = cap.p_WB - cap.p_WA;
      const double dd = d.squaredNorm();
      const double t = dd > 0.0 ? std::clamp((c.centroid_W - cap.p_WA).dot(d) / dd, 0.0, 1.0) : 0.0;
      c.clearance = std::min(c.clearance, (c.centroid_W - cap.p_WA - t * d).norm() - cap.radius);
    }
    order.push_back(k);
  }
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return all[a].clearance < all[b].clearance; });
  stats_.clusters = static_cast<int>(order.size());
  const int slots = std::min(static_cast<int>(order.size()), options_.max_obstacles);
  const int num_kept = static_cast<int>(order.size());
  stats_.merged_clusters = num_kept > options_.max_obstacles ? num_kept - options_.max_obstacles + 1 : 0;
  std::vector<int> slot_of(all.size(), -1);
  for (int s = 0; s < static_cast<int>(order.size()); ++s) slot_of[order[s]] = std::min(s, slots - 1);
  // the slots' points, their indices and the obstacles' summaries
  std::vector<int> counts(slots, 0);
  long kept = 0;
  for (int v = 0; v < nv; ++v) {
    if (voxel_cluster_[v] < 0) continue;
    voxel_cluster_[v] = slot_of[voxel_cluster_[v]];
    if (voxel_cluster_[v] >= 0) {
      ++counts[voxel_cluster_[v]];
      ++kept;
    }
  }
  std::vector<CloudCluster> merged(slots);
  for (int s = 0; s < slots; ++s) {
    slot_points_[s].resize(3, counts[s]);
    slot_counts_[s].resize(counts[s]);
  }
  kept_.resize(3, kept);
  std::fill(counts.begin(), counts.end(), 0);
  long k = 0;
  for (int v = 0; v < nv; ++v) {
    const int s = voxel_cluster_[v];
    if (s < 0) continue;
    slot_counts_[s][counts[s]] = voxel_count_[v];
    slot_points_[s].col(counts[s]++) = voxel_sum_[v];
    kept_.col(k++) = voxel_sum_[v];
    merged[s].centroid_W += voxel_count_[v] * voxel_sum_[v];
    ++merged[s].voxels;
    merged[s].points += voxel_count_[v];
  }
  for (int s = 0; s < slots; ++s) {
    merged[s].centroid_W /= static_cast<double>(merged[s].points);
    merged[s].clearance = all[order[s]].clearance;
    indices_[s].Build(slot_points_[s]);
  }
  clusters_ = std::move(merged);
}

void CloudObstacles::UpdateTracks(double time) {
  const double dt = has_update_ ? time - last_time_ : 0.0;
  const bool merged_last = stats_.merged_clusters > 0;
  const int n = static_cast<int>(clusters_.size());
  // greedy matching, closest (cluster, predicted track) pairs first
  struct Pair {
    double d;
    int cluster, track;
  };
  std::vector<Pair> pairs;
  for (int c = 0; c < n; ++c) {
    if (merged_last && c == n - 1) continue;  // the merged slot is not one object: at rest, untracked
    for (int t = 0; t < static_cast<int>(tracks_.size()); ++t) {
      const Eigen::Vector3d predicted = tracks_[t].centroid_W + dt * tracks_[t].v_WO;
      const double d = (clusters_[c].centroid_W - predicted).norm();
      if (d <= options_.track_gate) pairs.push_back({d, c, t});
    }
  }
  std::sort(pairs.begin(), pairs.end(), [](const Pair& a, const Pair& b) {
    return a.d < b.d || (a.d == b.d && (a.cluster < b.cluster || (a.cluster == b.cluster && a.track < b.track)));
  });
  std::vector<int> cluster_track(n, -1);
  std::vector<char> track_used(tracks_.size(), 0);
  for (const Pair& p : pairs) {
    if (cluster_track[p.cluster] >= 0 || track_used[p.track]) continue;
    cluster_track[p.cluster] = p.track;
    track_used[p.track] = 1;
  }
  next_tracks_.clear();
  const int window = options_.velocity_window;
  for (int c = 0; c < n; ++c) {
    CloudCluster& cl = clusters_[c];
    if (merged_last && c == n - 1) continue;
    Track t;
    t.centroid_W = cl.centroid_W;
    if (cluster_track[c] >= 0) {
      const Track& old = tracks_[cluster_track[c]];
      t.id = old.id;
      t.age = old.age + 1;
      t.v_WO = old.v_WO;
      // the window goes on, its oldest entry dropped when full
      const int keep = std::min(old.count, window - 1);
      for (int k = 0; k < keep; ++k) {
        t.t[k] = old.t[old.count - keep + k];
        t.c[k] = old.c[old.count - keep + k];
      }
      t.count = keep;
    } else {
      t.id = next_track_id_++;
      // a piece split off a followed object (the arm or the image border cuts it in two) moves with it: it inherits
      // the velocity of the nearest track's prediction within the gate; anything else starts at rest
      double nearest = options_.track_gate;
      for (const Track& old : tracks_) {
        const double d = (cl.centroid_W - (old.centroid_W + dt * old.v_WO)).norm();
        if (d < nearest) {
          nearest = d;
          t.v_WO = old.v_WO;
        }
      }
    }
    t.t[t.count] = time;
    t.c[t.count] = cl.centroid_W;
    ++t.count;
    if (options_.estimate_velocity && t.count >= 2) {
      // least-squares slope of centroid against time over the window
      double tm = 0.0;
      Eigen::Vector3d cm = Eigen::Vector3d::Zero();
      for (int k = 0; k < t.count; ++k) {
        tm += t.t[k];
        cm += t.c[k];
      }
      tm /= t.count;
      cm /= t.count;
      double stt = 0.0;
      Eigen::Vector3d stc = Eigen::Vector3d::Zero();
      for (int k = 0; k < t.count; ++k) {
        stt += (t.t[k] - tm) * (t.t[k] - tm);
        stc += (t.t[k] - tm) * (t.c[k] - cm);
      }
      if (stt > 0.0) t.v_WO = stc / stt;
      const double speed = t.v_WO.norm();
      if (speed > options_.max_speed) t.v_WO *= options_.max_speed / speed;
    }
    if (!options_.estimate_velocity) t.v_WO.setZero();
    cl.track = t.id;
    cl.age = t.age;
    cl.v_WO = t.v_WO.norm() < options_.min_speed ? Eigen::Vector3d::Zero() : t.v_WO;
    next_tracks_.push_back(t);
  }
  std::swap(tracks_, next_tracks_);
}

void CloudObstacles::FillScene(rmp::Scene* scene) const {
  scene->obstacles.clear();
  const double radius = 0.5 * options_.voxel_size + options_.point_margin;
  for (size_t s = 0; s < clusters_.size(); ++s) {
    scene->obstacles.push_back(rmp::Obstacle::MakePoints(indices_[s], radius, clusters_[s].v_WO));
  }
}

}  // namespace rmpmarl::control
