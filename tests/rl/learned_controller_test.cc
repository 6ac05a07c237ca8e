// control::LearnedController — the learned agents in a user's loop — against the env they were trained in: the same
// observations and actions on the same state (its warnings from the capsules' geometry, the env's from MuJoCo), and
// a whole episode in a plain control loop without the env.
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/rl/policy_task.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "rmpmarl/common/error.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::rl {
namespace {

std::string ShippedDefault() {
  return (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string();
}

// the env's first observations and the controller's on the same reset state agree (float tolerance: MuJoCo's
// narrow phase against math::CapsuleBoxDistance), so do the actions, for several episodes and two arms
TEST(LearnedControllerTest, ObservesAndActsAsTheAgentsInTheEnv) {
  const control::PolicyFile file = control::LoadPolicyFile(ShippedDefault());
  for (const char* robot : {"panda", "ur5e"}) {
    SCOPED_TRACE(robot);
    TaskMove move;
    move.robot = robot;
    tasks::TaskConfig config = PolicyTaskConfig(file, ShippedDefault(), move);
    config.randomization.variants = 1;
    config.scenario.crossing.num_obstacles = 4;
    const auto context = tasks::MakeTaskContext(config);
    tasks::ManipulatorEnv env(context);
    tasks::StepBuffers buffers(env.spec());
    control::PolicyRuntime runtime(file.weights, context->nq());
    std::vector<float> env_actions(static_cast<size_t>(context->nq()) * env.spec().action.size());
    int compared_warnings = 0;
    std::vector<double> max_diff(env.spec().local_obs_dim, 0.0);
    double max_action_diff = 0.0;
    for (int episode = 0; episode < 6; ++episode) {
      std::mt19937_64 rng(100 + episode);
      env.Reset(rng, buffers.out());
      // a few steps into the episode so that cubes come near and options run
      for (int k = 0; k < 60 * episode; ++k) {
        runtime.Act(buffers.local_obs.data(), context->nq(), env_actions.data());
        env.Step(env_actions.data(), rng, buffers.out());
      }
      const kinematics::Robot& r = env.world().model().robot();
      control::LearnedControllerOptions options;
      options.max_obstacles = context->num_obstacles();
      control::LearnedController controller(r, tasks::AgentConfigOf(config), file.weights, options);
      controller.Reset(env.world().q());
      rmp::Scene scene;
      env.scenario().FillScene(&scene);
      controller.BeginControlStep(env.world().q(), env.world().qd(), scene);
      const int d = env.spec().local_obs_dim;
      for (int i = 0; i < context->nq(); ++i) {
        for (int k = 0; k < d; ++k) {
          if (k == control::LocalObs::kProgress || (k >= control::LocalObs::kOption && k < control::LocalObs::kRmpSize)) continue;  // episode state
          const double diff = std::abs(controller.observations()[i * d + k] - buffers.local_obs[i * d + k]);
          max_diff[k] = std::max(max_diff[k], diff);
        }
        compared_warnings += buffers.local_obs[i * d + control::LocalObs::kWarningFlag] > 0.5f;
      }
      runtime.Act(buffers.local_obs.data(), context->nq(), env_actions.data());
      // the controller's observations with the episode state (progress, running option) the fresh controller cannot
      // know: the actions they give
      std::vector<float> obs = controller.observations(), actions(env_actions.size());
      for (int i = 0; i < context->nq(); ++i) {
        for (int k : {control::LocalObs::kProgress, control::LocalObs::kOption, control::LocalObs::kOption + 1, control::LocalObs::kOption + 2,
                      control::LocalObs::kOptionPhaseB, control::LocalObs::kOptionAge}) {
          obs[i * d + k] = buffers.local_obs[i * d + k];
        }
      }
      runtime.Act(obs.data(), context->nq(), actions.data());
      // the continuous parameters (this controller runs a fixed option: its option logits are near-tied and unused)
      const tasks::ActionSpec& a = env.spec().action;
      for (int i = 0; i < context->nq(); ++i) {
        for (int c = 0; c < a.num_continuous; ++c) {
          const size_t k = static_cast<size_t>(i) * a.size() + a.continuous_offset() + c;
          max_action_diff = std::max(max_action_diff, static_cast<double>(std::abs(env_actions[k] - actions[k])));
        }
      }
    }
    // MuJoCo's narrow phase and math:: agree on the distances to 0.2 mm; the witness points of near-parallel
    // capsules (a link beside its neighbour) are not unique, and MuJoCo picks others: their direction and lever differ
    for (int k = 0; k < static_cast<int>(max_diff.size()); ++k) {
      const bool witness = (k >= control::LocalObs::kWarningDirection && k < control::LocalObs::kWarningDistance) ||
                           (k >= control::LocalObs::kWitnessLever && k < control::LocalObs::kDistanceGradient + 1);
      const double tolerance = witness ? 0.05 : k == control::LocalObs::kWarningDistance ? 1e-3 : 2e-5;
      EXPECT_LE(max_diff[k], tolerance) << control::PerJointObservationNames(config.interface, true)[k];
    }
    EXPECT_LE(max_action_diff, 0.05);  // the parameters the agents read from those observations
    EXPECT_GT(compared_warnings, 0);  // the warning features were compared where they are set
  }
}

// over whole episodes the controller, fed the env's measured state every control step, keeps the agents' episode
// state as the env does (progress, running option, its age) and sees and acts as they do all along
TEST(LearnedControllerTest, StaysInLockstepWithTheAgentsInTheEnvOverWholeEpisodes) {
  const control::PolicyFile file = control::LoadPolicyFile(ShippedDefault());
  tasks::TaskConfig config = PolicyTaskConfig(file, ShippedDefault());
  config.randomization.variants = 1;
  const auto context = tasks::MakeTaskContext(config);
  tasks::ManipulatorEnv env(context);
  tasks::StepBuffers buffers(env.spec());
  control::PolicyRuntime runtime(file.weights, context->nq());
  const int nq = context->nq(), d = env.spec().local_obs_dim;
  const tasks::ActionSpec& a = env.spec().action;
  std::vector<float> env_actions(static_cast<size_t>(nq) * a.size());
  control::LearnedControllerOptions options;
  options.max_obstacles = context->num_obstacles();
  control::LearnedController controller(env.world().model().robot(), tasks::AgentConfigOf(config), file.weights,
                                        options);
  int steps = 0, read_actions = 0;
  double max_state_diff = 0.0, max_joint_diff = 0.0, max_action_diff = 0.0;
  for (int episode = 0; episode < 2; ++episode) {
    std::mt19937_64 rng(300 + episode);
    env.Reset(rng, buffers.out());
    controller.Reset(env.world().q());
    while (!buffers.terminated && !buffers.truncated) {
      rmp::Scene scene;
      env.scenario().FillScene(&scene);
      controller.BeginControlStep(env.world().q(), env.world().qd(), scene);
      runtime.Act(buffers.local_obs.data(), nq, env_actions.data());
      for (int i = 0; i < nq; ++i) {
        const float* mine = controller.observations().data() + static_cast<size_t>(i) * d;
        const float* env_obs = buffers.local_obs.data() + static_cast<size_t>(i) * d;
        for (int k : {control::LocalObs::kProgress, control::LocalObs::kOption, control::LocalObs::kOption + 1, control::LocalObs::kOption + 2,
                      control::LocalObs::kOptionPhaseB, control::LocalObs::kOptionAge}) {
          max_state_diff = std::max(max_state_diff, static_cast<double>(std::abs(mine[k] - env_obs[k])));
        }
        for (int k = control::LocalObs::kJointPosition; k <= control::LocalObs::kJointIndex; ++k) {
          max_joint_diff = std::max(max_joint_diff, static_cast<double>(std::abs(mine[k] - env_obs[k])));
        }
        // the controller reads an action where the env's step does, and runs its network only then
        EXPECT_EQ(controller.actions_read()[i], buffers.next_action_read[i]) << "step " << steps << " joint " << i;
        if (buffers.next_action_read[i] == 0.0f) continue;
        ++read_actions;
        for (int c = 0; c < a.num_continuous; ++c) {
          const size_t k = static_cast<size_t>(i) * a.size() + a.continuous_offset() + c;
          max_action_diff = std::max(max_action_diff,
                                     static_cast<double>(std::abs(controller.actions()[k] - env_actions[k])));
        }
      }
      env.Step(env_actions.data(), rng, buffers.out());
      ++steps;
    }
  }
  EXPECT_EQ(steps, 2 * config.episode.max_steps);  // both episodes ran to the end
  EXPECT_EQ(controller.steps(), config.episode.max_steps);
  EXPECT_LE(max_state_diff, 1e-6);  // the same count and options, step by step
  EXPECT_LE(max_joint_diff, 1e-6);  // the same measured state
  EXPECT_LE(max_action_diff, 0.05);  // as on a single state (witness points of near-parallel capsules)
  EXPECT_GT(read_actions, 2 * nq * config.episode.max_steps / config.options.parameter_period);
}

// without a target in the scene the agents hold the end effector where it was at the first step without one: the
// target features are zero at once (not those of a target left over from the last step), and when the arm moves on
// they point back to the held position
TEST(LearnedControllerTest, WithoutATargetHoldsTheEndEffectorWhereItIs) {
  const control::PolicyFile file = control::LoadPolicyFile(ShippedDefault());
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  control::LearnedController controller(robot, control::PolicyAgentConfig(file, ShippedDefault()), file.weights);
  const int nq = robot.model.nq(), d = controller.observations().size() / nq;
  Eigen::VectorXd q = robot.home.size() == nq ? robot.home : Eigen::VectorXd::Zero(nq);
  const Eigen::VectorXd qd = Eigen::VectorXd::Zero(nq);
  controller.Reset(q);
  rmp::Scene scene;
  scene.has_target = true;
  scene.p_WT = Eigen::Vector3d(0.3, 0.3, 0.3);
  controller.BeginControlStep(q, qd, scene);
  EXPECT_GT(std::abs(controller.observations()[control::LocalObs::kEeToTarget]), 0.01);
  scene.has_target = false;
  q[0] += 0.5;  // the arm moved: the end effector is elsewhere, and that is the target now
  controller.BeginControlStep(q, qd, scene);
  for (int i = 0; i < nq; ++i) {
    for (int k = control::LocalObs::kEeToTarget; k < control::LocalObs::kEeToTarget + 4; ++k) {
      EXPECT_NEAR(controller.observations()[static_cast<size_t>(i) * d + k], 0.0, 1e-6) << "joint " << i << " feature " << k;
    }
  }
  Eigen::VectorXd qdd(nq);
  controller.Evaluate(q, qd, scene, qdd);
  EXPECT_TRUE(qdd.allFinite());
  q[1] += 0.3;  // moved again: the held position stays where it was
  controller.BeginControlStep(q, qd, scene);
  double feature = 0.0;
  for (int k = control::LocalObs::kEeToTarget; k < control::LocalObs::kEeToTarget + 3; ++k) {
    feature = std::max(feature, std::abs(static_cast<double>(controller.observations()[k])));
  }
  EXPECT_GT(feature, 0.01);
  // the layer pulls towards it as with that target given: q̈ equals the layer's with the held point as the target
  Eigen::VectorXd held(nq);
  controller.Evaluate(q, qd, scene, held);
  EXPECT_TRUE(held.allFinite());
  EXPECT_GT((held - qdd).norm(), 1e-3);
}

// a user's loop: World + scenario + ReactiveController, no env. On the sim's own crossing scene (four cubes) the
// learned controller runs as RMPflow does, in the same place, without a collision and tracking as close
TEST(LearnedControllerTest, RunsInAPlainControlLoopBesideRmpflow) {
  const control::PolicyFile file = control::LoadPolicyFile(ShippedDefault());
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  std::unique_ptr<sim::Scenario> scenario = sim::MakeScenario("crossing", robot);
  auto world_model = std::make_shared<const sim::WorldModel>(robot, scenario->scene_spec());
  double learned_mm = 0.0, rmpflow_mm = 0.0;
  for (std::uint64_t seed = 1; seed <= 3; ++seed) {
    auto learned = control::MakeLearnedController(robot, file, ShippedDefault(), scenario->num_obstacles());
    const control::ControllerOptions options = learned->controller_options();
    for (const bool is_learned : {true, false}) {
      sim::World world(world_model);
      std::unique_ptr<control::AccelerationPolicy> policy;
      if (is_learned) {
        policy = std::move(learned);
      } else {
        policy = std::make_unique<control::RmpflowAccelerationPolicy>(robot, scenario->num_obstacles());
      }
      control::ReactiveController controller(world_model->servos(), std::move(policy), is_learned ? options : control::ControllerOptions{});
      sim::EpisodeOptions episode;
      episode.duration = 5.0;
      episode.seed = seed;
      const sim::EpisodeMetrics r = sim::RunEpisode(episode, world, controller, *scenario, {});
      EXPECT_EQ(r.nonfinite_policy_outputs, 0);
      EXPECT_FALSE(r.invalid);
      if (is_learned) {
        EXPECT_EQ(r.collisions, 0) << "seed " << seed;
        EXPECT_EQ(controller.policy().name(), "marl-rmp-residual");
      }
      (is_learned ? learned_mm : rmpflow_mm) += 1000.0 * r.settled_tracking_error / 3.0;
    }
  }
  std::printf("tracking error, mean of 3 episodes: learned %.1f mm, RMPflow %.1f mm\n", learned_mm, rmpflow_mm);
  EXPECT_LT(learned_mm, 1.25 * rmpflow_mm);
}

TEST(LearnedControllerTest, RefusesWhatDoesNotFit) {
  const control::PolicyFile file = control::LoadPolicyFile(ShippedDefault());
  const kinematics::Robot robot = kinematics::LoadShippedRobot("panda");
  tasks::TaskConfig direct = PolicyTaskConfig(file, ShippedDefault());
  direct.interface = tasks::InterfaceMode::kPerJointDirect;
  EXPECT_THROW(control::LearnedController(robot, tasks::AgentConfigOf(direct), file.weights), InputError);
  tasks::TaskConfig no_lookahead = PolicyTaskConfig(file, ShippedDefault());
  no_lookahead.observation.lookahead = 0.0;
  no_lookahead.options.target_gate_clearance = -INFINITY;
  try {
    control::LearnedController c(robot, tasks::AgentConfigOf(no_lookahead), file.weights);
    ADD_FAILURE() << "expected an InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("observations"), std::string::npos) << e.what();
  }
  control::LearnedControllerOptions one_obstacle;
  one_obstacle.max_obstacles = 1;
  control::LearnedController c(robot, control::PolicyAgentConfig(file, ShippedDefault()), file.weights, one_obstacle);
  c.Reset(Eigen::VectorXd::Zero(robot.model.nq()));
  rmp::Scene scene;
  scene.obstacles.assign(2, rmp::Obstacle::MakeSphere(Eigen::Vector3d(1, 1, 1), 0.05));
  EXPECT_THROW(c.BeginControlStep(Eigen::VectorXd::Zero(robot.model.nq()), Eigen::VectorXd::Zero(robot.model.nq()),
                                  scene),
               InputError);
  TaskMove static_scene;
  static_scene.scene = "static-reach";
  EXPECT_THROW(PolicyTaskConfig(file, ShippedDefault(), static_scene), InputError);
  TaskMove static_speed;
  static_speed.scene = "cluttered";
  static_speed.obstacle_speed = 1.0;
  EXPECT_THROW(PolicyTaskConfig(file, ShippedDefault(), static_speed), InputError);
}

}  // namespace
}  // namespace rmpmarl::rl
