#pragma once
/// The manipulator environment (docs/environments.md): ONE Env implementation parameterised by robot, scenario and
/// interface mode; the paper's tasks (pretrain-2link, reach-avoid, line-crossing, cluttered) are TaskConfigs.
///
///   auto context = tasks::MakeTaskContext(tasks::LoadShippedTaskConfig("reach-avoid"));  // builds the variant pool once
///   rl::VecEnv envs(tasks::MakeManipulatorEnvFactory(context), {.num_envs = 64, .seed = 1, .num_threads = 2});
///
/// A TaskContext is built once per config and shared (read-only) by every env: it owns the pool of K link-length
/// variants, each compiled into one sim::WorldModel. An env picks a variant per reset and never builds a model.
/// Env::Step allocates nothing.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <random>
#include <span>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/tasks/env.h"
#include "rmpmarl/control/joint_agents.h"
#include "rmpmarl/tasks/reward.h"
#include "rmpmarl/tasks/task_config.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::tasks {

/// a geometrically similar copy of `robot` scaled by s: joint offsets, capsule end points and radii, and the
/// end-effector offset (so self-collision properties are unchanged). Throws InputError unless s > 0.
kinematics::Robot ScaleRobot(const kinematics::Robot& robot, double s);

/// the robot a task config names, before randomisation (planar2 with the mid link lengths, or a shipped arm).
kinematics::Robot NominalTaskRobot(const TaskConfig& config);

/// Makes a scenario for a robot variant (tests and tools: replaces the task's own scenario).
using ScenarioMaker = std::function<std::unique_ptr<sim::Scenario>(const kinematics::Robot& variant_robot)>;

/// One link-length variant of the task's robot, compiled once.
struct RobotVariant {
  std::shared_ptr<const sim::WorldModel> world_model;
  double link_scale = 1.0;                      ///< URDF arms: the uniform scale (1 for planar2)
  std::array<double, 2> planar2_lengths = {0, 0};  ///< planar2: link lengths [m]
};

/// Everything an env of one task shares with its siblings, built once: the validated config, the EnvSpec, the
/// variant pool (K WorldModels) and the obstacle layout. Immutable after construction; safe to share across threads.
class TaskContext {
 public:
  /// validates `config` (InputError), loads the robot and builds config.randomization.variants WorldModels.
  /// `scenario` (optional) replaces the task's scenario for every variant.
  explicit TaskContext(TaskConfig config, ScenarioMaker scenario = {});
  TaskContext(const TaskContext&) = delete;
  TaskContext& operator=(const TaskContext&) = delete;

  const TaskConfig& config() const { return config_; }
  const EnvSpec& spec() const { return spec_; }
  int nq() const { return nq_; }
  int num_agents() const { return spec_.num_agents; }
  int num_obstacles() const { return num_obstacles_; }
  int num_variants() const { return static_cast<int>(variants_.size()); }
  const RobotVariant& variant(int k) const { return variants_[k]; }
  /// per-episode choices of the scenario besides the variant (line-crossing: the speeds; else 1).
  int num_scenario_settings() const { return num_settings_; }
  /// a fresh scenario for variant k and setting s (envs call this lazily, once per pair).
  std::unique_ptr<sim::Scenario> MakeScenario(int variant, int setting) const;
  const control::GlobalStateLayout& global_layout() const { return global_layout_; }

 private:
  TaskConfig config_;
  ScenarioMaker scenario_maker_;
  std::function<std::unique_ptr<sim::Scenario>(const kinematics::Robot&, int setting)> make_scenario_;
  EnvSpec spec_;
  int nq_ = 0;
  int num_obstacles_ = 0;
  int num_settings_ = 1;
  std::vector<RobotVariant> variants_;
  control::GlobalStateLayout global_layout_{InterfaceMode::kDirect, 0, 0};
};

/// std::make_shared<const TaskContext>(config, scenario).
std::shared_ptr<const TaskContext> MakeTaskContext(TaskConfig config, ScenarioMaker scenario = {});

/// WorldModels built by TaskContexts in this process so far (tests check that envs and resets build none).
long WorldModelsBuilt();

/// What happened in the last Step (diagnostics, tests). Sized at construction.
struct StepInfo {
  bool invalid = false;            ///< the step ended the episode as invalid
  int collision_events = 0;        ///< collision events in this step
  double distance_before = 0.0;    ///< ‖p_E − p_T‖ before the step [m]
  double distance_after = 0.0;     ///< after [m]
  RewardTerms reward;              ///< the step's terms
  Eigen::VectorXd joint_reach;     ///< R_i per joint (before δ_i)
  Eigen::VectorXd dq_command;      ///< commanded joint displacement of the step
  Eigen::VectorXd qdd;             ///< per-joint-rmp: the basic layer's q̈ of the step
};

/// A controller that drives the robot in place of the agents (the baselines of the experiments: RMPflow, RRT): an
/// acceleration policy made once per robot variant, run through control::ReactiveController with its own options, the
/// same way as `rmpmarl demo`. Episodes, metrics and rewards are the task's own, so baselines and agents are measured
/// on identical episodes.
struct ExternalController {
  std::function<std::unique_ptr<control::AccelerationPolicy>(const kinematics::Robot& variant_robot)> make_policy;
  control::ControllerOptions options;  ///< control_rate is replaced by the task's
  /// what the controller is told of the obstacles: empty, the scenario's exact shapes; else a sensor made per robot
  /// variant (e.g. perception::DepthPerception), which replaces them before every control step. The agents'
  /// observations and the metrics keep the truth.
  std::function<std::unique_ptr<sim::ObstacleSensor>(const sim::WorldModel& variant_world)> make_sensor{};
};

