#pragma once
/// Replays recorded point clouds as an obstacle sensor (docs/perception.md): one PLY/PCD file (a static scene), or a
/// folder of them played in name order at a frame rate (the last frame is held). The clouds are in the robot's base
/// frame and in metres; each frame becomes point-set obstacles through CloudObstacles, as a live sensor's would.
#include <Eigen/Core>
#include <filesystem>
#include <vector>

#include "rmpmarl/control/cloud_obstacles.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::perception {

/// Options of RecordedCloud.
struct RecordedCloudOptions {
  double rate = 30.0;  ///< [Hz] updates per simulated second (a folder's frames advance at this rate), > 0
  control::CloudObstacleOptions cloud{};
};

/// the .ply/.pcd files a path names: the file itself, or a folder's files in name order. Throws InputError for a
/// missing path, a file of another kind or a folder without any.
std::vector<std::filesystem::path> RecordedCloudFiles(const std::filesystem::path& path);

/// A sensor that plays recorded clouds. Every file is read (and checked) at construction.
class RecordedCloud final : public sim::ObstacleSensor {
 public:
  /// throws InputError for a bad path or file (ReadPointCloud) or bad options.
  RecordedCloud(const kinematics::Robot& robot, const std::filesystem::path& path, RecordedCloudOptions options = {});

  void Reset(const sim::World& world) override;
  void Sense(const sim::World& world, rmp::Scene* scene) override;
  const Eigen::Matrix3Xd& points() const override { return cloud_.points(); }
  sim::SensorSummary Summary() const override;

  int num_frames() const { return static_cast<int>(frames_.size()); }
  long total_points() const;

 private:
  RecordedCloudOptions options_;
  std::vector<Eigen::Matrix3Xd> frames_;  // base frame
  control::CloudObstacles cloud_;
  long shown_ = -1;  // rate tick of the last update
  long updates_ = 0;
  double update_us_ = 0.0, points_ = 0.0, obstacles_ = 0.0;
};

}  // namespace rmpmarl::perception
