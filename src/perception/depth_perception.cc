// The depth-camera obstacle sensor: render at the camera rate, back-project, CloudObstacles.
#include "rmpmarl/perception/depth_perception.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::perception {

void ValidateDepthPerceptionOptions(const DepthPerceptionOptions& o) {
  if (o.cameras.empty()) throw InputError("DepthPerceptionOptions.cameras: expected at least one camera, got none");
  for (size_t k = 0; k < o.cameras.size(); ++k) {
    ValidateDepthCameraOptions(o.cameras[k]);
    if (o.cameras[k].rate != o.cameras[0].rate) {
      throw InputError(fmt::format("DepthPerceptionOptions.cameras[{}].rate: expected the first camera's {} Hz (the "
                                   "cameras are rendered together), got {}", k, o.cameras[0].rate, o.cameras[k].rate));
    }
  }
  if (o.stride < 1 || o.stride > 64) {
    throw InputError(fmt::format("DepthPerceptionOptions.stride: expected a pixel stride in [1, 64], got {}", o.stride));
  }
  control::ValidateCloudObstacleOptions(o.cloud);
  ValidateOcclusionMemoryOptions(o.memory);
}

namespace {

// the cloud's crop: the options' box, else 3 cm above the scene's floor (z = 0 without one: the cameras see no lower)
control::CloudObstacleOptions CloudOf(const sim::WorldModel& model, control::CloudObstacleOptions cloud) {
  if (!cloud.workspace) cloud.workspace = control::FloorCrop(model.scene().has_floor ? model.scene().floor_height : 0.0);
  return cloud;
}

}  // namespace

DepthPerception::DepthPerception(const sim::WorldModel& model, const DepthPerceptionOptions& options)
    : options_(options), cloud_(model.robot(), CloudOf(model, options.cloud)),
      memory_(options.memory, options.cloud.voxel_size) {}

std::unique_ptr<DepthPerception> DepthPerception::Create(const sim::WorldModel& model,
                                                         const DepthPerceptionOptions& options, std::string* why_not) {
  ValidateDepthPerceptionOptions(options);
  std::unique_ptr<DepthPerception> p(new DepthPerception(model, options));
  for (const DepthCameraOptions& c : options.cameras) {
    std::unique_ptr<DepthCamera> camera = DepthCamera::Create(model, c, why_not);
    if (!camera) return nullptr;
    p->cameras_.push_back(std::move(camera));
    p->ranges_.emplace_back(c.min_range, c.max_range);
  }
  p->images_.resize(p->cameras_.size());
  p->camera_points_.resize(p->cameras_.size());
  p->counts_.resize(p->cameras_.size());
  p->period_ = 1.0 / options.cameras[0].rate;
  return p;
}

void DepthPerception::Reset(const sim::World& world) {
  cloud_.Reset();
  memory_.Reset();
  next_time_ = world.time();
  updates_ = 0;
  update_us_ = points_ = obstacles_ = hidden_ = 0.0;
  velocity_errors_.clear();
  tracked_errors_.clear();
}

void DepthPerception::Sense(const sim::World& world, rmp::Scene* scene) {
  const double time = world.time();
  // a frame is due: render every camera, one cloud, one update (half a physics step of slack for rounding)
  if (time >= next_time_ - 1e-9) {
    const auto start = std::chrono::steady_clock::now();
    long total = 0;
    for (size_t k = 0; k < cameras_.size(); ++k) {
      cameras_[k]->Render(world.mj_data(), &images_[k]);
      counts_[k] = DepthToWorldPoints(images_[k], options_.stride, &camera_points_[k]);
      total += counts_[k];
    }
    // what the new images see, or see through, is forgotten; what they cannot see is added to their cloud
    memory_.Forget(images_, ranges_, time, options_.stride);
    if (cameras_.size() == 1) {
      cloud_.Update(camera_points_[0].leftCols(counts_[0]), time, world.q(), memory_.points(), memory_.counts());
    } else {
      all_points_.resize(3, total);
      long at = 0;
      for (size_t k = 0; k < cameras_.size(); ++k) {
        all_points_.middleCols(at, counts_[k]) = camera_points_[k].leftCols(counts_[k]);
        at += counts_[k];
      }
      cloud_.Update(all_points_, time, world.q(), memory_.points(), memory_.counts());
    }
    hidden_ += static_cast<double>(memory_.stats().hidden);
    memory_.Remember(cloud_, time);
    // the next frame on the camera's own clock (a late call does not shift the clock)
    while (next_time_ <= time + 1e-9) next_time_ += period_;
    ++updates_;
    update_us_ += std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start).count();
    points_ += static_cast<double>(cloud_.points().cols());
    obstacles_ += cloud_.num_obstacles();
    ScoreVelocities(*scene);
  }
  cloud_.FillScene(scene);
}

void DepthPerception::ScoreVelocities(const rmp::Scene& truth) {
  for (const control::CloudCluster& c : cloud_.clusters()) {
    double best = 0.15;
    const rmp::Obstacle* match = nullptr;
    for (const rmp::Obstacle& o : truth.obstacles) {
      if (o.shape == rmp::ObstacleShape::kPoints) continue;
      const double d = (rmp::Centre(o) - c.centroid_W).norm();
      if (d < best) {
        best = d;
        match = &o;
      }
    }
    if (match != nullptr) {
      const double e = (c.v_WO - match->v_WO).norm();
      velocity_errors_.push_back(e);
      if (c.age >= 2) tracked_errors_.push_back(e);
    }
  }
}

sim::SensorSummary DepthPerception::Summary() const {
  sim::SensorSummary s;
  s.updates = updates_;
  if (updates_ > 0) {
    s.update_mean_us = update_us_ / updates_;
    s.points_mean = points_ / updates_;
    s.obstacles_mean = obstacles_ / updates_;
    s.hidden_mean = hidden_ / updates_;
  }
  s.velocity_samples = static_cast<long>(velocity_errors_.size());
  if (!velocity_errors_.empty()) {
    std::vector<double> e = velocity_errors_;
    double sum = 0.0;
    for (double x : e) sum += x;
    s.velocity_error_mean = sum / e.size();
    auto p90 = e.begin() + static_cast<long>(0.9 * (e.size() - 1));
    std::nth_element(e.begin(), p90, e.end());
    s.velocity_error_p90 = *p90;
  }
  s.velocity_samples_tracked = static_cast<long>(tracked_errors_.size());
  if (!tracked_errors_.empty()) {
    double sum = 0.0;
    for (double x : tracked_errors_) sum += x;
    s.velocity_error_tracked_mean = sum / static_cast<double>(tracked_errors_.size());
  }
  return s;
}

std::function<std::unique_ptr<sim::ObstacleSensor>(const sim::WorldModel&)> DepthSensorMaker(
    const DepthPerceptionOptions& options) {
  ValidateDepthPerceptionOptions(options);
  return [options](const sim::WorldModel& model) -> std::unique_ptr<sim::ObstacleSensor> {
    std::string why_not;
    std::unique_ptr<DepthPerception> sensor = DepthPerception::Create(model, options, &why_not);
    if (!sensor) {
      throw InputError(fmt::format("depth perception: the simulated depth camera needs offscreen rendering (EGL), "
                                   "which is not available here: {}", why_not));
    }
    return sensor;
  };
}

}  // namespace rmpmarl::perception
