#pragma once
/// The episodes of a task on the one episode loop (sim::EpisodeLoop). `TaskEpisode` draws an episode from an rng the
/// way every user of the task does (variant, scenario setting, seed, start state), keeps the per-joint agents' view
/// of it (their sensing: observations and the reward read it) and scores every control step with the task's reward,
/// eq (14). Two things drive it: `ManipulatorEnv` (the agents' actions, observations and rewards for learning) and
/// `ControllerEpisodes` (a control::ReactiveController — RMPflow, RRT, the learned agents as a user's loop runs them
/// — on the same episodes: the experiments' baselines, `demo`, `eval --as-controller`).
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <random>
#include <vector>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/control/joint_agents.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/tasks/reward.h"
#include "rmpmarl/tasks/task_context.h"

namespace rmpmarl::tasks {

/// What one control step of a task episode scored.
struct StepScore {
  RewardTerms reward;              ///< the step's terms, eq (14)
  Eigen::VectorXd joint_reach;     ///< R_i per joint (before δ_i)
  double distance_before = 0.0;    ///< ‖p_E − p_T‖ before the step [m]
  double distance_after = 0.0;     ///< after [m]
  int collision_events = 0;        ///< collision events in this step
};

/// the episode loop's options for a task: its settle time, warning distance, scenario update and success
/// tolerance; reached = within that tolerance where the task has one, within LoopOptions' default otherwise.
sim::LoopOptions TaskLoopOptions(const TaskConfig& config);

/// One episode of a task at a time. Per episode: Draw, reset the controllers on world(), Begin; per control step:
/// BeginStep, the control step (on loop()), Advance, Score. Allocates nothing after the first episode of a variant.
class TaskEpisode {
 public:
  explicit TaskEpisode(std::shared_ptr<const TaskContext> context);
  ~TaskEpisode();
  TaskEpisode(const TaskEpisode&) = delete;
  TaskEpisode& operator=(const TaskEpisode&) = delete;

  /// draws the next episode from `rng` (variant, scenario setting, seed, start state) and resets the world and the
  /// scenario to its start. Returns true when the variant changed (a controller made per variant must follow).
  bool Draw(std::mt19937_64& rng);
  /// starts the drawn episode: the loop (contacts at the start, the scene, the sensor's reset; `sensor` not owned,
  /// null: exact obstacles), the agents' sensing and the reward's state.
  void Begin(sim::ObstacleSensor* sensor = nullptr);
  /// before a control step: remembers the end effector's error and Jacobian for the reward.
  void BeginStep();
  /// the control period after the control step: physics (EpisodeLoop::Advance), then the agents' sensing; with
  /// `end_options`, the agents' options end their step. False when the simulation diverged (the episode is invalid).
  bool Advance(bool end_options);
  /// scores the step with the commanded joint displacement `dq_command`: reward, return and metrics.
  const StepScore& Score(const Eigen::Ref<const Eigen::VectorXd>& dq_command);
  /// the episode is over: a collision with terminate_on_collision (terminated) or the horizon (truncated).
  bool Terminated() const;
  bool Truncated() const;
  /// ends the episode as invalid (a non-finite action, observation or reward).
  void MarkInvalid() { loop_.MarkInvalid(); }

  const TaskContext& context() const { return *context_; }
  const TaskConfig& config() const { return context_->config(); }
  sim::EpisodeLoop& loop() { return loop_; }
  const sim::EpisodeLoop& loop() const { return loop_; }
  sim::World& world() { return *world_; }
  const sim::World& world() const { return *world_; }
  const sim::Scenario& scenario() const { return *scenario_; }
  const kinematics::Robot& robot() const { return world_->model().robot(); }
  control::JointAgents& agents() { return *agents_; }
  const control::JointAgents& agents() const { return *agents_; }
  int variant() const { return variant_; }
  int setting() const { return setting_; }
  int steps() const { return loop_.steps(); }
  /// the target at the current state.
  const Eigen::Vector3d& p_WT() const { return p_WT_; }
  const Eigen::Vector3d& v_WT() const { return v_WT_; }
  /// the episode's metrics as if it ended now.
  EpisodeMetrics Metrics() const { return loop_.Metrics(); }
  const StepScore& last_score() const { return score_; }

