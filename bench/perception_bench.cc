// The cost of point-cloud obstacles: nearest points of a robot's capsules to a 20 000-point cloud (the kd-tree index
// against brute force, and the index's build), and a 320 × 240 depth image to obstacles (back-projection, then the
// whole CloudObstacles update: crop, voxel grid, self filter, clustering, tracking), with and without the memory of
// hidden static obstacles (OcclusionMemory: every kept voxel of the static scene remembered, checked against each
// new image and forgotten as seen, then remembered again).
// Run: build/bench/perception_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <chrono>
#include <random>
#include <vector>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/math/point_cloud.h"
#include "rmpmarl/control/cloud_obstacles.h"
#include "rmpmarl/perception/depth_camera.h"
#include "rmpmarl/perception/occlusion_memory.h"

namespace rmpmarl::perception {
namespace {

// Panda's capsules in world at a reaching configuration
std::vector<math::Capsule> PandaCapsules() {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  kinematics::Data data(robot.model);
  Eigen::VectorXd q(7);
  q << 0.3, 0.2, -0.1, -1.9, 0.1, 2.1, 0.7;
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  std::vector<math::Capsule> capsules;
  for (const auto& c : robot.capsules) capsules.push_back({data.X_WL[c.link] * c.p_LA, data.X_WL[c.link] * c.p_LB, c.radius});
  return capsules;
}

// n points as a depth camera sees a cluttered workspace: the surfaces of 8 boxes of 8–20 cm around the arm, with
// 2 mm noise
Eigen::Matrix3Xd ClutterCloud(int n) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0), size(0.04, 0.1);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<Eigen::Vector3d> centres, halves;
  for (int b = 0; b < 8; ++b) {
    centres.emplace_back(0.45 + 0.3 * u(rng), 0.45 * u(rng), 0.45 + 0.3 * u(rng));
    halves.emplace_back(size(rng), size(rng), size(rng));
  }
  Eigen::Matrix3Xd p(3, n);
  for (int i = 0; i < n; ++i) {
    const int b = i % 8, axis = (i / 8) % 3;
    Eigen::Vector3d q(u(rng), u(rng), u(rng));
    q[axis] = q[axis] > 0 ? 1.0 : -1.0;
    p.col(i) = centres[b] + halves[b].cwiseProduct(q) + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
  }
  return p;
}

void BM_CapsulesVsCloud_Index(benchmark::State& state) {
  const std::vector<math::Capsule> capsules = PandaCapsules();
  const math::PointCloudIndex index(ClutterCloud(static_cast<int>(state.range(0))));
  for (auto _ : state) {
    for (const math::Capsule& c : capsules) {
      math::DistanceResult r = math::CapsulePointCloudDistance(c, index, 0.01);
      benchmark::DoNotOptimize(r);
    }
  }
  state.SetLabel(std::to_string(capsules.size()) + " capsules");
}
BENCHMARK(BM_CapsulesVsCloud_Index)->Arg(20000)->Unit(benchmark::kMicrosecond);

void BM_CapsulesVsCloud_BruteForce(benchmark::State& state) {
  const std::vector<math::Capsule> capsules = PandaCapsules();
  const Eigen::Matrix3Xd cloud = ClutterCloud(static_cast<int>(state.range(0)));
  for (auto _ : state) {
    for (const math::Capsule& c : capsules) {
      math::SegmentNearestPoint r = math::NearestToSegmentBruteForce(cloud, c.p_WA, c.p_WB);
      benchmark::DoNotOptimize(r);
    }
  }
  state.SetLabel(std::to_string(capsules.size()) + " capsules");
}
BENCHMARK(BM_CapsulesVsCloud_BruteForce)->Arg(20000)->Unit(benchmark::kMicrosecond);

void BM_PointCloudIndexBuild(benchmark::State& state) {
  const Eigen::Matrix3Xd cloud = ClutterCloud(static_cast<int>(state.range(0)));
  math::PointCloudIndex index;
  index.Reserve(static_cast<int>(cloud.cols()));
  for (auto _ : state) {
    index.Build(cloud);
    benchmark::DoNotOptimize(index.size());
  }
}
BENCHMARK(BM_PointCloudIndexBuild)->Arg(2000)->Arg(20000)->Unit(benchmark::kMicrosecond);

