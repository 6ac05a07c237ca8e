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
#include <memory>
#include <random>
#include <span>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/control/joint_agents.h"
#include "rmpmarl/tasks/env.h"
#include "rmpmarl/tasks/reward.h"
#include "rmpmarl/tasks/task_context.h"
#include "rmpmarl/tasks/task_episode.h"

namespace rmpmarl::tasks {

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

/// The manipulator environment: the agents' actions, observations and rewards on a task's episodes (TaskEpisode on
/// the one episode loop). See docs/environments.md for the observation, action and reward definitions. Controllers
/// that are not the agents (RMPflow, RRT, the learned agents in a user's loop) run the same episodes through
/// ControllerEpisodes.
class ManipulatorEnv final : public Env {
 public:
  explicit ManipulatorEnv(std::shared_ptr<const TaskContext> context);
  ~ManipulatorEnv() override;

  const EnvSpec& spec() const override { return context_->spec(); }
  void Reset(std::mt19937_64& rng, const StepOutput& out) override;
  /// \pre Reset. Actions: num_agents × action size floats; see Step(std::span) for the checked form.
  void Step(const float* actions, std::mt19937_64& rng, const StepOutput& out) override;
  /// the same with a size check: a wrong count ends the episode flagged invalid.
  void Step(std::span<const float> actions, std::mt19937_64& rng, const StepOutput& out);

  const TaskContext& context() const { return *context_; }
  const sim::World& world() const { return episode_.world(); }
  const sim::Scenario& scenario() const { return episode_.scenario(); }
  /// the variant of the current episode.
  int variant() const { return episode_.variant(); }
  /// the scenario setting of the current episode (line-crossing: index into the speeds).
  int scenario_setting() const { return episode_.setting(); }
  const control::OptionMachine& option_machine(int agent) const { return episode_.agents().option_machine(agent); }
  /// the per-joint agents' state (sensing, observations, options).
  const control::JointAgents& agents() const { return episode_.agents(); }
  /// the task episode under the env (its loop, world and scenario).
  const TaskEpisode& episode() const { return episode_; }
  const StepInfo& last_step() const { return info_; }
  /// the episode's metrics as if it ended now (a run stopped before the episode's end, e.g. `demo --duration`).
  EpisodeMetrics metrics() const { return episode_.Metrics(); }
  /// steps taken in the current episode.
  int steps() const { return episode_.steps(); }

 private:
  bool ValidActions(const float* actions) const;
  void ApplyActions(const float* actions, float* option_started, float* parameters_read);
  void WriteObservation(const StepOutput& out) const;
  void WriteGlobal(float* s) const;
  void Finish(const StepOutput& out, bool terminated, bool truncated, bool invalid);
  void SanitiseOutputs(const StepOutput& out);

  std::shared_ptr<const TaskContext> context_;
  const TaskConfig& config_;
  int nq_;
  int num_agents_;
  TaskEpisode episode_;
  std::unique_ptr<control::ReactiveController> controller_;  // per-joint-rmp: drives the agents' basic layer
  double control_period_ = 0.0;
  // commanded state (direct modes) and the step's command change
  Eigen::VectorXd q_cmd_, q_cmd_before_, v_max_, dq_max_;
  bool active_ = false;
  StepInfo info_;
};

/// an EnvFactory making ManipulatorEnvs that share `context` (the lambda holds the shared_ptr).
EnvFactory MakeManipulatorEnvFactory(std::shared_ptr<const TaskContext> context);

}  // namespace rmpmarl::tasks
