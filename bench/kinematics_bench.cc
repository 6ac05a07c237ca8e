// Kinematics benchmarks: forward kinematics + position Jacobians of capsule end points on a 7-DoF arm (goal ≤ 1 µs).
#include <benchmark/benchmark.h>

#include <random>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"

namespace {

using namespace rmpmarl::kinematics;

// random configurations within limits, precomputed so the benchmark loop measures kinematics only.
std::vector<Eigen::VectorXd> Configurations(const Model& model, int count) {
  std::mt19937_64 rng(42);
  std::vector<Eigen::VectorXd> qs;
  for (int n = 0; n < count; ++n) {
    Eigen::VectorXd q(model.nq());
    for (int i = 0; i < model.nq(); ++i) {
      q[i] = std::uniform_real_distribution<double>(model.limits()[i].lower, model.limits()[i].upper)(rng);
    }
    qs.push_back(q);
  }
  return qs;
}

// FK + Jacobians of `num_points` capsule end points (the first capsules' A and B points in order).
void BM_FkAndCapsuleJacobians(benchmark::State& state, const std::string& robot_name, int num_points) {
  const Robot robot = LoadShippedRobot(robot_name);
  const Model& model = robot.model;
  Data data(model);
  std::vector<std::pair<int, Eigen::Vector3d>> points;
  for (const LinkCapsule& c : robot.capsules) {
    if (model.link_dofs(c.link).empty()) continue;  // the base does not move
    points.emplace_back(c.link, c.p_LA);
    points.emplace_back(c.link, c.p_LB);
  }
  points.resize(std::min<size_t>(points.size(), num_points));
  std::vector<Eigen::Matrix3Xd> jacobians(points.size(), Eigen::Matrix3Xd(3, model.nq()));
  const auto qs = Configurations(model, 256);
  size_t n = 0;
  for (auto _ : state) {
    CalcForwardKinematics(model, qs[n++ & 255], &data);
    for (size_t p = 0; p < points.size(); ++p) {
      CalcPointJacobian(model, data, points[p].first, points[p].second, jacobians[p]);
    }
    benchmark::DoNotOptimize(jacobians.back().data());
    benchmark::ClobberMemory();
  }
  state.counters["points"] = static_cast<double>(points.size());
}

void BM_ForwardKinematics(benchmark::State& state, const std::string& robot_name) {
  const Robot robot = LoadShippedRobot(robot_name);
  Data data(robot.model);
  const auto qs = Configurations(robot.model, 256);
  size_t n = 0;
  for (auto _ : state) {
    CalcForwardKinematics(robot.model, qs[n++ & 255], &data);
    benchmark::DoNotOptimize(data.X_WL.back().data());
  }
}

void BM_VelocityKinematicsAndJdotQdot(benchmark::State& state, const std::string& robot_name) {
  const Robot robot = LoadShippedRobot(robot_name);
  Data data(robot.model);
  const auto qs = Configurations(robot.model, 256);
  const Eigen::VectorXd qd = Eigen::VectorXd::Constant(robot.model.nq(), 0.5);
  size_t n = 0;
  for (auto _ : state) {
    CalcVelocityKinematics(robot.model, qs[n++ & 255], qd, &data);
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const LinkCapsule& c : robot.capsules) sum += CalcPointJdotQdot(data, c.link, c.p_LB);
    benchmark::DoNotOptimize(sum.data());
  }
}

BENCHMARK_CAPTURE(BM_ForwardKinematics, panda, std::string("panda"));
BENCHMARK_CAPTURE(BM_FkAndCapsuleJacobians, panda_7_points, std::string("panda"), 7);
BENCHMARK_CAPTURE(BM_FkAndCapsuleJacobians, panda_14_points, std::string("panda"), 14);
BENCHMARK_CAPTURE(BM_FkAndCapsuleJacobians, iiwa14_14_points, std::string("iiwa14"), 14);
BENCHMARK_CAPTURE(BM_VelocityKinematicsAndJdotQdot, panda, std::string("panda"));

}  // namespace
