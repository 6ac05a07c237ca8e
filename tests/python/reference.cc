// The C++ side of the Python tests' comparisons: the engine and the controllers driven from C++ alone, on inputs the
// test writes, with outputs the test compares with what the Python package returns for the same inputs.
//   reference rollout TASK ROBOT INTERFACE NUM_ENVS SEED STEPS ACTIONS.f32 OUT.f32 OVERRIDES
//     VecEnv (next-step autoreset) reset with SEED, then STEPS steps with the actions (float32 [STEPS, N, A, act]);
//     writes per reset/step: obs [N, A, D], state [N, S], rewards [N], terminated [N], truncated [N] as float32.
//   reference controller POLICY|rmpflow ROBOT STEPS INPUT.f64 OUT.f64
//     input per step: q, qd (nq each), target (3), one box (centre 3, half sizes 3); the first step's q, qd reset.
//     writes per step: q̈ of the policy (decide on this state) and q_cmd, q̇_cmd of a ReactiveController::Update.
#include <cstdio>
#include <exception>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/vec_env.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/world.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/tasks/task_config.h"

using namespace rmpmarl;

namespace {

template <typename T>
std::vector<T> ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::vector<char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<T> v(bytes.size() / sizeof(T));
  std::copy(bytes.begin(), bytes.begin() + static_cast<long>(v.size() * sizeof(T)), reinterpret_cast<char*>(v.data()));
  return v;
}

template <typename T>
void Write(std::ofstream& out, const T* data, size_t count) {
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(count * sizeof(T)));
}

int Rollout(char** argv) {
  tasks::TaskConfig config = tasks::LoadTaskConfig(tasks::TaskConfigPath(argv[2]), argv[10]);
  config.robot = argv[3];
  config.interface = tasks::ParseInterfaceMode(argv[4]);
  const int n = std::stoi(argv[5]);
  const std::uint64_t seed = std::stoull(argv[6]);
  const int steps = std::stoi(argv[7]);
  rl::VecEnv env(tasks::MakeManipulatorEnvFactory(tasks::MakeTaskContext(config)),
                 {.num_envs = n, .seed = 0, .num_threads = 2, .autoreset = rl::Autoreset::kNextStep});
  const std::vector<float> actions = ReadAll<float>(argv[8]);
  const tasks::EnvSpec& s = env.spec();
  const size_t per_step = static_cast<size_t>(n) * s.num_agents * s.action.size();
  if (actions.size() != per_step * steps) {
    std::fprintf(stderr, "reference rollout: expected %zu actions, got %zu\n", per_step * steps, actions.size());
    return 2;
  }
  std::ofstream out(argv[9], std::ios::binary);
  auto record = [&] {
    const rl::Batch& b = env.batch();
    Write(out, b.local_obs.data(), b.local_obs.size());
    Write(out, b.global_state.data(), b.global_state.size());
    Write(out, b.reward.data(), b.reward.size());
    for (int k = 0; k < n; ++k) {
      const float flags[2] = {static_cast<float>(b.terminated[k]), static_cast<float>(b.truncated[k])};
      Write(out, flags, 2);
    }
  };
  env.Reset(seed);
  record();
  for (int t = 0; t < steps; ++t) {
    env.Step(actions.data() + t * per_step);
    record();
  }
  return 0;
}

int Controller(char** argv) {
  const std::string which = argv[2];
  const kinematics::Robot robot = kinematics::LoadShippedRobot(argv[3]);
  const int steps = std::stoi(argv[4]);
  const int nq = robot.model.nq();
  const std::vector<double> input = ReadAll<double>(argv[5]);
  const size_t per_step = 2 * nq + 9;
  if (input.size() != per_step * steps) {
    std::fprintf(stderr, "reference controller: expected %zu values, got %zu\n", per_step * steps, input.size());
    return 2;
  }
  auto world = std::make_shared<const sim::WorldModel>(robot);
  auto make = [&]() -> std::pair<std::unique_ptr<control::AccelerationPolicy>, control::ControllerOptions> {
    if (which == "rmpflow") {
      return {std::make_unique<control::RmpflowAccelerationPolicy>(world->robot(), rmp::LoadRmpflowOptions(world->robot()),
                                                               4),
              control::ControllerOptions{}};
    }
    const control::PolicyFile file = control::LoadPolicyFile(which);
    control::LearnedControllerOptions options;
    options.max_obstacles = 4;
    auto learned = control::MakeLearnedController(world->robot(), file, which, options);
    const control::ControllerOptions controller_options = learned->controller_options();
    return {std::move(learned), controller_options};
  };
  auto [policy, unused] = make();
  auto [loop_policy, options] = make();
  control::ReactiveController controller(world->servos(), std::move(loop_policy), options);
  std::ofstream out(argv[6], std::ios::binary);
  Eigen::VectorXd qdd(nq);
  rmp::Scene scene;
  for (int t = 0; t < steps; ++t) {
    const double* in = input.data() + t * per_step;
    const Eigen::Map<const Eigen::VectorXd> q(in, nq), qd(in + nq, nq);
    scene.p_WT = Eigen::Vector3d(in + 2 * nq);
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.translation() = Eigen::Vector3d(in + 2 * nq + 3);
    scene.obstacles = {rmp::Obstacle::MakeBox(X, Eigen::Vector3d(in + 2 * nq + 6))};
    if (t == 0) {
      policy->Reset(q);
      controller.Reset(q, qd);
    }
    policy->BeginControlStep(q, qd, scene);
    policy->Evaluate(q, qd, scene, qdd);
    controller.Update(q, qd, scene);
    Write(out, qdd.data(), nq);
    Write(out, controller.q_cmd().data(), nq);
    Write(out, controller.qd_cmd().data(), nq);
  }
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  try {
    const std::string mode = argc > 1 ? argv[1] : "";
    if (mode == "rollout" && argc == 11) return Rollout(argv);
    if (mode == "controller" && argc == 7) return Controller(argv);
    std::fprintf(stderr, "usage: reference rollout TASK ROBOT INTERFACE N SEED STEPS ACTIONS OUT OVERRIDES | controller "
                         "POLICY|rmpflow ROBOT STEPS INPUT OUT\n");
    return 2;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "reference: %s\n", e.what());
    return 1;
  }
}
