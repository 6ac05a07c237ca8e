// RMP benchmarks: the full RMPflow baseline evaluation (kinematics, distances, every leaf RMP, pullback, resolve) on
// a 7-DoF arm with 20 box obstacles (goal ≤ 3 µs), and the paper's two-RMP basic layer at one joint.
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "learned_default.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/joint_layer.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "rmpmarl/control/agent_interface.h"

namespace {

using namespace rmpmarl;

constexpr int kStates = 256;  // a power of two: states are indexed with n & (kStates − 1)

// the 7-DoF Panda; `one_capsule_per_link` keeps the first capsule of every moving link (7) as in the goal's "7 link
// capsules", otherwise all 12 capsules of its moving links (13 with the base) take part.
kinematics::Robot BenchRobot(bool one_capsule_per_link) {
  kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  if (one_capsule_per_link) {
    std::vector<kinematics::LinkCapsule> kept;
    std::vector<char> seen(robot.model.num_links(), 0);
    for (const kinematics::LinkCapsule& c : robot.capsules) {
      if (robot.model.link_dofs(c.link).empty() || seen[c.link]) continue;
      seen[c.link] = 1;
      kept.push_back(c);
    }
    robot.capsules = kept;
  }
  return robot;
}

// random states within the joint limits (velocities up to half the limits), precomputed
void States(const kinematics::Model& model, std::vector<Eigen::VectorXd>* qs, std::vector<Eigen::VectorXd>* qds) {
  std::mt19937_64 rng(42);
  for (int n = 0; n < kStates; ++n) {
    Eigen::VectorXd q(model.nq()), qd(model.nq());
    for (int i = 0; i < model.nq(); ++i) {
      const auto& l = model.limits()[i];
      const double lo = std::isfinite(l.lower) ? l.lower : -M_PI, hi = std::isfinite(l.upper) ? l.upper : M_PI;
      q[i] = std::uniform_real_distribution<double>(lo, hi)(rng);
      qd[i] = std::uniform_real_distribution<double>(-0.5, 0.5)(rng) * l.velocity;
    }
    qs->push_back(q);
    qds->push_back(qd);
  }
}

// 20 randomly posed boxes (5–15 cm half sides) in a 1.6 × 1.6 × 1.2 m workspace around the arm, and a target
rmp::Scene BoxScene(int count) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> xy(-0.8, 0.8), z(0.0, 1.2), half(0.05, 0.15), v(-0.2, 0.2);
  std::normal_distribution<double> normal(0.0, 1.0);
  rmp::Scene scene;
  for (int k = 0; k < count; ++k) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.linear() = Eigen::Quaterniond(normal(rng), normal(rng), normal(rng), normal(rng)).normalized().toRotationMatrix();
    X.translation() = Eigen::Vector3d(xy(rng), xy(rng), z(rng));
    scene.obstacles.push_back(rmp::Obstacle::MakeBox(X, Eigen::Vector3d(half(rng), half(rng), half(rng)),
                                                     Eigen::Vector3d(v(rng), v(rng), v(rng))));
  }
  scene.p_WT = Eigen::Vector3d(0.4, 0.2, 0.5);
  return scene;
}

// full RMPflow evaluation: q, q̇, scene ↦ q̈
// (radius > 0 overrides the collision RMP's deactivation radius r, default 0.5 m)
void BM_RmpflowEvaluate(benchmark::State& state, bool one_capsule_per_link, int num_boxes, double radius) {
  const kinematics::Robot robot = BenchRobot(one_capsule_per_link);
  rmp::RmpflowOptions options = rmp::LoadRmpflowOptions(rmp::RmpflowConfigPath(robot.name));
  if (radius > 0.0) options.collision.metric_modulation_radius = radius;
  rmp::RmpflowPolicy policy(robot, options, num_boxes);
  const rmp::Scene scene = BoxScene(num_boxes);
  std::vector<Eigen::VectorXd> qs, qds;
  States(robot.model, &qs, &qds);
  Eigen::VectorXd qdd(robot.model.nq());
  size_t n = 0;
  double active_obstacle = 0.0, active_self = 0.0;
  for (auto _ : state) {
    const size_t k = n++ & (kStates - 1);
    policy.Evaluate(qs[k], qds[k], scene, qdd);
    benchmark::DoNotOptimize(qdd.data());
    benchmark::ClobberMemory();
    active_obstacle += policy.diagnostics().active_obstacle_pairs;
    active_self += policy.diagnostics().active_self_pairs;
  }
  state.counters["dofs"] = robot.model.nq();
  state.counters["capsules"] = static_cast<double>(robot.capsules.size());
  state.counters["boxes"] = num_boxes;
  state.counters["active_obst_pairs"] = active_obstacle / static_cast<double>(n);
  state.counters["active_self_pairs"] = active_self / static_cast<double>(n);
}

// the paper's two RMPs at one joint (target at the end effector + collision RMPs of the capsules the joint moves);
// with_kinematics adds the CalcVelocityKinematics the per-joint agents share
void BM_JointLayer(benchmark::State& state, int dof, bool with_kinematics) {
  const kinematics::Robot robot = BenchRobot(/*one_capsule_per_link=*/true);
  kinematics::Data kin(robot.model);
  const rmp::Scene scene = BoxScene(20);
  std::vector<Eigen::VectorXd> qs, qds;
  States(robot.model, &qs, &qds);
  const rmp::BasicRmpParams params;
  const rmp::JointLayerWeights weights;
  const int d = std::min(dof, robot.model.nq() - 1);
  size_t n = 0;
  double terms = 0.0;
  if (!with_kinematics) kinematics::CalcVelocityKinematics(robot.model, qs[0], qds[0], &kin);
  for (auto _ : state) {
    const size_t k = n++ & (kStates - 1);
    if (with_kinematics) kinematics::CalcVelocityKinematics(robot.model, qs[k], qds[k], &kin);
    const rmp::JointLayerResult r = rmp::EvaluateJointLayer(robot, kin, d, scene, params, weights);
    benchmark::DoNotOptimize(r.qdd);
    terms += r.collision_terms;
  }
  state.counters["collision_terms"] = terms / static_cast<double>(n);
}

