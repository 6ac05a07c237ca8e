#pragma once
/// The episode runner (docs/control.md): World + ReactiveController + Scenario for a duration, with the metrics of
/// the paper's experiments — end-effector tracking error, clearances, collision events, success — and the cost of a
/// control step. Optionally calls a frame callback at a video frame rate (the CLI renders there).
#include <cstdint>
#include <functional>
#include <limits>
#include <string>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/sim/controlled_world.h"
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

/// Tells the controller what a sensor perceives of the obstacles instead of their exact shapes. RunEpisode and the
/// environments' external controllers call Reset at the start of an episode and Sense before every control step,
/// with the scene the scenario filled (the truth, which a sensor may read only to score itself).
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

/// Options of RunEpisode.
struct EpisodeOptions {
  double duration = 10.0;         ///< simulated time [s], > 0
  std::uint64_t seed = 0;         ///< scenario draw (Scenario::Reset)
  double video_fps = 0.0;         ///< frame-callback rate [Hz]; 0: no frames
  double reach_tolerance = 0.01;  ///< time_to_reach is the first time the tracking error is below this [m]
  double tracking_warmup = 0.0;   ///< tracking mean/std/max ignore the first warmup seconds [s]
  bool stop_on_collision = false; ///< end the episode at the first collision event
  /// not owned; null: the controller is told the scenario's exact obstacles
  ObstacleSensor* sensor = nullptr;
};

/// What a frame callback sees: the state after a physics step, before the scenario moves on.
struct FrameInfo {
  int index = 0;                       ///< frame number, from 0
  double time = 0.0;                   ///< simulation time [s]
  const World* world = nullptr;        ///< render this (its mjData is consistent: kinematics and contacts current)
  const Scenario* scenario = nullptr;
  const ContactReport* contacts = nullptr;
  double tracking_error = 0.0;         ///< ‖p_WE − p_WT‖ [m]
  const ObstacleSensor* sensor = nullptr;  ///< EpisodeOptions::sensor
};

/// Called at EpisodeOptions::video_fps (first frame at t = 0).
using FrameCallback = std::function<void(const FrameInfo& frame)>;

/// Metrics of one episode. Distances in mm, times in s unless the name says otherwise.
struct EpisodeResult {
  std::string scenario;        ///< Scenario::name()
  std::string policy;          ///< AccelerationPolicy::name()
  std::uint64_t seed = 0;
  double duration = 0.0;       ///< simulated time actually run [s] (shorter after divergence/stop_on_collision)
  long physics_steps = 0;
  long control_steps = 0;
  int frames = 0;              ///< frame callbacks made

  // end effector vs target, sampled every physics step (after tracking_warmup)
  double tracking_error_mean_mm = 0.0;
  double tracking_error_std_mm = 0.0;   ///< population standard deviation
  double tracking_error_max_mm = 0.0;
  double final_tracking_error_mm = 0.0; ///< at the end of the episode
  double time_to_reach = -1.0;          ///< first time the error was below reach_tolerance [s]; −1: never

  /// smallest signed robot–obstacle (or floor) distance seen [mm]; +inf when nothing came within the warning margin
  double min_clearance_mm = std::numeric_limits<double>::infinity();
  /// smallest signed distance between checked link pairs [mm]; +inf when none came within the margin
  double min_self_clearance_mm = std::numeric_limits<double>::infinity();

  /// collision events: a (link, obstacle | link | floor) pair entering penetration (distance < 0)
  int collision_events = 0;
  int obstacle_collision_events = 0;  ///< of which robot–obstacle (or floor)
  int self_collision_events = 0;      ///< of which link–link
  int colliding_pairs = 0;            ///< distinct pairs that ever penetrated
  double time_in_collision = 0.0;     ///< simulated time with at least one pair in penetration [s]

  long nonfinite_policy_outputs = 0;  ///< control steps whose q̈ was non-finite (position held)
  long resyncs = 0;                   ///< commanded state restarted from the measured one
  double control_step_mean_us = 0.0;  ///< policy evaluation + integration, steady_clock [µs]
  double control_step_max_us = 0.0;
  double wall_time = 0.0;             ///< wall-clock time of the whole episode [s]

  SensorSummary sensor;  ///< with EpisodeOptions::sensor: what it perceived (zeros without one)

  bool diverged = false;  ///< MuJoCo hit a non-finite state (World::Step not ok); the episode ended there
  bool success = false;   ///< no collision event and no divergence
};

/// runs one episode: scenario.Reset(seed, world), sim::ResetController(controller, world), then per physics step: the controller
/// every physics_steps_per_control() steps, World::Step, contacts and metrics, the frame callback when due, and
/// scenario.Advance. Throws InputError for bad options or mismatched parts (controller and world of different
/// robots).
EpisodeResult RunEpisode(const EpisodeOptions& options, World& world, control::ReactiveController& controller,
                         Scenario& scenario, const FrameCallback& on_frame = {});

}  // namespace rmpmarl::sim
