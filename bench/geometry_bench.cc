// Per-call cost of the capsule distance queries over 1024 preallocated, seeded random inputs (~30 % penetrating).
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "rmpmarl/math/geometry.h"

namespace rmpmarl::math {
namespace {

using Eigen::Quaterniond;
using Eigen::Vector3d;

constexpr int kInputs = 1024;  // a power of two: inputs are indexed with i & (kInputs − 1)

// a uniformly distributed point in the cube [-half, half]³
Vector3d RandomPoint(std::mt19937_64& rng, double half) {
  std::uniform_real_distribution<double> u(-half, half);
  return Vector3d(u(rng), u(rng), u(rng));
}

// kInputs capsules with end points in [-half, half]³ and radii in [0, r_max]
std::vector<Capsule> RandomCapsules(std::mt19937_64& rng, double half, double r_max) {
  std::uniform_real_distribution<double> radius(0.0, r_max);
  std::vector<Capsule> capsules(kInputs);
  for (Capsule& c : capsules) c = Capsule{RandomPoint(rng, half), RandomPoint(rng, half), radius(rng)};
  return capsules;
}

// which capsule–box pairs a benchmark draws: the natural mix (~30 % penetrating), or only one kind
enum class Mix { kAll, kSeparated, kPenetrating };

// randomly posed boxes near the origin and capsules around them, filtered to the requested mix
void RandomCapsuleBoxPairs(Mix mix, std::vector<Capsule>* capsules, std::vector<Box>* boxes) {
  std::mt19937_64 rng(17);
  std::uniform_real_distribution<double> half(0.05, 0.6), radius(0.0, 0.2);
  std::normal_distribution<double> normal(0.0, 1.0);
  while (static_cast<int>(capsules->size()) < kInputs) {
    Box box;
    box.X_WB.linear() = Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized().toRotationMatrix();
    box.X_WB.translation() = RandomPoint(rng, 0.3);
    box.half_size = Vector3d(half(rng), half(rng), half(rng));
    const Capsule capsule{RandomPoint(rng, 1.2), RandomPoint(rng, 1.2), radius(rng)};
    const bool penetrating = CapsuleBoxDistance(capsule, box).distance < 0.0;
    if ((mix == Mix::kSeparated && penetrating) || (mix == Mix::kPenetrating && !penetrating)) continue;
    capsules->push_back(capsule);
    boxes->push_back(box);
  }
}

// CapsuleBoxDistance over the given mix of inputs
void BM_CapsuleBoxDistance(benchmark::State& state, Mix mix) {
  std::vector<Capsule> capsules;
  std::vector<Box> boxes;
  RandomCapsuleBoxPairs(mix, &capsules, &boxes);
  int i = 0;
  for (auto _ : state) {
    DistanceResult result = CapsuleBoxDistance(capsules[i], boxes[i]);
    benchmark::DoNotOptimize(result);
    i = (i + 1) & (kInputs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK_CAPTURE(BM_CapsuleBoxDistance, mixed, Mix::kAll);
BENCHMARK_CAPTURE(BM_CapsuleBoxDistance, separated, Mix::kSeparated);
BENCHMARK_CAPTURE(BM_CapsuleBoxDistance, penetrating, Mix::kPenetrating);

// CapsuleCapsuleDistance over random pairs
void BM_CapsuleCapsuleDistance(benchmark::State& state) {
  std::mt19937_64 rng(18);
  const std::vector<Capsule> first = RandomCapsules(rng, 1.0, 0.4), second = RandomCapsules(rng, 1.0, 0.4);
  int i = 0;
  for (auto _ : state) {
    DistanceResult result = CapsuleCapsuleDistance(first[i], second[i]);
    benchmark::DoNotOptimize(result);
    i = (i + 1) & (kInputs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CapsuleCapsuleDistance);

// CapsuleSphereDistance over random pairs
void BM_CapsuleSphereDistance(benchmark::State& state) {
  std::mt19937_64 rng(19);
  const std::vector<Capsule> capsules = RandomCapsules(rng, 1.0, 0.7);
  std::vector<Sphere> spheres(kInputs);
  std::uniform_real_distribution<double> radius(0.0, 0.7);
  for (Sphere& s : spheres) s = Sphere{RandomPoint(rng, 1.0), radius(rng)};
  int i = 0;
  for (auto _ : state) {
    DistanceResult result = CapsuleSphereDistance(capsules[i], spheres[i]);
    benchmark::DoNotOptimize(result);
    i = (i + 1) & (kInputs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_CapsuleSphereDistance);

// ClosestPointsSegmentSegment over random pairs
void BM_ClosestPointsSegmentSegment(benchmark::State& state) {
  std::mt19937_64 rng(20);
  const std::vector<Capsule> first = RandomCapsules(rng, 1.0, 0.0), second = RandomCapsules(rng, 1.0, 0.0);
  int i = 0;
  for (auto _ : state) {
    SegmentClosestPoints result =
        ClosestPointsSegmentSegment(first[i].p_WA, first[i].p_WB, second[i].p_WA, second[i].p_WB);
    benchmark::DoNotOptimize(result);
    i = (i + 1) & (kInputs - 1);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ClosestPointsSegmentSegment);

}  // namespace
}  // namespace rmpmarl::math
