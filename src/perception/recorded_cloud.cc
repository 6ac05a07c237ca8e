// Recorded point clouds (PLY/PCD files) as an obstacle sensor.
#include "rmpmarl/perception/recorded_cloud.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/cloud_io.h"

namespace rmpmarl::perception {
namespace fs = std::filesystem;
namespace {

bool IsCloudFile(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext == ".ply" || ext == ".pcd";
}

}  // namespace

std::vector<fs::path> RecordedCloudFiles(const fs::path& path) {
  std::error_code ec;
  if (fs::is_regular_file(path, ec)) {
    if (!IsCloudFile(path)) {
      throw InputError(fmt::format("{}: expected a point cloud file (.ply or .pcd) or a folder of them, got a '{}' "
                                   "file", path.string(), path.extension().string()));
    }
    return {path};
  }
  if (!fs::is_directory(path, ec)) {
    throw InputError(fmt::format("{}: expected a point cloud file (.ply or .pcd) or a folder of them; there is no "
                                 "such file or folder", path.string()));
  }
  std::vector<fs::path> files;
  for (const fs::directory_entry& e : fs::directory_iterator(path)) {
    if (e.is_regular_file() && IsCloudFile(e.path())) files.push_back(e.path());
  }
  if (files.empty()) throw InputError(fmt::format("{}: a folder without .ply or .pcd files", path.string()));
  std::sort(files.begin(), files.end());
  return files;
}

RecordedCloud::RecordedCloud(const kinematics::Robot& robot, const fs::path& path, RecordedCloudOptions options)
    : options_(std::move(options)), cloud_(robot, options_.cloud) {
  if (!(options_.rate > 0.0 && std::isfinite(options_.rate))) {
    throw InputError(fmt::format("RecordedCloudOptions.rate: expected a finite rate > 0 Hz, got {}", options_.rate));
  }
  for (const fs::path& file : RecordedCloudFiles(path)) {
    control::PointCloudFile f = control::ReadPointCloud(file, {.max_points = options_.cloud.max_points});
    frames_.push_back(std::move(f.points));
  }
}

long RecordedCloud::total_points() const {
  long n = 0;
  for (const Eigen::Matrix3Xd& f : frames_) n += f.cols();
  return n;
}

void RecordedCloud::Reset(const sim::World&) {
  cloud_.Reset();
  shown_ = -1;
  updates_ = 0;
  update_us_ = points_ = obstacles_ = 0.0;
}

void RecordedCloud::Sense(const sim::World& world, rmp::Scene* scene) {
  const double time = world.time();
  // an update at every tick of the rate, with the frame due then (the last one held after the recording ends): a held
  // frame is filtered again at the robot's new pose, so the robot's own recorded points never become obstacles
  const long tick = static_cast<long>(std::floor(time * options_.rate + 1e-9));
  if (tick != shown_) {
    const int frame = static_cast<int>(std::min<long>(tick, num_frames() - 1));
    // the frame's own time (its tick), not the control step's that noticed it: velocities from the recording's clock
    const control::CloudUpdateStats& s = cloud_.UpdateInBaseFrame(frames_[frame], static_cast<double>(tick) / options_.rate,
                                                         world.q());
    shown_ = tick;
    ++updates_;
    update_us_ += s.time_us;
    points_ += static_cast<double>(cloud_.points().cols());
    obstacles_ += cloud_.num_obstacles();
  }
  cloud_.FillScene(scene);
}

sim::SensorSummary RecordedCloud::Summary() const {
  sim::SensorSummary s;
  s.updates = updates_;
  if (updates_ > 0) {
    s.update_mean_us = update_us_ / updates_;
    s.points_mean = points_ / updates_;
    s.obstacles_mean = obstacles_ / updates_;
  }
  return s;
}

}  // namespace rmpmarl::perception
