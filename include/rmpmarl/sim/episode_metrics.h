#pragma once
/// The one metrics struct of an episode and the loop's scoring options (sim/episode.h runs the loop). No simulator
/// header: environments and reports include this alone.
#include <limits>

namespace rmpmarl::sim {

/// When the scenario moves obstacles and target inside one control period.
enum class ScenarioUpdate {
  kPhysicsStep,  ///< before every physics timestep (smooth motion)
  kControlStep,  ///< once per control period, by the period (cheaper; obstacles jump v·T)
};

/// What happened in one episode. SI units (metres, seconds); millimetres only where printed.
struct EpisodeMetrics {
  /// not invalid, no collision event and final_tracking_error ≤ the loop's success_max_final_error
  bool success = false;
  bool invalid = false;   ///< ended on a non-finite state, action or simulation (MuJoCo diverged)
  bool reached = false;   ///< final_tracking_error ≤ the loop's reach_tolerance
  double time_to_reach = -1.0;  ///< first control step's time with the error below reach_tolerance [s]; −1: never

  int collisions = 0;            ///< collision events: a (link, obstacle | link | floor) pair entering penetration
  int obstacle_collisions = 0;   ///< of which robot–obstacle or robot–floor
  int self_collisions = 0;       ///< of which link–link
  double time_in_collision = 0.0;  ///< simulated time with at least one pair in penetration [s]
  /// smallest signed robot–obstacle (or floor) distance sensed at a control step [m]; +inf: nothing came within the
  /// warning margin
  double min_clearance = std::numeric_limits<double>::infinity();
  /// smallest signed distance between checked link pairs at a control step [m]; +inf: none came within the margin
  double min_self_clearance = std::numeric_limits<double>::infinity();

  // ‖p_WE − p_WT‖ after every control step
  double mean_tracking_error = 0.0;   ///< over the episode [m]
  double max_tracking_error = 0.0;    ///< [m]
  double final_tracking_error = 0.0;  ///< at the last step [m]
  /// mean over the steps at t ≥ the loop's settle_time (NaN: the episode ended before) [m]: the tracking precision
  /// once the start transient is over
  double settled_tracking_error = std::numeric_limits<double>::quiet_NaN();

  int length = 0;           ///< control steps
  long physics_steps = 0;
  double duration = 0.0;    ///< simulated time run [s]
  double episode_return = 0.0;  ///< undiscounted sum of the task's rewards (0 outside a task)
  /// mean wall time of the controller per control step (policy or basic layer + integration; 0 when the agents
  /// command joints directly) [µs]
  double mean_control_us = 0.0;
  double max_control_us = 0.0;
  long nonfinite_policy_outputs = 0;  ///< control steps whose q̈ was non-finite (position held)
};

/// The loop's choices of scoring and scenario motion.
struct LoopOptions {
  double reach_tolerance = 0.02;  ///< EpisodeMetrics::reached and time_to_reach [m], > 0
  /// success needs the final error below this [m] (+inf: success = no collision and not invalid)
  double success_max_final_error = std::numeric_limits<double>::infinity();
  double settle_time = 1.0;       ///< start of the settled phase [s], ≥ 0
  /// the robot's warning contacts (control::WarningSensor: capsules against the scene's obstacles and each other)
  /// are sensed within this distance once per control step [m], > 0; the clearances are read from them
  double warning_margin = 0.15;
  /// a floor plane z = floor_height in the warning contacts [m]; NaN: none
  double floor_height = std::numeric_limits<double>::quiet_NaN();
  ScenarioUpdate scenario_update = ScenarioUpdate::kPhysicsStep;
};

}  // namespace rmpmarl::sim
