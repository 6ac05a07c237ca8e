#pragma once
/// The one episode loop (docs/control.md). `EpisodeLoop` runs an episode stage by stage — the controller's scene
/// (sensed or exact), a control period of physics with the scenario moving, contacts and collision events, the end
/// effector's error — and keeps the one `EpisodeMetrics` of the project. Everything that runs an episode drives it:
/// `RunEpisode` below (a controller alone), `tasks::TaskEpisode` (the tasks' episodes, under the RL environments, the
/// experiments, `demo` and `eval`) and the live viewer.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/control/warning.h"
#include "rmpmarl/kinematics/model.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/sim/controlled_world.h"
#include "rmpmarl/sim/episode_metrics.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::sim {

/// What a sensor made of the obstacles over an episode (ObstacleSensor::Summary).
struct SensorSummary {
  long updates = 0;                  ///< sensor frames processed
  double update_mean_us = 0.0;       ///< wall time per frame: rendering, back-projection and the cloud pipeline [µs]
  double points_mean = 0.0;          ///< kept points per frame (after filtering and downsampling)
  double obstacles_mean = 0.0;       ///< obstacles per frame
  /// points remembered from earlier frames that the cameras could not see (hidden, no depth, outside), per frame
  /// (perception::OcclusionMemory)
  double hidden_mean = 0.0;
  long velocity_samples = 0;         ///< sensed obstacles matched to a true one (centre within 0.15 m)
  double velocity_error_mean = 0.0;  ///< mean |v_sensed − v_true| over the matched ones [m/s]
  double velocity_error_p90 = 0.0;   ///< its 90th percentile [m/s]
  long velocity_samples_tracked = 0;          ///< of which obstacles followed for 2 updates or more
  double velocity_error_tracked_mean = 0.0;   ///< mean |v_sensed − v_true| over those [m/s]
};

/// Tells the controller what a sensor perceives of the obstacles instead of their exact shapes. The episode loop
/// calls Reset at the start of an episode and Sense before every control step, with the scene the scenario filled
/// (the truth, which a sensor may read only to score itself).
class ObstacleSensor {
 public:
  virtual ~ObstacleSensor();
  virtual void Reset(const World& world) = 0;
  /// replaces scene->obstacles with the sensed ones at the world's current state. Obstacles of kind kPoints point
  /// into the sensor: valid until its next Sense or Reset.
  virtual void Sense(const World& world, rmp::Scene* scene) = 0;
  /// the points the sensor sees now (3 × N, world frame; for drawing), empty when it has none.
  virtual const Eigen::Matrix3Xd& points() const = 0;
  virtual SensorSummary Summary() const = 0;
};

/// Collision events: a (link, partner) pair entering penetration, i.e. in penetration now and not at the physics
/// step before. Partners are the obstacles, then the links, then the floor; preallocated, so counting allocates
/// nothing.
class CollisionCounter {
 public:
  CollisionCounter() = default;
  CollisionCounter(int num_links, int num_obstacles);
  /// forgets every pair; the next Count is at physics step 0.
  void Reset();
  struct Events {
    int obstacle = 0;  ///< robot–obstacle or robot–floor pairs entering penetration
    int self = 0;      ///< link–link pairs entering penetration
    int total() const { return obstacle + self; }
  };
  /// the pairs of `report` (the state after physics step `physics_step`) that enter penetration.
  Events Count(const ContactReport& report, long physics_step);

 private:
  int num_obstacles_ = 0;
  int partners_ = 1;
  std::vector<long> last_seen_;  // per (link, partner): physics step it was last in penetration
};

/// One episode, stage by stage. Begin binds a world and what moves its scene (a Scenario already reset to the
/// episode's start, or another SceneSource); each control step is then SenseScene (or StepController) followed by
/// Advance — or, to run several worlds in lockstep on one scene (the viewer's side by side), PhysicsStep per physics
/// step and EndPeriod. Allocates nothing after Begin.
class EpisodeLoop {
 public:
  EpisodeLoop() = default;
  /// starts an episode: contacts at the start (a pair in penetration is a collision event at t = 0), the scene, the
  /// sensor's reset, the end effector's error, cleared metrics. `physics_steps` per control period ≥ 1; the sensor
  /// (not owned) may be null: the controller is told the scene's exact obstacles.
  void Begin(World* world, Scenario* scenario, int physics_steps, const LoopOptions& options,
             ObstacleSensor* sensor = nullptr);
  /// the same with a scene source that is not a Scenario (scenario() is then unavailable, frames carry none).
  void Begin(World* world, SceneSource* source, int physics_steps, const LoopOptions& options,
             ObstacleSensor* sensor = nullptr);

  /// fills the scene anew from the source (after the source changed outside Advance, e.g. a user's edit).
  void RefreshScene();
  /// the scene a controller is told at this control step: the source's, or what the sensor perceives of it.
  const rmp::Scene& SenseScene();
  /// one control step of `controller` on SenseScene(); its compute time counts in the metrics.
  control::ControlStepResult StepController(control::ReactiveController& controller);
  /// a control step computed elsewhere (the agents' direct commands): its compute time [µs].
  void AddControlTime(double us);