// the basic layer at all 7 joints in one pass (each distance computed once), kinematics included
void BM_JointLayersAllJoints(benchmark::State& state) {
  const kinematics::Robot robot = BenchRobot(/*one_capsule_per_link=*/true);
  kinematics::Data kin(robot.model);
  const rmp::Scene scene = BoxScene(20);
  std::vector<Eigen::VectorXd> qs, qds;
  States(robot.model, &qs, &qds);
  const std::vector<rmp::JointLayerWeights> weights(robot.model.nq());
  std::vector<rmp::JointLayerResult> results(robot.model.nq());
  size_t n = 0;
  for (auto _ : state) {
    const size_t k = n++ & (kStates - 1);
    kinematics::CalcVelocityKinematics(robot.model, qs[k], qds[k], &kin);
    rmp::EvaluateJointLayers(robot, kin, scene, rmp::BasicRmpParams{}, weights, results);
    benchmark::DoNotOptimize(results.data());
  }
}

// the learned default's layer (the coupled resolve of the agents' target and collision RMPs on RMPflow's structure,
// with the parameters its controller file carries) at random per-joint scales in the agents' range, on the same
// states and scenes as BM_RmpflowEvaluate: structure (push-forward, C-space leaves, pullback) and coupled layer, as one
// control substep evaluates them; `vectorised` false: the scalar leaf loop (CoupledLayerWorkspace::vectorised)
void BM_CoupledLayerEvaluate(benchmark::State& state, int num_boxes, bool vectorised) {
  const kinematics::Robot robot = BenchRobot(/*one_capsule_per_link=*/false);
  const int nq = robot.model.nq();
  rmp::RmpflowPolicy structure(robot, rmp::LoadRmpflowOptions(rmp::RmpflowConfigPath(robot.name)), 0);
  const tasks::TaskConfig config = bench::LearnedDefaultConfig();
  const rmp::BasicRmpParams& params = config.basic_layer.params;
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto gain = [&](double range) { return control::GainScale(u(rng), range); };  // an agent's scale
  std::vector<rmp::JointLayerWeights> weights(nq);
  for (rmp::JointLayerWeights& w : weights) {
    w.target_accel_scale = gain(config.options.TargetGainRange());
    w.target_metric_scale = gain(config.options.TargetGainRange());
    w.collision_accel_scale = gain(config.options.gain_range);
    w.collision_metric_scale = gain(config.options.gain_range);
    w.collision_length_scale = std::pow(w.collision_accel_scale, config.options.collision_length_exponent);
  }
  rmp::CoupledLayerWorkspace workspace(nq);
  workspace.vectorised = vectorised;
  const rmp::Scene scene = BoxScene(num_boxes);
  std::vector<Eigen::VectorXd> qs, qds;
  States(robot.model, &qs, &qds);
  Eigen::VectorXd qdd(nq);
  size_t n = 0;
  for (auto _ : state) {
    const size_t k = n++ & (kStates - 1);
    structure.EvaluateStructure(qs[k], qds[k]);
    rmp::EvaluateCoupledLayer(robot, structure.data().kinematics, scene, params, weights, structure.data().f_root,
                              structure.data().M_root, config.basic_layer.relative_regularizer, &workspace, qdd);
    benchmark::DoNotOptimize(qdd.data());
    benchmark::ClobberMemory();
  }
}

BENCHMARK_CAPTURE(BM_RmpflowEvaluate, arm7_7caps_20boxes, true, 20, 0.0);
BENCHMARK_CAPTURE(BM_RmpflowEvaluate, arm7_allcaps_5boxes, false, 5, 0.0);
BENCHMARK_CAPTURE(BM_RmpflowEvaluate, arm7_allcaps_0boxes, false, 0, 0.0);
BENCHMARK_CAPTURE(BM_CoupledLayerEvaluate, default_layer_arm7_allcaps_0boxes, 0, true);
BENCHMARK_CAPTURE(BM_CoupledLayerEvaluate, default_layer_arm7_allcaps_5boxes, 5, true);
BENCHMARK_CAPTURE(BM_CoupledLayerEvaluate, default_layer_arm7_allcaps_5boxes_scalar, 5, false);
BENCHMARK_CAPTURE(BM_CoupledLayerEvaluate, default_layer_arm7_allcaps_20boxes, 20, true);
BENCHMARK_CAPTURE(BM_CoupledLayerEvaluate, default_layer_arm7_allcaps_20boxes_scalar, 20, false);
BENCHMARK_CAPTURE(BM_RmpflowEvaluate, arm7_7caps_20boxes_r0.2, true, 20, 0.2);
BENCHMARK_CAPTURE(BM_RmpflowEvaluate, arm7_allcaps_20boxes, false, 20, 0.0);
BENCHMARK_CAPTURE(BM_RmpflowEvaluate, arm7_7caps_0boxes, true, 0, 0.0);
BENCHMARK_CAPTURE(BM_JointLayer, joint4_20boxes, 3, false);
BENCHMARK_CAPTURE(BM_JointLayer, joint4_20boxes_with_kinematics, 3, true);
BENCHMARK_CAPTURE(BM_JointLayer, joint1_20boxes_with_kinematics, 0, true);
BENCHMARK(BM_JointLayersAllJoints);

}  // namespace
