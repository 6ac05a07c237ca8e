// Memory of static obstacles the cameras cannot see now: kept while hidden, forgotten when seen through.
#include "rmpmarl/perception/occlusion_memory.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::perception {

void ValidateOcclusionMemoryOptions(const OcclusionMemoryOptions& o) {
  auto fail = [](std::string_view field, std::string_view expected, const std::string& got) {
    throw InputError(fmt::format("OcclusionMemoryOptions.{}: expected {}, got {}", field, expected, got));
  };
  if (!(o.hold_time > 0.0)) fail("hold_time", "a time > 0 s", fmt::format("{}", o.hold_time));
  if (!(o.depth_tolerance > 0.0 && o.depth_tolerance <= 0.5)) {
    fail("depth_tolerance", "a depth in (0, 0.5] m", fmt::format("{}", o.depth_tolerance));
  }
  if (o.window < 0 || o.window > 8) fail("window", "a half-width in [0, 8] px", fmt::format("{}", o.window));
  if (o.min_age < 1) fail("min_age", "at least 1 update", fmt::format("{}", o.min_age));
  if (o.max_points < 1) fail("max_points", "at least 1", fmt::format("{}", o.max_points));
}

PointVisibility ClassifyPoint(const DepthImage& image, const Eigen::Vector3d& p_W, double tolerance, int window,
                              double min_range, double max_range, int stride) {
  const CameraIntrinsics& k = image.intrinsics;
  if (k.width < 1 || k.height < 1 || image.depth.size() != static_cast<size_t>(k.width) * k.height) {
    throw InputError(fmt::format("ClassifyPoint image: expected {} x {} = {} depths, got {}", k.width, k.height,
                                 static_cast<long>(k.width) * k.height, image.depth.size()));
  }
  if (stride < 1) throw InputError(fmt::format("ClassifyPoint stride: expected an integer >= 1, got {}", stride));
  const Eigen::Vector3d p_C = image.X_WC.inverse() * p_W;
  const double z = p_C.z();
  if (!(z >= min_range && z <= max_range)) return PointVisibility::kOutside;
  const double pu = k.fx * p_C.x() / z + k.cx, pv = k.fy * p_C.y() / z + k.cy;
  if (!(pu > -0.5 && pu < k.width - 0.5 && pv > -0.5 && pv < k.height - 0.5)) return PointVisibility::kOutside;
  // the nearest pixel the cloud was made of
  const long last_u = (k.width - 1) / stride * stride, last_v = (k.height - 1) / stride * stride;
  const long u = std::clamp(std::lround(pu / stride) * stride, 0L, last_u);
  const long v = std::clamp(std::lround(pv / stride) * stride, 0L, last_v);
  const float* depth = image.depth.data();
  const double d = depth[v * k.width + u];
  if (d > 0.0 && d < z - tolerance) return PointVisibility::kHidden;
  if (d > 0.0 && d <= z + tolerance) return PointVisibility::kSeen;
  // the centre pixel sees past the point or has no depth: free only if no pixel around it stops at or before it
  int valid = 0;
  bool near_surface = false, in_front = false;
  for (long dv = -window; dv <= window; ++dv) {
    for (long du = -window; du <= window; ++du) {
      const long uu = u + du * stride, vv = v + dv * stride;
      if (uu < 0 || uu >= k.width || vv < 0 || vv >= k.height) continue;
      const double dd = depth[vv * k.width + uu];
      if (!(dd > 0.0)) continue;
      ++valid;
      if (dd < z - tolerance) {
        in_front = true;
      } else if (dd <= z + tolerance) {
        near_surface = true;
      }
    }
  }
  if (near_surface) return PointVisibility::kSeen;
  if (in_front) return PointVisibility::kHidden;
  return valid > 0 ? PointVisibility::kFree : PointVisibility::kNoDepth;
}

