#pragma once
/// Obstacles from a point cloud (docs/perception.md): what a depth camera or a user's sensor sees becomes point-set
/// obstacles (rmp::ObstacleShape::kPoints) that every controller — RMPflow, the paper's agents, the learned default —
/// avoids through its nearest points, with velocities from tracking.
///
/// One update, in order:
///  1. points with a NaN or infinite coordinate are dropped (counted); a cloud in millimetres is refused;
///  2. points outside the workspace box are dropped (the room beyond the reach; by default nothing the arm can reach,
///     so a table below its base or a shelf above it stays — a scene with a floor plane crops above it, FloorCrop);
///  3. voxel-grid downsampling: one point per occupied voxel of `voxel_size`, the centroid of its points;
///  4. the self filter: voxels within a robot capsule's radius + `self_filter_margin` (at the robot's configuration
///     q) are the robot itself, dropped;
///  5. Euclidean clustering: voxels that touch (26-neighbourhood) form one cluster; clusters of fewer than
///     `min_cluster_voxels` voxels are speckle, dropped; the clusters nearest the arm become obstacles, the rest
///     (beyond max_obstacles − 1) are merged into the last one, so no point is lost;
///  6. tracking: a cluster continues the track whose predicted centroid is nearest (within `track_gate`); its velocity
///     is the least-squares slope of the centroid over the last few updates. A new cluster near a track's prediction
///     (a piece cut off a followed object) inherits its velocity; any other new track starts at rest.
/// Each obstacle's points are spheres of radius voxel_size / 2 (a voxel's centroid stands for points up to half a
/// voxel away).
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <optional>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/math/point_cloud.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::control {

/// Options of CloudObstacles.
struct CloudObstacleOptions {
  double voxel_size = 0.02;  ///< [m], in [0.001, 0.5]
  /// world-frame crop box [m]; unset: ReachCrop(robot), everything within the arm's reach of its base (above and
  /// below it). Points outside are counted (CloudUpdateStats::outside_points); CloudObstacles::workspace() is the box.
  std::optional<Eigen::AlignedBox3d> workspace;
  double self_filter_margin = 0.01;  ///< [m] ≥ 0: a voxel within a capsule's radius + this is the robot's
  /// [m] in [0, 0.2]: each kept point is a sphere of half a voxel plus this margin for the controllers — room for
  /// what the cloud misses of an object (the sides the camera cannot see, points the self filter took near the arm).
  /// 2 cm: chosen on evaluation seed 7 of the cluttered scene (0 / 1 / 2 cm: RMPflow 87 / 94 / 97 % success, the
  /// learned default 95 / 94 / 99 %), reported on other seeds (docs/perception.md)
  double point_margin = 0.02;
  int min_cluster_voxels = 2;        ///< ≥ 1: smaller clusters are dropped as speckle noise
  int max_obstacles = 8;             ///< ≥ 1: obstacle slots; further clusters are merged into the last one
  long max_points = 2'000'000;       ///< larger clouds are refused (InputError): a 1280 × 720 depth image is 0.92 M
  /// a cloud whose median distance from the robot's base exceeds this [m] is refused as not in metres (a cloud in
  /// millimetres puts a table 1 m away at 1000)
  double unit_check_distance = 50.0;
  bool estimate_velocity = true;      ///< false: every obstacle at rest
  double track_gate = 0.25;          ///< [m] largest distance from a track's predicted centroid to its next cluster
  /// [updates] in [2, 16]: a track's velocity is the least-squares slope of its last `velocity_window` centroids
  int velocity_window = 5;
  double max_speed = 3.0;            ///< [m/s] estimates are clipped to this speed
  /// [m/s] estimates below this are reported as 0: a static obstacle's centroid jitters by a fraction of a voxel
  /// between frames (2 cm voxels at 30 Hz: 0.03 m/s mean, 0.05 m/s p90), and a controller's look-ahead reads any
  /// non-zero speed as a moving obstacle
  double min_speed = 0.1;
};

/// throws InputError naming the field unless the options are valid.
void ValidateCloudObstacleOptions(const CloudObstacleOptions& options);

/// the default crop: a cube centred on the robot's base origin whose half side is an upper bound of its reach (the
/// joint offsets along the chain, prismatic travel and the capsules' extent) plus `margin` [m].
Eigen::AlignedBox3d ReachCrop(const kinematics::Robot& robot, double margin = 0.3);
/// the crop of a scene with a floor plane z = floor_height (the simulated cameras' scenes): from 3 cm above the floor
/// to 2.5 m, ±2 m around the origin — the floor's own points go.
Eigen::AlignedBox3d FloorCrop(double floor_height = 0.0);

/// the key of the voxel (cube of side 1 / inv_voxel_size, corners on multiples of it) that holds p_W: its three
/// integer indices packed in 21 bits each. ValidateCloudObstacleOptions keeps the workspace within that range.
std::int64_t VoxelKey(const Eigen::Vector3d& p_W, double inv_voxel_size);

/// What one update did, in points / voxels / clusters.
struct CloudUpdateStats {
  long input_points = 0;
  long nonfinite_points = 0;  ///< dropped: a NaN or infinite coordinate
  long outside_points = 0;    ///< dropped: outside the workspace box
  long voxels = 0;            ///< occupied voxels after downsampling
  long robot_voxels = 0;      ///< dropped by the self filter
  int clusters = 0;           ///< kept clusters (before merging)
  int speckle_clusters = 0;   ///< dropped: fewer than min_cluster_voxels
  int merged_clusters = 0;    ///< clusters merged into the last obstacle slot
  double time_us = 0.0;       ///< wall time of the update [µs], of which:
  double downsample_us = 0.0; ///< unit check, crop and voxel grid
  double filter_us = 0.0;     ///< self filter
  double cluster_us = 0.0;    ///< clustering and the obstacles' indices
  double track_us = 0.0;      ///< tracking
};

/// One obstacle of the last update.
struct CloudCluster {
  Eigen::Vector3d centroid_W = Eigen::Vector3d::Zero();  ///< mean of its points (before downsampling)
  Eigen::Vector3d v_WO = Eigen::Vector3d::Zero();        ///< tracked velocity [m/s]
  int voxels = 0;
  long points = 0;         ///< points of the cloud in its voxels
  int track = -1;          ///< track id, stable across updates while the cluster is followed
  int age = 0;             ///< updates the track was followed before this one (0: a new track, at rest)
  double clearance = 0.0;  ///< distance from the centroid to the nearest robot capsule surface [m]
};

/// Point-cloud obstacles for one robot. Update() keeps its buffers, so steady-state updates of clouds no larger than
/// earlier ones allocate little. Scenes filled by FillScene point into this object's indices: they are valid until
/// the next Update or Reset.
class CloudObstacles {
 public:
  /// throws InputError for bad options.
  CloudObstacles(const kinematics::Robot& robot, CloudObstacleOptions options = {});

  /// forgets the tracks and the obstacles (start of an episode).
  void Reset();
  /// a cloud p_W (3 × N, world frame) sensed at `time` [s] with the robot at configuration q. Throws InputError for a
  /// cloud of more than max_points points, one in millimetres, a time earlier than the last update's, or a q of the
  /// wrong size or not finite.
  const CloudUpdateStats& Update(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, double time,
                                 const Eigen::Ref<const Eigen::VectorXd>& q);
  /// the same, with points of earlier frames the sensor cannot see now (OcclusionMemory): remembered_W.col(i) stands
  /// for remembered_counts[i] points of the cloud (the points its voxel held when it was last seen), so an object
  /// partly hidden keeps its centroid. They go through the same steps as the cloud's own points.
  const CloudUpdateStats& Update(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, double time,
                                 const Eigen::Ref<const Eigen::VectorXd>& q, const Eigen::Matrix3Xd& remembered_W,
                                 const std::vector<int>& remembered_counts);
  /// the same for a cloud in the robot's base frame (the root link's frame): p_W = X_WB p_B.
  const CloudUpdateStats& UpdateInBaseFrame(const Eigen::Ref<const Eigen::Matrix3Xd>& p_B, double time,
                                            const Eigen::Ref<const Eigen::VectorXd>& q);

  /// sets scene->obstacles to the last update's obstacles (none before the first update).
  void FillScene(rmp::Scene* scene) const;
  /// the last update's obstacles.
  const std::vector<CloudCluster>& clusters() const { return clusters_; }
  int num_obstacles() const { return static_cast<int>(clusters_.size()); }
  /// the kept points of the last update (voxel centroids off the robot, in kept clusters; 3 × N), for drawing.
  const Eigen::Matrix3Xd& points() const { return kept_; }
  /// the points of obstacle k of the last update (voxel centroids, 3 × clusters()[k].voxels).
  const Eigen::Matrix3Xd& cluster_points(int k) const { return slot_points_[k]; }
  /// how many points of the cloud each of cluster_points(k) stands for.
  const std::vector<int>& cluster_point_counts(int k) const { return slot_counts_[k]; }
  const CloudUpdateStats& stats() const { return stats_; }
  const CloudObstacleOptions& options() const { return options_; }
  /// the crop box in use (options().workspace, or ReachCrop of the robot).
  const Eigen::AlignedBox3d& workspace() const { return workspace_; }
  const kinematics::Robot& robot() const { return robot_; }

 private:
  static constexpr int kMaxWindow = 16;
  struct Track {
    int id = 0;
    Eigen::Vector3d centroid_W = Eigen::Vector3d::Zero();
    Eigen::Vector3d v_WO = Eigen::Vector3d::Zero();
    int age = 0;
    // the window of (time, centroid), oldest first
    int count = 0;
    double t[kMaxWindow] = {};
    Eigen::Vector3d c[kMaxWindow];
  };
  void Downsample(const Eigen::Ref<const Eigen::Matrix3Xd>& p_W, const Eigen::Matrix3Xd& remembered_W,
                  const std::vector<int>& remembered_counts);
  void SelfFilter(const Eigen::Ref<const Eigen::VectorXd>& q);
  void Cluster();
  void UpdateTracks(double time);
  int Find(int v);

  kinematics::Robot robot_;
  CloudObstacleOptions options_;
  Eigen::AlignedBox3d workspace_;
  kinematics::Data kin_;
  std::vector<math::Capsule> capsules_W_;
  // voxel hash: open addressing over packed integer voxel keys
  std::vector<std::int64_t> table_keys_;
  std::vector<int> table_voxel_;
  std::vector<std::int64_t> voxel_key_;
  std::vector<Eigen::Vector3d> voxel_sum_;
  std::vector<int> voxel_count_;
  std::vector<char> voxel_robot_;
  std::vector<int> parent_;          // union-find over voxels
  std::vector<int> voxel_cluster_;   // voxel → slot, −1 none
  std::vector<int> root_cluster_;    // union-find root → component
  std::vector<double> sample_;       // scratch of the unit check
  std::vector<CloudCluster> clusters_;
  std::vector<math::PointCloudIndex> indices_;  // one per obstacle slot
  std::vector<Eigen::Matrix3Xd> slot_points_;
  std::vector<std::vector<int>> slot_counts_;
  Eigen::Matrix3Xd kept_;
  std::vector<Track> tracks_, next_tracks_;
  int next_track_id_ = 0;
  double last_time_ = -1.0;
  bool has_update_ = false;
  CloudUpdateStats stats_;
};

}  // namespace rmpmarl::control
