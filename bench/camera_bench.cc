// The simulated depth camera at 320 × 240: rendering (MuJoCo through EGL, depth read back and made metric, noise) and
// back-projection to world points, on Panda with four cube obstacles and a floor, seen by the default camera.
// Run: build/bench/camera_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
// The label of each result is the GL renderer (e.g. llvmpipe: software rasterisation on the CPU).
#include <benchmark/benchmark.h>

#include <memory>
#include <string>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/perception/depth_camera.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::perception {
namespace {

std::shared_ptr<const sim::WorldModel> PandaWithFourBoxesAndFloor() {
  sim::SceneSpec scene;
  const Eigen::Vector3d p[4] = {{0.45, 0.15, 0.45}, {0.45, -0.2, 0.3}, {0.2, 0.3, 0.7}, {0.35, 0.0, 0.9}};
  for (const Eigen::Vector3d& p_WO : p) {
    scene.obstacles.push_back(sim::ObstacleSpec::Cube(0.1, Eigen::Isometry3d(Eigen::Translation3d(p_WO))));
  }
  scene.has_floor = true;
  scene.p_WT = Eigen::Vector3d(0.5, 0.0, 0.5);
  return std::make_shared<const sim::WorldModel>(kinematics::LoadShippedRobot("panda"), scene);
}

// a 320 × 240 camera with D435-like noise, or nullptr (and the benchmark skipped) without offscreen rendering.
std::unique_ptr<DepthCamera> MakeCamera(const sim::WorldModel& model, benchmark::State& state) {
  DepthCameraOptions options;
  options.width = 320;
  options.height = 240;
  options.noise.sigma_at_1m = 0.002;
  options.noise.dropout = 0.01;
  std::string why_not;
  auto camera = DepthCamera::Create(model, options, &why_not);
  if (camera == nullptr) {
    state.SkipWithError(("offscreen rendering unavailable: " + why_not).c_str());
  } else {
    state.SetLabel(camera->gl_renderer());
  }
  return camera;
}

void BM_DepthRender_320x240(benchmark::State& state) {
  auto model = PandaWithFourBoxesAndFloor();
  sim::World world(model);
  auto camera = MakeCamera(*model, state);
  if (camera == nullptr) return;
  DepthImage image;
  for (auto _ : state) {
    camera->Render(world.mj_data(), &image);
    benchmark::DoNotOptimize(image.depth.data());
  }
  state.counters["frames/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
// llvmpipe rasterises in worker threads: wall-clock time is the cost of a frame.
BENCHMARK(BM_DepthRender_320x240)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_DepthToWorldPoints_320x240(benchmark::State& state) {
  auto model = PandaWithFourBoxesAndFloor();
  sim::World world(model);
  auto camera = MakeCamera(*model, state);
  if (camera == nullptr) return;
  DepthImage image;
  camera->Render(world.mj_data(), &image);
  Eigen::Matrix3Xd p_W;
  int points = 0;
  for (auto _ : state) {
    points = DepthToWorldPoints(image, 1, &p_W);
    benchmark::DoNotOptimize(p_W.data());
  }
  state.counters["points"] = benchmark::Counter(points);
}
BENCHMARK(BM_DepthToWorldPoints_320x240)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace rmpmarl::perception