 private:
  void Sense();

  std::shared_ptr<const TaskContext> context_;
  int nq_ = 0;
  std::unique_ptr<sim::World> world_;
  int variant_ = -1;
  int setting_ = 0;
  std::vector<std::unique_ptr<sim::Scenario>> scenarios_;  // [variant * settings + setting], made lazily
  sim::Scenario* scenario_ = nullptr;
  std::unique_ptr<control::JointAgents> agents_;
  sim::EpisodeLoop loop_;
  sim::LoopOptions loop_options_;
  int physics_steps_ = 1;
  Eigen::VectorXd joint_weights_;  // δ_i
  ReachCycleTracker cycles_;
  Eigen::Vector3d p_WT_ = Eigen::Vector3d::Zero(), v_WT_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d e_before_ = Eigen::Vector3d::Zero();  // p_T − p_E at the start of the step
  Eigen::Matrix3Xd J_WE_before_;
  StepScore score_;
};

/// How a controller is made for each robot variant of a task.
struct ControllerMaker {
  std::function<std::unique_ptr<control::AccelerationPolicy>(const kinematics::Robot& variant_robot)> make_policy;
  control::ControllerOptions options;  ///< control_rate is replaced by the task's
  /// what the controller is told of the obstacles: empty, the scenario's exact shapes; else a sensor made per robot
  /// variant (e.g. perception::DepthPerception). The agents' sensing and the metrics keep the truth.
  std::function<std::unique_ptr<sim::ObstacleSensor>(const sim::WorldModel& variant_world)> make_sensor{};
};

/// the task's learned agents as a user's loop runs them (control::LearnedController with `weights`, on the task's
/// agent config and controller options) for up to `max_obstacles` obstacles, named `name`.
ControllerMaker LearnedControllerMaker(const TaskConfig& config, const control::PolicyWeights& weights,
                                       std::string name, int max_obstacles);

/// Options of ControllerEpisodes::Run.
struct RunOptions {
  double video_fps = 0.0;              ///< frame-callback rate [Hz]; 0: none
  sim::FrameCallback on_frame = {};    ///< after every control period when a frame is due (first at t = 0)
};

/// A controller on a task's episodes: the same episodes as the task's envs (TaskEpisode, drawn from the same rng),
/// driven by a control::ReactiveController made per robot variant instead of the agents' actions. The episode,
/// its metrics and its reward are the task's, so baselines and agents are measured on identical episodes.
class ControllerEpisodes {
 public:
  /// throws InputError without a policy maker or with bad controller options.
  ControllerEpisodes(std::shared_ptr<const TaskContext> context, ControllerMaker maker);
  ~ControllerEpisodes();

  /// runs the episode drawn from `rng` to its end (the task's horizon, or a collision when the task terminates on
  /// one) and returns its metrics.
  EpisodeMetrics Run(std::mt19937_64& rng, const RunOptions& options = {});

  const TaskEpisode& episode() const { return episode_; }
  /// the current variant's controller and sensor (null before the first Run; the sensor null without one).
  const control::ReactiveController* controller() const { return controller_; }
  const sim::ObstacleSensor* sensor() const { return sensor_; }

 private:
  TaskEpisode episode_;
  ControllerMaker maker_;
  std::vector<std::unique_ptr<control::ReactiveController>> controllers_;  // per variant, made lazily
  std::vector<std::unique_ptr<sim::ObstacleSensor>> sensors_;             // per variant with make_sensor
  control::ReactiveController* controller_ = nullptr;
  sim::ObstacleSensor* sensor_ = nullptr;
  Eigen::VectorXd q_cmd_before_, dq_command_;
};

}  // namespace rmpmarl::tasks