OcclusionMemory::OcclusionMemory(OcclusionMemoryOptions options, double voxel_size)
    : options_(std::move(options)), voxel_size_(voxel_size) {
  ValidateOcclusionMemoryOptions(options_);
  if (!(voxel_size > 0.0 && std::isfinite(voxel_size))) {
    throw InputError(fmt::format("OcclusionMemory voxel_size: expected a size > 0 m, got {}", voxel_size));
  }
  points_.resize(3, 0);
}

void OcclusionMemory::Reset() {
  entries_.clear();
  points_.resize(3, 0);
  counts_.clear();
  stats_ = {};
}

void OcclusionMemory::Forget(const std::vector<DepthImage>& images, const std::vector<Eigen::Vector2d>& ranges,
                             double time, int stride) {
  if (images.size() != ranges.size()) {
    throw InputError(fmt::format("OcclusionMemory::Forget: expected one range per image ({}), got {}", images.size(),
                                 ranges.size()));
  }
  stats_ = {};
  if (!options_.enabled) return;
  size_t kept = 0;
  for (const Entry& e : entries_) {
    if (time - e.seen > options_.hold_time) {
      ++stats_.forgotten_old;
      continue;
    }
    bool seen = false, free = false;
    for (size_t c = 0; c < images.size(); ++c) {
      const PointVisibility v = ClassifyPoint(images[c], e.p_W, options_.depth_tolerance, options_.window,
                                              ranges[c].x(), ranges[c].y(), stride);
      seen = seen || v == PointVisibility::kSeen;
      free = free || v == PointVisibility::kFree;
    }
    if (seen) {
      ++stats_.forgotten_seen;
    } else if (free) {
      ++stats_.forgotten_free;
    } else {
      ++stats_.hidden;
      entries_[kept++] = e;
    }
  }
  entries_.resize(kept);
  RebuildPoints();
}

void OcclusionMemory::Remember(const control::CloudObstacles& cloud, double time) {
  if (!options_.enabled) return;
  next_.clear();
  const std::vector<control::CloudCluster>& clusters = cloud.clusters();
  for (int k = 0; k < static_cast<int>(clusters.size()); ++k) {
    const control::CloudCluster& c = clusters[k];
    if (c.track < 0 || c.age < options_.min_age || !c.v_WO.isZero(0.0)) continue;
    const Eigen::Matrix3Xd& p = cloud.cluster_points(k);
    const std::vector<int>& counts = cloud.cluster_point_counts(k);
    for (Eigen::Index i = 0; i < p.cols(); ++i) {
      Entry e;
      e.p_W = p.col(i);
      e.key = control::VoxelKey(e.p_W, 1.0 / voxel_size_);
      e.count = counts[i];
      e.seen = time;
      // a voxel still in memory is hidden now: it stays as it was last seen (its count does not take in this frame's
      // points of the same voxel again)
      auto old = std::lower_bound(entries_.begin(), entries_.end(), e.key,
                                  [](const Entry& a, std::int64_t key) { return a.key < key; });
      if (old != entries_.end() && old->key == e.key) e = *old;
      next_.push_back(e);
    }
  }
  if (static_cast<long>(next_.size()) > options_.max_points) {
    std::stable_sort(next_.begin(), next_.end(), [](const Entry& a, const Entry& b) { return a.seen > b.seen; });
    stats_.forgotten_full = static_cast<long>(next_.size()) - options_.max_points;
    next_.resize(options_.max_points);
  }
  std::sort(next_.begin(), next_.end(), [](const Entry& a, const Entry& b) { return a.key < b.key; });
  std::swap(entries_, next_);
  RebuildPoints();
}

void OcclusionMemory::RebuildPoints() {
  if (points_.cols() != static_cast<Eigen::Index>(entries_.size())) points_.resize(3, entries_.size());
  counts_.resize(entries_.size());
  for (size_t i = 0; i < entries_.size(); ++i) {
    points_.col(i) = entries_[i].p_W;
    counts_[i] = entries_[i].count;
  }
}

}  // namespace rmpmarl::perception