  /// one control period: PhysicsStep until the period is over (or the simulation diverged), then EndPeriod.
  bool Advance();
  /// one physics step of the period: the source moves the scene (every step, or by the period at its first step),
  /// the world steps, contacts and collision events are counted. False when the simulation diverged.
  bool PhysicsStep();
  /// ends the control period: the scene and the end effector's error are brought up to date and scored. False when
  /// the simulation diverged in the period (the episode is then invalid and this step is not scored).
  bool EndPeriod();
  /// adds a reward to EpisodeMetrics::episode_return.
  void AddReward(double r) { metrics_.episode_return += r; }
  /// marks the episode invalid (a non-finite action or output).
  void MarkInvalid() { metrics_.invalid = true; }

  /// the metrics as if the episode ended now.
  EpisodeMetrics Metrics() const;

  const World& world() const { return *world_; }
  World& world() { return *world_; }
  /// \pre the episode's source is a Scenario.
  const Scenario& scenario() const;
  const Scenario* scenario_or_null() const { return scenario_; }
  /// the source's scene at the current state (the truth).
  const rmp::Scene& scene() const { return scene_; }
  /// the robot's warning contacts with the scene (the truth) at the current state, sensed once per control step.
  std::span<const control::WarningContact> warnings() const { return warnings_->contacts(); }
  /// the arm's kinematics (link poses and velocities) at the current state, computed once per control step.
  const kinematics::Data& kinematics() const { return *kin_; }
  const ContactReport& contacts() const { return *contacts_; }
  const ObstacleSensor* sensor() const { return sensor_; }
  /// ‖p_WE − p_WT‖ now [m].
  double tracking_error() const { return error_; }
  /// control steps run.
  int steps() const { return steps_; }
  double time() const;
  /// collision events in the last control period.
  int step_collisions() const { return step_events_.total(); }

 private:
  void Observe(const ContactReport& report);
  // the kinematics, the end effector's error and the warning contacts of the current state
  void SenseState();

  World* world_ = nullptr;
  SceneSource* source_ = nullptr;
  Scenario* scenario_ = nullptr;  // source_ when it is a Scenario
  ObstacleSensor* sensor_ = nullptr;
  LoopOptions options_;
  int physics_steps_ = 1;
  double timestep_ = 0.0;
  const ContactReport* contacts_ = nullptr;
  rmp::Scene scene_, sensed_;
  CollisionCounter counter_;
  std::optional<kinematics::Data> kin_;
  const kinematics::Model* kin_model_ = nullptr;
  std::optional<control::WarningSensor> warnings_;
  long physics_step_ = 0;
  int steps_ = 0;
  double error_ = 0.0;
  double tracking_sum_ = 0.0, settled_sum_ = 0.0;
  int settled_steps_ = 0;
  long collision_physics_steps_ = 0;
  double control_us_sum_ = 0.0;
  CollisionCounter::Events observed_;  // of the last report observed
  // the control period in progress: physics steps taken, events so far, divergence
  int period_step_ = 0;
  CollisionCounter::Events period_events_;
  bool period_ok_ = true;
  CollisionCounter::Events step_events_;
  EpisodeMetrics metrics_;
};

/// Options of RunEpisode.
struct EpisodeOptions {
  double duration = 10.0;         ///< simulated time [s], > 0
  std::uint64_t seed = 0;         ///< scenario draw (Scenario::Reset)
  double video_fps = 0.0;         ///< frame-callback rate [Hz]; 0: no frames
  LoopOptions loop{};             ///< scoring and scenario motion
  bool stop_on_collision = false; ///< end the episode at the first collision event
  /// not owned; null: the controller is told the scenario's exact obstacles
  ObstacleSensor* sensor = nullptr;
};

/// What a frame callback sees: the state after a control period, before the next control step.
struct FrameInfo {
  int index = 0;                       ///< frame number, from 0
  double time = 0.0;                   ///< simulation time [s]
  const World* world = nullptr;        ///< render this (its mjData is consistent: kinematics and contacts current)
  const Scenario* scenario = nullptr;     ///< null when the loop's scene source is not a Scenario
  const ContactReport* contacts = nullptr;
  double tracking_error = 0.0;         ///< ‖p_WE − p_WT‖ [m]
  const ObstacleSensor* sensor = nullptr;
  std::span<const control::WarningContact> warnings{};  ///< the robot's warning contacts (EpisodeLoop::warnings)
  const kinematics::Data* kinematics = nullptr;  ///< the arm's link poses at this state (EpisodeLoop::kinematics)
  const rmp::Scene* scene = nullptr;             ///< the source's scene at this state, the truth (EpisodeLoop::scene)
};

/// Called at EpisodeOptions::video_fps (first frame at t = 0), at control-period boundaries.
using FrameCallback = std::function<void(const FrameInfo& frame)>;

/// calls `on_frame` when a frame is due at the loop's current time; `next_frame` counts the frames made.
void MaybeFrame(const EpisodeLoop& loop, double fps, int* next_frame, const FrameCallback& on_frame);

/// runs one episode of a controller alone: scenario.Reset(seed, world), sim::ResetController, then EpisodeLoop's
/// stages for the duration. Throws InputError for bad options or mismatched parts (controller and world of
/// different robots).
EpisodeMetrics RunEpisode(const EpisodeOptions& options, World& world, control::ReactiveController& controller,
                          Scenario& scenario, const FrameCallback& on_frame = {});

}  // namespace rmpmarl::sim