// a 320 × 240 depth image of a D435-like camera looking at the workspace from the front: a floor, a back wall and
// six boxes, by ray casting (no renderer needed)
DepthImage SyntheticDepthImage() {
  DepthCameraOptions options;
  DepthImage image;
  image.intrinsics = IntrinsicsFor(options);
  image.X_WC = options.X_WC;
  const CameraIntrinsics& k = image.intrinsics;
  image.depth.assign(static_cast<size_t>(k.width) * k.height, 0.0f);
  std::vector<Eigen::AlignedBox3d> boxes;
  for (int b = 0; b < 6; ++b) {
    const Eigen::Vector3d c(0.35 + 0.07 * b, -0.3 + 0.12 * b, 0.25 + 0.05 * (b % 3));
    boxes.emplace_back(c.array() - 0.05, c.array() + 0.05);
  }
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      const Eigen::Vector3d d_C((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);  // z = 1: t is the depth
      const Eigen::Vector3d o = image.X_WC.translation(), d = image.X_WC.linear() * d_C;
      double t = d.z() < 0 ? -o.z() / d.z() : 10.0;  // the floor z = 0
      if (d.x() < 0) t = std::min(t, (-0.4 - o.x()) / d.x());  // a wall at x = −0.4
      for (const Eigen::AlignedBox3d& b : boxes) {  // slab test
        double t0 = 0.0, t1 = 1e9;
        for (int a = 0; a < 3; ++a) {
          const double ta = (b.min()[a] - o[a]) / d[a], tb = (b.max()[a] - o[a]) / d[a];
          t0 = std::max(t0, std::min(ta, tb));
          t1 = std::min(t1, std::max(ta, tb));
        }
        if (t0 <= t1) t = std::min(t, t0);
      }
      if (t > options.min_range && t < options.max_range) image.depth[static_cast<size_t>(v) * k.width + u] = static_cast<float>(t);
    }
  }
  return image;
}

void BM_DepthToWorldPoints_320x240(benchmark::State& state) {
  const DepthImage image = SyntheticDepthImage();
  Eigen::Matrix3Xd points;
  for (auto _ : state) benchmark::DoNotOptimize(DepthToWorldPoints(image, 1, &points));
}
BENCHMARK(BM_DepthToWorldPoints_320x240)->Unit(benchmark::kMicrosecond);

// back-projection and the whole obstacle update (the floor cropped, 2 cm voxels)
void BM_DepthToObstacles_320x240(benchmark::State& state) {
  const DepthImage image = SyntheticDepthImage();
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  control::CloudObstacles cloud(robot, {});
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  Eigen::Matrix3Xd points;
  double time = 0.0;
  long input = 0, kept = 0;
  double downsample = 0.0, filter = 0.0, cluster = 0.0, track = 0.0;
  for (auto _ : state) {
    const int n = DepthToWorldPoints(image, 1, &points);
    const control::CloudUpdateStats& s = cloud.Update(points.leftCols(n), time, q);
    time += 1.0 / 30.0;
    input = s.input_points;
    kept = cloud.points().cols();
    downsample += s.downsample_us;
    filter += s.filter_us;
    cluster += s.cluster_us;
    track += s.track_us;
  }
  // the stages' mean wall time per update [µs]
  const double iterations = static_cast<double>(state.iterations());
  state.counters["downsample_us"] = downsample / iterations;
  state.counters["filter_us"] = filter / iterations;
  state.counters["cluster_us"] = cluster / iterations;
  state.counters["track_us"] = track / iterations;
  state.SetLabel(std::to_string(input) + " points → " + std::to_string(kept) + " voxels, " +
                 std::to_string(cloud.num_obstacles()) + " obstacles");
}
BENCHMARK(BM_DepthToObstacles_320x240)->Unit(benchmark::kMicrosecond);

// the same with the memory, as DepthPerception runs it: Forget, Update with the remembered points, Remember
void BM_DepthToObstaclesWithMemory_320x240(benchmark::State& state) {
  const std::vector<DepthImage> images{SyntheticDepthImage()};
  const DepthCameraOptions camera;
  const std::vector<Eigen::Vector2d> ranges{Eigen::Vector2d(camera.min_range, camera.max_range)};
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  control::CloudObstacles cloud(robot, {});
  OcclusionMemory memory(OcclusionMemoryOptions{}, cloud.options().voxel_size);
  const Eigen::VectorXd q = Eigen::VectorXd::Zero(7);
  Eigen::Matrix3Xd points;
  double time = 0.0, memory_us = 0.0;
  long remembered = 0;
  for (auto _ : state) {
    const int n = DepthToWorldPoints(images[0], 1, &points);
    const auto t0 = std::chrono::steady_clock::now();
    memory.Forget(images, ranges, time);
    const auto t1 = std::chrono::steady_clock::now();
    cloud.Update(points.leftCols(n), time, q, memory.points(), memory.counts());
    const auto t2 = std::chrono::steady_clock::now();
    memory.Remember(cloud, time);
    const auto t3 = std::chrono::steady_clock::now();
    memory_us += std::chrono::duration<double, std::micro>((t1 - t0) + (t3 - t2)).count();
    remembered = memory.size();
    time += 1.0 / 30.0;
  }
  state.counters["memory_us"] = memory_us / static_cast<double>(state.iterations());
  state.SetLabel(std::to_string(remembered) + " voxels remembered");
}
BENCHMARK(BM_DepthToObstaclesWithMemory_320x240)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rmpmarl::perception
