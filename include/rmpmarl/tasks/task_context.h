#pragma once
/// What every episode of one task shares, built once (docs/environments.md): the validated config, the EnvSpec, the
/// pool of link-length variants (one sim::WorldModel each) and the scenario maker.
#include <array>
#include <functional>
#include <memory>
#include <vector>

#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/sim/scenario.h"
#include "rmpmarl/sim/world.h"
#include "rmpmarl/tasks/env.h"
#include "rmpmarl/tasks/task_config.h"

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

}  // namespace rmpmarl::tasks
