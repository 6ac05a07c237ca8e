// A controller's whole control step in a user's loop — control::ReactiveController::Update: the policy's sensing,
// observations and network (the learned controller) and its acceleration policy at every integration substep — for
// the shipped learned default and RMPflow, on the same states of the same scene. Per arm and scene, the states are
// recorded once from an RMPflow episode (seed 3, one state per control step) and replayed to each controller in
// order, one Update per iteration. The scenes: the demo's (the crossing scene of the default's task, moved to the
// arm: one cube) and a work cell (the cells task: a shelf, box or table of static boxes, a cube crossing on top).
#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include <map>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "learned_default.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/servos.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/tasks/task_episode.h"

namespace rmpmarl::bench {
namespace {

struct Recording {
  kinematics::Robot robot;
  std::vector<Eigen::VectorXd> q, qd;
  std::vector<rmp::Scene> scenes;
};

std::string DefaultPath() { return (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string(); }

// scene "": the controller file's own (the demo's)
const Recording& Record(const std::string& arm, const std::string& scene) {
  static std::map<std::string, Recording> cache;
  const std::string key = arm + "/" + scene;
  auto it = cache.find(key);
  if (it != cache.end()) return it->second;
  rl::TaskMove move;
  move.robot = arm;
  move.scene = scene;
  tasks::TaskConfig config = rl::PolicyTaskConfig(control::LoadPolicyFile(DefaultPath()), DefaultPath(), move);
  config.randomization.variants = 1;
  const auto context = tasks::MakeTaskContext(config);
  Recording r{context->variant(0).world_model->robot(), {}, {}, {}};
  tasks::ControllerMaker rmpflow;
  rmpflow.make_policy = [&](const kinematics::Robot& robot) {
    return std::make_unique<control::RmpflowAccelerationPolicy>(robot, context->num_obstacles());
  };
  tasks::ControllerEpisodes runner(context, rmpflow);
  std::mt19937_64 rng(3);
  runner.Run(rng, {.video_fps = 1000.0, .on_frame = [&](const sim::FrameInfo& f) {
                     r.q.push_back(f.world->q());
                     r.qd.push_back(f.world->qd());
                     r.scenes.emplace_back();
                     f.scenario->FillScene(&r.scenes.back());
                   }});
  return cache.emplace(key, std::move(r)).first->second;
}

void BM_ControllerUpdate(benchmark::State& state, const std::string& arm, const std::string& scene, bool learned) {
  const Recording& r = Record(arm, scene);
  const control::PolicyFile file = control::LoadPolicyFile(DefaultPath());
  const int obstacles = static_cast<int>(r.scenes.front().obstacles.size());
  std::unique_ptr<control::ReactiveController> controller;
  if (learned) {
    auto policy = control::MakeLearnedController(r.robot, file, DefaultPath(), obstacles);
    const control::ControllerOptions options = policy->controller_options();
    controller = std::make_unique<control::ReactiveController>(control::ServosOf(r.robot), std::move(policy), options);
  } else {
    controller = std::make_unique<control::ReactiveController>(
        control::ServosOf(r.robot), std::make_unique<control::RmpflowAccelerationPolicy>(r.robot, obstacles));
  }
  const size_t n = r.q.size();
  size_t k = 0;
  controller->Reset(r.q[0], r.qd[0]);
  for (auto _ : state) {
    benchmark::DoNotOptimize(controller->Update(r.q[k], r.qd[k], r.scenes[k]));
    if (++k == n) {
      k = 0;
      state.PauseTiming();
      controller->Reset(r.q[0], r.qd[0]);
      state.ResumeTiming();
    }
  }
  state.SetLabel(fmt::format("{}, {} scene, {} states, {} obstacle{}", learned ? "marl-rmp-residual" : "RMPflow",
                             scene.empty() ? "the demo's" : scene, n, obstacles, obstacles == 1 ? "" : "s"));
}

void Register() {
  for (const std::string scene : {"", "cells"}) {
    for (const std::string arm : {"panda", "ur5e", "xarm6"}) {
      for (const bool learned : {true, false}) {
        const std::string name =
            "BM_ControllerUpdate/" + arm + (learned ? "/learned" : "/rmpflow") + (scene.empty() ? "" : "/" + scene);
        benchmark::RegisterBenchmark(name.c_str(), [arm, scene, learned](benchmark::State& s) {
          BM_ControllerUpdate(s, arm, scene, learned);
        })->Unit(benchmark::kMicrosecond);
      }
    }
  }
}

const int registered = (Register(), 0);

}  // namespace
}  // namespace rmpmarl::bench
