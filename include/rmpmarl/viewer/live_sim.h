#pragma once
/// What the viewer shows (docs/viewer.md): a source of frames that the page can steer. `LiveSim` is a MuJoCo scene
/// of one or two arms (the learned controller and/or RMPflow, each a control::ReactiveController in its own World) fed
/// the same target and obstacles: a scenario moves them until the page takes one over (drags it, adds or removes
/// obstacles). `ReplaySource` (recording.h) plays back a recorded episode. Both are driven by viewer::Realtime (realtime.h) on one
/// thread; nothing here is thread-safe.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/viewer/protocol.h"

namespace rmpmarl::control {
class LearnedController;
}

namespace rmpmarl::viewer {

/// What a frame reports about the loop that produced it.
struct FrameStats {
  long seq = 0;
  bool paused = false;
  double speed = 1.0;
  double rtf = 1.0;   ///< simulated over wall time over the last second, divided by the speed
  double load = 0.0;  ///< share of wall time spent computing
  long refused = 0;
};

/// A steerable source of frames.
class FrameSource {
 public:
  virtual ~FrameSource();
  /// the ranges commands are checked against.
  virtual const CommandLimits& limits() const = 0;
  /// applies a checked command other than pause, resume, step and speed (the loop's own); returns "" or why it was
  /// refused (the command's name first).
  virtual std::string Apply(const Command& command) = 0;
  /// advances to simulated time `t` [s] (whole control steps, or the last recorded frame at or before t).
  virtual void AdvanceTo(double t) = 0;
  /// one control step, or one frame of a replay.
  virtual void StepOnce() = 0;
  /// simulated time [s].
  virtual double time() const = 0;
  /// the smallest t for which AdvanceTo(t) moves on (+inf: it cannot, e.g. a replay at its last frame).
  virtual double next_time() const = 0;
  /// the hello message of the current set-up, and a number that changes when it does.
  virtual const std::string& hello() const = 0;
  virtual long hello_version() const = 0;
  /// the frame message of the current state.
  virtual void Frame(const FrameStats& stats, std::string* out) = 0;
};

/// Options of a LiveSim.
struct LiveSimOptions {
  std::string scenario = std::string(sim::kDefaultScenario);
  sim::ScenarioOverrides overrides{};
  /// a fixed scene instead of the scenario (rmpmarl view --scene: a MoveIt planning scene and request)
  std::optional<sim::StaticSceneOptions> scene{};
  /// every arm's controller follows RRT-Connect plans (planning::PlanFollowPolicy) instead of the target directly
  bool plan = false;
  /// ... with plans made beside the simulation loop (PlanFollowOptions::plan_beside_loop): a long plan does not hold
  /// the live view; the arms go for the goal alone until their plan is ready (not reproducible step for step)
  bool plan_beside_loop = false;
  std::uint64_t seed = 0;
  /// the first arm's controller: "learned" (needs a controller file) or "rmpflow"
  std::string controller = "learned";
  /// a second arm: the learned controller on the first, RMPflow on the second
  bool side_by_side = false;
  /// obstacles the page may add besides the scenario's: cubes of side 0.1 m and spheres of radius 0.05 m
  int extra_boxes = 8;
  int extra_spheres = 8;
  /// the most obstacles in the scene at once
  int max_obstacles = 16;
  /// commanded positions must lie within ±arena of the base [m]
  double arena = 5.0;
  /// the robot's visual elements for the page (LoadRobotVisuals); empty: capsules only
  std::vector<VisualShape> visuals{};
};

/// The live scene.
class LiveSim final : public FrameSource {
 public:
  /// `policy` (may be null: RMPflow only) is the learned controller's file, `policy_path` names it. Throws
  /// InputError for an unknown scenario, a controller file that does not fit the robot, or a learned controller
  /// asked for without a file.
  LiveSim(kinematics::Robot robot, std::shared_ptr<const control::PolicyFile> policy, std::string policy_path,
          LiveSimOptions options = {});
  ~LiveSim() override;

  const CommandLimits& limits() const override { return limits_; }
  std::string Apply(const Command& command) override;
  void AdvanceTo(double t) override;
  void StepOnce() override { ControlStep(); }
  double time() const override { return time_; }
  double next_time() const override { return time_ + 0.5 * period_; }
  const std::string& hello() const override { return hello_; }
  long hello_version() const override { return hello_version_; }
  void Frame(const FrameStats& stats, std::string* out) override;

  /// a new episode of the scenario with `seed`: arms at its start posture, the scenario's target and obstacles.
  void Reset(std::uint64_t seed);
  /// one control step of every arm, each an episode loop (sim::EpisodeLoop) stepped in lockstep with the others:
  /// controllers, then the physics steps, with the scenario moving what the page does not hold.
  void ControlStep();

  int num_arms() const { return static_cast<int>(arms_.size()); }
  const sim::World& world(int arm) const;
  const std::string& controller(int arm) const;
  /// end-effector position of an arm, the target.
  Eigen::Vector3d end_effector(int arm) const;
  const Eigen::Vector3d& target() const { return p_WT_; }
  /// ids of the obstacles in the scene.
  std::vector<int> obstacle_ids() const;
  /// an obstacle's centre [m] (its id must be in the scene).
  Eigen::Vector3d obstacle_position(int id) const;
  /// an arm's collision events since the scene (re)started (a link–obstacle pair entering penetration: the episode
  /// loop's counter).
  long collisions(int arm) const;
  double control_period() const { return period_; }
  const sim::Scenario& scenario() const { return *scenario_; }

 private:
  struct Slot;
  struct Arm;
  class ArmSource;
  void BuildArms();
  std::unique_ptr<Arm> MakeArm(const std::string& controller, const Eigen::VectorXd& q,
                               const Eigen::VectorXd& qd) const;
  // every slot's pose and the target into every arm's world (PlaceInto each), after the page changed them
  void PlaceObstacles();
  // the scene every arm's controller is told, from the slots and the target
  void FillScene(rmp::Scene* scene) const;
  // one physics step of the shared scene: the scenario moves what the page does not hold
  void AdvanceShared(double dt);
  // every slot's pose and the target into `world`
  void PlaceInto(sim::World& world) const;
  void FillObstacleViews();
  void UpdateHello();
  std::string ActiveIds() const;

  kinematics::Robot robot_;
  std::shared_ptr<const control::PolicyFile> policy_;
  std::string policy_path_, policy_label_;
  LiveSimOptions options_;
  CommandLimits limits_;
  std::unique_ptr<sim::Scenario> scenario_;
  std::shared_ptr<const sim::WorldModel> model_;         // the arms' worlds: scenario obstacles + room for more
  std::shared_ptr<const sim::WorldModel> shadow_model_;  // the scenario's own world (it moves its obstacles there)
  std::unique_ptr<sim::World> shadow_;
  sim::ContactReport no_contacts_;
  std::vector<Slot> slots_;
  std::vector<std::unique_ptr<Arm>> arms_;
  std::string controller_;  // the first arm's
  bool side_by_side_ = false;
  double period_ = 0.01, dt_ = 0.002;
  int physics_steps_ = 5;
  double time_ = 0.0;
  std::uint64_t seed_ = 0;
  bool target_held_ = false;
  Eigen::Vector3d p_WT_ = Eigen::Vector3d::Zero(), v_WT_ = Eigen::Vector3d::Zero();
  sim::TargetState live_target_;  // p_WT_ and the velocity the controllers are told
  std::vector<ObstacleView> obstacle_views_;
  std::string hello_;
  long hello_version_ = 0;
};

}  // namespace rmpmarl::viewer