/// The manipulator environment. See docs/environments.md for the observation, action and reward definitions.
class ManipulatorEnv final : public Env {
 public:
  explicit ManipulatorEnv(std::shared_ptr<const TaskContext> context);
  /// an env whose robot is driven by `external` (Step ignores the actions; observations are still written).
  ManipulatorEnv(std::shared_ptr<const TaskContext> context, ExternalController external);
  ~ManipulatorEnv() override;

  const EnvSpec& spec() const override { return context_->spec(); }
  void Reset(std::mt19937_64& rng, const StepOutput& out) override;
  /// \pre Reset. Actions: num_agents × action size floats; see Step(std::span) for the checked form.
  void Step(const float* actions, std::mt19937_64& rng, const StepOutput& out) override;
  /// the same with a size check: a wrong count ends the episode flagged invalid.
  void Step(std::span<const float> actions, std::mt19937_64& rng, const StepOutput& out);

  const TaskContext& context() const { return *context_; }
  const sim::World& world() const { return *world_; }
  const sim::Scenario& scenario() const { return *scenario_; }
  /// the external controller's sensor in the current episode, null without one.
  const sim::ObstacleSensor* sensor() const { return sensor_; }
  /// the variant of the current episode.
  int variant() const { return variant_; }
  /// the scenario setting of the current episode (line-crossing: index into the speeds).
  int scenario_setting() const { return setting_; }
  const control::OptionMachine& option_machine(int agent) const { return agents_->option_machine(agent); }
  /// the per-joint agents' state (sensing, observations, options).
  const control::JointAgents& agents() const { return *agents_; }
  /// the external controller's policy of the current episode (nullptr when the agents act).
  const control::AccelerationPolicy* external_policy() const {
    return external_controller_ != nullptr ? &external_controller_->policy() : nullptr;
  }
  const StepInfo& last_step() const { return info_; }
  /// the running counters of the episode (collisions, minimum clearance, return); the summaries (tracking errors,
  /// control time, success) are filled when the episode ends — MetricsSoFar has them at any step.
  const EpisodeMetrics& metrics() const { return metrics_; }
  /// the episode's metrics as if it ended now (a run stopped before the episode's end, e.g. `demo --duration`).
  EpisodeMetrics MetricsSoFar() const;
  /// steps taken in the current episode.
  int steps() const { return steps_; }

 private:
  void StartEpisode(std::mt19937_64& rng);
  bool ValidActions(const float* actions) const;
  void ApplyActions(const float* actions, float* option_started, float* parameters_read);
  bool AdvancePhysics();  // false when MuJoCo diverged
  void CountCollisions(const sim::ContactReport& report);
  void UpdateKinematics();
  void WriteObservation(const StepOutput& out) const;
  void WriteGlobal(float* s) const;
  void Finish(const StepOutput& out, bool terminated, bool truncated, bool invalid);
  void SanitiseOutputs(const StepOutput& out);

  std::shared_ptr<const TaskContext> context_;
  const TaskConfig& config_;
  int nq_;
  int num_agents_;
  // simulation
  std::unique_ptr<sim::World> world_;
  int variant_ = -1;
  int setting_ = 0;
  std::vector<std::unique_ptr<sim::Scenario>> scenarios_;  // [variant * settings + setting], made lazily
  sim::Scenario* scenario_ = nullptr;
  const kinematics::Robot* robot_ = nullptr;               // the current variant's robot
  std::unique_ptr<control::JointAgents> agents_;                    // sensing, observations, options, the basic layer's weights
  std::unique_ptr<control::ReactiveController> controller_;    // per-joint-rmp: drives the agents' basic layer
  ExternalController external_;                            // baselines (make_policy empty: the agents act)
  std::vector<std::unique_ptr<control::ReactiveController>> external_controllers_;  // per variant, made lazily
  std::vector<std::unique_ptr<sim::ObstacleSensor>> sensors_;  // per variant with ExternalController::make_sensor
  sim::ObstacleSensor* sensor_ = nullptr;                        // the current variant's, or null
  rmp::Scene sensed_scene_;                                      // what the external controller is told
  control::ReactiveController* external_controller_ = nullptr; // the current variant's
  int physics_steps_ = 1;
  double control_period_ = 0.0;
  rmp::Scene scene_;
  const sim::ContactReport* report_ = nullptr;
  // commanded state (direct modes) and the step's command change
  Eigen::VectorXd q_cmd_, q_cmd_before_, v_max_, dq_max_;
  // the target of the current state, the end effector's error and Jacobian at the start of the step
  Eigen::Vector3d p_WT_ = Eigen::Vector3d::Zero(), v_WT_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3Xd J_WE_before_;
  Eigen::Vector3d e_before_ = Eigen::Vector3d::Zero();  // p_T − p_E at the start of the step
  Eigen::VectorXd joint_weights_;  // δ_i
  ReachCycleTracker cycles_;
  std::vector<long> pair_last_seen_;  // per (link, partner) pair: physics step index it was last in penetration
  long physics_step_ = 0;
  int step_collisions_ = 0;
  double step_min_clearance_ = 0.0;
  // episode
  bool active_ = false;
  int steps_ = 0;
  double tracking_sum_mm_ = 0.0;
  double settled_sum_mm_ = 0.0;
  int settled_steps_ = 0;
  long collision_physics_steps_ = 0;
  double control_us_sum_ = 0.0;
  EpisodeMetrics metrics_;
  StepInfo info_;
};

/// an EnvFactory making ManipulatorEnvs that share `context` (the lambda holds the shared_ptr).
EnvFactory MakeManipulatorEnvFactory(std::shared_ptr<const TaskContext> context);

}  // namespace rmpmarl::tasks
