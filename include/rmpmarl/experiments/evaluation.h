#pragma once
/// One evaluation path for every method of the paper's comparisons (docs/experiments.md): a learned policy (an
/// exported .rmpp actor of any interface mode, run by the Eigen runtime), a fixed-option ablation of the basic layer,
/// the RMPflow baseline and the RRT baseline all act in the SAME task episodes: episode i of evaluation seed S is
/// ManipulatorEnv::Reset with std::mt19937_64(EpisodeSeed(S, i)), whatever the method, so robot variant, start
/// state, target path and obstacle paths are identical (tests/experiments/evaluation_test.cc proves it).
///
///   const auto records = experiments::EvaluateMethod(experiments::Method::Rmpflow(), task, {.episodes = 50});
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rmpmarl/planning/rrt.h"
#include "rmpmarl/sim/episode.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/tasks/env.h"
#include "rmpmarl/tasks/task_config.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::experiments {

/// What acts in the episodes.
enum class MethodKind {
  kPolicy,       ///< an exported actor (.rmpp) on its interface mode (per-joint-rmp, direct, per-joint-direct)
  kFixedOption,  ///< the basic layer alone: every joint runs one RMP option with unit scales and never terminates it
  kRmpflow,      ///< the full RMPflow baseline (configs/rmpflow), through the demo's controller and servos
  kRrt,          ///< the RRT-Connect replanning baseline (planning::RrtPolicy)
};

/// One method of a comparison.
struct Method {
  std::string name;                                         ///< row label, e.g. "MARL-RMP"
  MethodKind kind = MethodKind::kRmpflow;
  std::string policy_path;                                  ///< kPolicy: the .rmpp file
  tasks::InterfaceMode interface = tasks::InterfaceMode::kPerJointRmp;  ///< kPolicy: the mode it was trained on
  int fixed_option = 0;  ///< kFixedOption: 0 target, 1 collision, 2 target-then-collision (control::RmpOption order)
  /// kFixedOption: the raw continuous parameters u of every joint (control::RmpActionLayout order: target accel, target
  /// metric, collision accel, collision metric); 0 = unit scales
  std::array<float, control::RmpActionLayout::kNumContinuous> fixed_parameters{};
  /// kFixedOption, a hand rule on the look-ahead block of the local observation (needs observation.lookahead > 0):
  /// joint i acts with `parameters` while a moving obstacle is predicted to pass within `clearance` [m] of a capsule
  /// joint i moves, and with fixed_parameters otherwise. The rule compares the clipped feature (clearance / ℓ in
  /// [−1, 2]), so a clearance ≥ 2ℓ always fires; an obstacle moving away counts with its current clearance.
  struct ThreatGate {
    double clearance = 0.0;
    std::array<float, control::RmpActionLayout::kNumContinuous> parameters{};
  };
  std::optional<ThreatGate> threat_gate;
  /// kRmpflow: changes to the robot's RMPflow config (configs/rmpflow) for this method (e.g. tuned gains); empty: none
  std::function<void(rmp::RmpflowOptions&)> adjust_rmpflow;
  planning::RrtOptions rrt;                                 ///< kRrt
  /// changes to the task this method is evaluated on (e.g. the basic-layer settings it was trained with); empty: none
  std::function<void(tasks::TaskConfig&)> adjust_task;

  static Method Policy(std::string name, std::string path, tasks::InterfaceMode interface);
  static Method FixedOption(std::string name, int option);
  static Method Rmpflow(std::string name = "RMPflow");
  static Method Rrt(std::string name = "RRT", planning::RrtOptions options = {});
};

/// How many episodes, which ones, and on how many threads.
struct EvalProtocol {
  int episodes = 50;
  /// evaluation seed S: episodes are EpisodeSeed(S, 0 … episodes − 1). Tune on another seed than the one reported.
  std::uint64_t eval_seed = 20231001;
  int jobs = 2;  ///< worker threads (one env and one runtime each); results do not depend on it
  /// what the controllers know of the obstacles: empty, the exact shapes; else a sensor per env and robot variant
  /// (perception::DepthPerception). RMPflow and RRT are told what it senses; learned methods then run as
  /// control::LearnedController (warnings from the sensed obstacles, not from MuJoCo's contacts); fixed-option methods,
  /// which read MuJoCo's contacts, are refused.
  std::function<std::unique_ptr<sim::ObstacleSensor>(const sim::WorldModel&)> make_sensor{};
  int sensor_obstacle_slots = 8;  ///< with make_sensor: the controllers' obstacle slots (the sensor's clusters)
  /// learned methods run as control::LearnedController (as with a sensor) also on the exact shapes: the baseline that
  /// separates what perception costs from what the controller's own warnings change
  bool learned_as_controller = false;
};

/// One evaluated episode.
struct EpisodeRecord {
  int index = 0;                   ///< episode index i
  std::uint64_t episode_seed = 0;  ///< EpisodeSeed(S, i)
  tasks::EpisodeMetrics metrics;      ///< the env's metrics (success, collisions, tracking, settled, clearance, …)
  int variant = 0;                 ///< the robot variant of the episode
  int setting = 0;                 ///< the scenario setting (line-crossing: index into the speeds)
  /// wall time per control step of the whole method: the policy's forward pass (learned methods) plus the env's
  /// controller (basic layer / RMPflow / RRT) [µs]
  double control_step_us = 0.0;
  /// planners (RRT): replans in the episode, how many found a path, and their wall times [ms] (0 otherwise)
  int plans = 0, plans_succeeded = 0;
  double planning_ms_mean = 0.0, planning_ms_max = 0.0;
  /// with EvalProtocol::make_sensor: what the sensor perceived in the episode (zeros without one)
  sim::SensorSummary sensor;
};

/// seed of episode i of evaluation seed S: splitmix64 of (S, i), forced ≥ 2^32 so that it never equals a training
/// env seed (the trainer seeds env k of segment s with seed + s·num_envs + k < 2^32).
std::uint64_t EpisodeSeed(std::uint64_t eval_seed, int index);

/// runs protocol.episodes episodes of `task` (its interface replaced by the method's) with `method`; the records
/// are in episode order. Throws InputError when a policy does not fit the task.
std::vector<EpisodeRecord> EvaluateMethod(const Method& method, const tasks::TaskConfig& task,
                                          const EvalProtocol& protocol);

/// A method's episodes split by what a reference method did on the same episodes (matched by index): "free" are the
/// episodes the reference finished without a collision, "blocked" the others. On pretrain-2link with the target
/// option as the reference, blocked episodes are those where tracking the target drives a link into the cube.
struct EpisodeSplit {
  int free_count = 0, blocked_count = 0;
  double free_success = 0.0, blocked_success = 0.0;          ///< success rates (NaN when no episode)
  double free_settled_mm = 0.0, blocked_settled_mm = 0.0;    ///< mean settled tracking error (finite values only)
};
/// throws InputError when an episode's index is not among the reference's, or the reference has an index twice.
EpisodeSplit SplitByReference(const std::vector<EpisodeRecord>& episodes, const std::vector<EpisodeRecord>& reference);

}  // namespace rmpmarl::experiments
