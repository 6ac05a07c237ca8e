// World::Step and World::QueryContacts for Panda with 4 cube obstacles near the arm (the paper's setting).
// Run: build/bench/sim_bench --benchmark_repetitions=5 --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>

#include "rmpmarl/sim/world.h"

namespace rmpmarl::sim {
namespace {

// a configuration in the middle of the joint ranges, nudged by `phase`.
Eigen::VectorXd Configuration(const WorldModel& wm, double phase) {
  Eigen::VectorXd q(wm.nq());
  for (int i = 0; i < wm.nq(); ++i) {
    const double lo = std::isfinite(wm.lower_limits()[i]) ? wm.lower_limits()[i] : -M_PI;
    const double hi = std::isfinite(wm.upper_limits()[i]) ? wm.upper_limits()[i] : M_PI;
    q[i] = 0.5 * (lo + hi) + 0.15 * (hi - lo) * std::sin(phase + i);
  }
  return q;
}

std::shared_ptr<const WorldModel> PandaWithFourBoxes() {
  SceneSpec scene;
  for (int j = 0; j < 4; ++j) scene.obstacles.push_back(ObstacleSpec::Cube(0.1));
  return std::make_shared<const WorldModel>(kinematics::LoadShippedRobot("panda"), scene);
}

// four cubes around the arm: some within the 15 cm warning margin of its links.
void PlaceBoxes(World* world) {
  const Eigen::Vector3d p[4] = {{0.45, 0.15, 0.45}, {0.45, -0.2, 0.3}, {0.2, 0.3, 0.7}, {0.35, 0.0, 0.9}};
  for (int j = 0; j < 4; ++j) world->SetObstaclePose(j, p[j], Eigen::Matrix3d::Identity());
}

void BM_WorldStep(benchmark::State& state) {
  auto wm = PandaWithFourBoxes();
  World world(wm);
  world.Reset(Configuration(*wm, 0.0));
  PlaceBoxes(&world);
  // the arm swings between two configurations near the boxes (a new target every 0.5 s of simulated time).
  const Eigen::VectorXd targets[2] = {Configuration(*wm, 0.3), Configuration(*wm, -0.3)};
  long steps = 0;
  double contacts = 0.0;
  for (auto _ : state) {
    if (steps++ % 250 == 0) world.SetJointTargets(targets[(steps / 250) % 2]);
    benchmark::DoNotOptimize(world.Step());
    contacts += world.mj_data()->ncon;
  }
  state.counters["contacts/step"] = benchmark::Counter(contacts / static_cast<double>(state.iterations()));
  state.counters["steps/s"] = benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_WorldStep)->Unit(benchmark::kMicrosecond);

// the query after a step: MuJoCo's contacts are current, only the classification runs.
void BM_QueryContacts(benchmark::State& state) {
  auto wm = PandaWithFourBoxes();
  World world(wm);
  world.Reset(Configuration(*wm, 0.0));
  PlaceBoxes(&world);
  world.Step();
  long warnings = 0;
  for (auto _ : state) {
    const ContactReport& report = world.QueryContacts();
    warnings = static_cast<long>(report.warnings.size());
    benchmark::DoNotOptimize(report.min_clearance);
  }
  state.counters["warnings"] = benchmark::Counter(static_cast<double>(warnings));
}
BENCHMARK(BM_QueryContacts)->Unit(benchmark::kMicrosecond);

// the query right after an obstacle moved: includes MuJoCo's position stage (kinematics + collision detection).
void BM_QueryContactsAfterObstacleMove(benchmark::State& state) {
  auto wm = PandaWithFourBoxes();
  World world(wm);
  world.Reset(Configuration(*wm, 0.0));
  PlaceBoxes(&world);
  const Eigen::Isometry3d X0 = world.ObstaclePose(0);
  long i = 0;
  for (auto _ : state) {
    Eigen::Isometry3d X = X0;
    X.translation().z() += 0.01 * static_cast<double>(++i % 10);
    world.SetObstaclePose(0, X);
    benchmark::DoNotOptimize(world.QueryContacts().min_clearance);
  }
}
BENCHMARK(BM_QueryContactsAfterObstacleMove)->Unit(benchmark::kMicrosecond);

// building the shared model once per variant: MJCF generation + two MuJoCo compilations.
void BM_WorldModelBuild(benchmark::State& state) {
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  SceneSpec scene;
  for (int j = 0; j < 4; ++j) scene.obstacles.push_back(ObstacleSpec::Cube(0.1));
  for (auto _ : state) benchmark::DoNotOptimize(WorldModel(robot, scene).mj_model());
}
BENCHMARK(BM_WorldModelBuild)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace rmpmarl::sim
