#pragma once
/// Memory of static obstacles the cameras cannot see now (docs/perception.md).
///
/// A camera sees an object only while nothing stands between them. When the arm passes in front of a cube, the
/// cube's points vanish from the cloud, and a controller fed that cloud alone steers into the cube it no longer sees.
/// OcclusionMemory keeps the voxels of obstacles at rest from earlier frames while no camera sees their place, and
/// forgets each one when a camera sees it again or sees through it (free-space carving, as occupancy maps clear
/// voxels along a sensor's rays). Each remembered voxel is projected into every depth image of the new frame:
///   - seen:   the image's depth at its pixel is its own to within `depth_tolerance`: forgotten, the new cloud has it;
///   - free:   every valid pixel of a small window around its pixel is farther than it (+ tolerance): the camera
///             sees past it, so the object has gone: forgotten;
///   - hidden: something nearer stands in front of it (the arm), its pixels have no depth, or it projects outside
///             the image: kept, until `hold_time` after it was last seen.
/// Only obstacles the tracker has followed at rest for `min_age` updates are remembered, so a moving object leaves no
/// trail. A remembered voxel keeps the number of points it held when last seen: it weighs in its obstacle's centroid
/// as it did then, so a cube the arm half hides neither moves nor gains a velocity.
///
/// With DepthPerception: Forget(the new frame's images) → CloudObstacles::Update(the new cloud, points(), counts())
/// → Remember(the update's obstacles). Remembered voxels go through the whole pipeline again (crop, voxel grid, self
/// filter, clustering, tracking) with the new frame's points.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "rmpmarl/control/cloud_obstacles.h"
#include "rmpmarl/perception/depth_camera.h"

namespace rmpmarl::perception {

/// Options of OcclusionMemory.
struct OcclusionMemoryOptions {
  bool enabled = true;           ///< false: nothing is remembered (the cloud of the current frame alone)
  double hold_time = 10.0;       ///< [s] > 0: a point not seen for this long is forgotten, hidden or not
  /// [m] in (0, 0.5]: an image depth within this of a point's depth sees the point; farther sees past it. Covers the
  /// voxel (a centroid lies up to half a voxel off the surface) and the depth noise
  double depth_tolerance = 0.03;
  int window = 1;                ///< [px] in [0, 8]: a point is free only if the (2 window + 1)² pixels around it are
  int min_age = 2;               ///< ≥ 1: updates an obstacle must have been followed at rest to be remembered
  long max_points = 100'000;     ///< ≥ 1: the memory's capacity; past it, the points last seen longest ago go first
};

/// throws InputError naming the field unless the options are valid.
void ValidateOcclusionMemoryOptions(const OcclusionMemoryOptions& options);

/// Where a world point stands in a depth image.
enum class PointVisibility {
  kSeen,     ///< the image's depth at its pixel is its own, to within the tolerance
  kFree,     ///< every valid pixel of the window sees past it
  kHidden,   ///< something nearer is in front of it
  kNoDepth,  ///< its pixel has no depth (dropout, out of range)
  kOutside,  ///< behind the camera, outside the image, or outside the camera's range
};

/// classifies p_W against `image` (see the file comment), with the image's depth at the pixel nearest to the point's
/// projection among those the cloud was made of (every `stride`-th in u and v, DepthToWorldPoints) and, for kFree,
/// every valid one of those within `window` of it. Throws InputError for an image whose depths do not match its
/// intrinsics or a stride < 1.
PointVisibility ClassifyPoint(const DepthImage& image, const Eigen::Vector3d& p_W, double depth_tolerance, int window,
                              double min_range, double max_range, int stride = 1);

/// What the last Forget and Remember did.
struct OcclusionMemoryStats {
  long forgotten_free = 0;  ///< seen through by a camera
  long forgotten_old = 0;   ///< not seen for hold_time
  long forgotten_full = 0;  ///< past max_points
  long forgotten_seen = 0;  ///< seen again (the new cloud has them)
  long hidden = 0;          ///< kept: no camera sees them
};

/// The points of static obstacles, remembered while the cameras cannot see them.
class OcclusionMemory {
 public:
  /// throws InputError for bad options or a voxel size ≤ 0 (the cloud's, which keys the points).
  OcclusionMemory(OcclusionMemoryOptions options, double voxel_size);

  /// forgets everything (start of an episode).
  void Reset();
  /// forgets the remembered points that a camera of the new frame sees or sees through, and those not seen for
  /// hold_time. `ranges` gives each image's camera range [min, max] (depth outside it is no depth).
  /// `stride`: the pixel stride the cloud was back-projected with (a point is seen only by a pixel of the cloud).
  void Forget(const std::vector<DepthImage>& images, const std::vector<Eigen::Vector2d>& ranges, double time,
              int stride = 1);
  /// the remembered points (3 × size()), to add to the new frame's cloud.
  const Eigen::Matrix3Xd& points() const { return points_; }
  /// how many points of the cloud each remembered point stands for (its voxel's when last seen).
  const std::vector<int>& counts() const { return counts_; }
  long size() const { return static_cast<long>(points_.cols()); }
  /// remembers the points of the update's obstacles that the tracker holds at rest (age ≥ min_age), seen at `time`;
  /// a voxel still in memory (hidden since Forget) keeps its point, count and last-seen time. Replaces the memory.
  void Remember(const control::CloudObstacles& cloud, double time);

  const OcclusionMemoryStats& stats() const { return stats_; }
  const OcclusionMemoryOptions& options() const { return options_; }

 private:
  struct Entry {
    std::int64_t key = 0;  // voxel key of p_W
    Eigen::Vector3d p_W = Eigen::Vector3d::Zero();
    int count = 1;         // points of the cloud in its voxel when last seen
    double seen = 0.0;     // time it was last seen [s]
  };
  void RebuildPoints();

  OcclusionMemoryOptions options_;
  double voxel_size_;
  std::vector<Entry> entries_, next_;  // sorted by key
  Eigen::Matrix3Xd points_;
  std::vector<int> counts_;
  OcclusionMemoryStats stats_;
};

}  // namespace rmpmarl::perception
