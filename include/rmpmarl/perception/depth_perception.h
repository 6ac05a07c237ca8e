#pragma once
/// Obstacles known only through depth cameras (docs/perception.md): a sim::ObstacleSensor that renders its simulated
/// cameras in MuJoCo at their frame rate, back-projects the depth images to one world-frame cloud and turns it into
/// point-set obstacles with CloudObstacles. Between frames the controller keeps the last frame's obstacles.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/control/cloud_obstacles.h"
#include "rmpmarl/perception/depth_camera.h"
#include "rmpmarl/perception/occlusion_memory.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::perception {

/// What to perceive with.
struct DepthPerceptionOptions {
  /// the cameras (all at the first one's rate); default: one 320 × 240 camera at DepthCameraOptions' default pose
  std::vector<DepthCameraOptions> cameras{DepthCameraOptions{}};
  int stride = 1;  ///< back-project every stride-th pixel in u and v, ≥ 1
  /// the cloud's obstacles; an unset workspace crops 3 cm above the scene's floor (control::FloorCrop)
  control::CloudObstacleOptions cloud{};
  /// static obstacles remembered while the arm hides them from the cameras (OcclusionMemory)
  OcclusionMemoryOptions memory{};
};

/// throws InputError naming the field unless the options are valid (cameras' own checks included).
void ValidateDepthPerceptionOptions(const DepthPerceptionOptions& options);

/// The depth-camera sensor of one world model. Not thread-safe: each thread builds its own (each holds an EGL context).
class DepthPerception final : public sim::ObstacleSensor {
 public:
  /// nullptr and *why_not when offscreen rendering is unavailable here; throws InputError for bad options.
  static std::unique_ptr<DepthPerception> Create(const sim::WorldModel& model, const DepthPerceptionOptions& options,
                                                 std::string* why_not);

  void Reset(const sim::World& world) override;
  void Sense(const sim::World& world, rmp::Scene* scene) override;
  const Eigen::Matrix3Xd& points() const override { return cloud_.points(); }
  sim::SensorSummary Summary() const override;

  const control::CloudObstacles& cloud() const { return cloud_; }
  const OcclusionMemory& memory() const { return memory_; }
  const DepthPerceptionOptions& options() const { return options_; }
  /// the last rendered image of camera k.
  const DepthImage& image(int k) const { return images_[k]; }

 private:
  DepthPerception(const sim::WorldModel& model, const DepthPerceptionOptions& options);
  void ScoreVelocities(const rmp::Scene& truth);

  DepthPerceptionOptions options_;
  std::vector<std::unique_ptr<DepthCamera>> cameras_;
  std::vector<DepthImage> images_;
  std::vector<Eigen::Vector2d> ranges_;  // each camera's [min_range, max_range]
  std::vector<Eigen::Matrix3Xd> camera_points_;
  std::vector<int> counts_;
  Eigen::Matrix3Xd all_points_;
  control::CloudObstacles cloud_;
  OcclusionMemory memory_;
  double period_ = 1.0 / 30.0;
  double next_time_ = 0.0;
  // summary
  long updates_ = 0;
  double update_us_ = 0.0, points_ = 0.0, obstacles_ = 0.0, hidden_ = 0.0;
  std::vector<double> velocity_errors_, tracked_errors_;  // all matches; tracks followed ≥ 2 updates
};

/// a maker of DepthPerception sensors with `options` (for tasks::ControllerMaker::make_sensor and
/// experiments::EvalProtocol::make_sensor); the sensors it makes throw InputError saying why when offscreen rendering
/// is unavailable. Validates the options now.
std::function<std::unique_ptr<sim::ObstacleSensor>(const sim::WorldModel&)> DepthSensorMaker(
    const DepthPerceptionOptions& options);

}  // namespace rmpmarl::perception
