// Cost of the robot collision checker (collision/checker.h) on the shipped Panda in front of a shelf of five boards:
// a configuration check (the fraction found free is reported; against the obstacles and against them prepared),
// placing the capsules alone, the exact clearance with its pair, and a 0.5 rad edge
// checked coarse to fine at 0.01 rad. 256 seeded configurations around the ready posture, preallocated.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "rmpmarl/collision/checker.h"
#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::collision {
namespace {

constexpr int kInputs = 256;  // a power of two: inputs are indexed with i & (kInputs − 1)

struct Fixture {
  kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  RobotCollisionModel model{robot};
  RobotCollisionData data{model};
  std::vector<rmp::Obstacle> shelf;
  std::vector<Eigen::VectorXd> q, q_to;
  Eigen::VectorXd scratch;

  Fixture() {
    // a shelf 0.5 m in front of the base: two sides, a top, a bottom and a middle board
    auto board = [&](double x, double y, double z, double hx, double hy, double hz) {
      Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
      X.translation() = Eigen::Vector3d(x, y, z);
      shelf.push_back(rmp::Obstacle::MakeBox(X, Eigen::Vector3d(hx, hy, hz)));
    };
    board(0.65, -0.4, 0.6, 0.15, 0.01, 0.6);
    board(0.65, 0.4, 0.6, 0.15, 0.01, 0.6);
    board(0.65, 0.0, 1.2, 0.15, 0.4, 0.01);
    board(0.65, 0.0, 0.0, 0.15, 0.4, 0.01);
    board(0.65, 0.0, 0.55, 0.15, 0.4, 0.01);
    Eigen::VectorXd ready(7);
    ready << 0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785;
    std::mt19937_64 rng(3);
    std::uniform_real_distribution<double> u(-0.8, 0.8), step(-1.0, 1.0);
    for (int i = 0; i < kInputs; ++i) {
      Eigen::VectorXd a = ready, d(7);
      for (int j = 0; j < 7; ++j) {
        a[j] += u(rng);
        d[j] = step(rng);
      }
      q.push_back(a);
      q_to.push_back(a + 0.5 * d.normalized());
    }
    scratch.resize(7);
  }
};

Fixture& Shared() {
  static Fixture f;
  return f;
}

void BM_CheckConfigCollisionFree(benchmark::State& state) {
  Fixture& f = Shared();
  int i = 0, free = 0;
  for (auto _ : state) {
    free += CheckConfigCollisionFree(f.model, f.q[i++ & (kInputs - 1)], f.shelf, 0.01, &f.data) ? 1 : 0;
  }
  state.counters["free_fraction"] = static_cast<double>(free) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_CheckConfigCollisionFree);

void BM_CheckConfigCollisionFreePrepared(benchmark::State& state) {
  Fixture& f = Shared();
  const PreparedObstacles shelf(f.shelf);
  int i = 0, free = 0;
  for (auto _ : state) {
    free += CheckConfigCollisionFree(f.model, f.q[i++ & (kInputs - 1)], shelf, 0.01, 0.01, false, &f.data) ? 1 : 0;
  }
  state.counters["free_fraction"] = static_cast<double>(free) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_CheckConfigCollisionFreePrepared);

void BM_PlaceRobot(benchmark::State& state) {
  Fixture& f = Shared();
  int i = 0;
  for (auto _ : state) {
    PlaceRobot(f.model, f.q[i++ & (kInputs - 1)], &f.data);
    benchmark::DoNotOptimize(f.data.capsule_W.data());
  }
}
BENCHMARK(BM_PlaceRobot);

void BM_CalcRobotClearance(benchmark::State& state) {
  Fixture& f = Shared();
  int i = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(CalcRobotClearance(f.model, f.q[i++ & (kInputs - 1)], f.shelf, &f.data).distance);
  }
}
BENCHMARK(BM_CalcRobotClearance);

void BM_CheckEdgeCollisionFree(benchmark::State& state) {
  Fixture& f = Shared();
  int i = 0, free = 0;
  for (auto _ : state) {
    const int k = i++ & (kInputs - 1);
    free += CheckEdgeCollisionFree(f.model, f.q[k], f.q_to[k], f.shelf, 0.01, 0.01, &f.data, &f.scratch) ? 1 : 0;
  }
  state.counters["free_fraction"] = static_cast<double>(free) / static_cast<double>(state.iterations());
}
BENCHMARK(BM_CheckEdgeCollisionFree);

}  // namespace
}  // namespace rmpmarl::collision
