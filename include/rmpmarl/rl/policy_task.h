#pragma once
/// The task of a controller file (control/policy_file.h): the whole task config it runs on, moved to another robot,
/// scene or obstacle speed; its readable card; the controller task a training run writes into it.
#include <filesystem>
#include <string>

#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::rl {

/// the file's task config: ParseTaskConfig(task_yaml) with messages naming `path`. Throws InputError when the file
/// carries no task, naming the flag that supplies one.
tasks::TaskConfig PolicyTaskConfig(const control::PolicyFile& file, const std::string& path);

/// Where a controller runs besides its own task: another robot, scene or obstacle speed (empty / unset: the file's).
struct TaskMove {
  std::string robot;  ///< a shipped arm, "planar2", or a path to a user's .urdf (collision YAML beside it, else fitted)
  /// the .urdf's collision YAML ("": beside it, else capsules fitted in memory); with `robot` set, "" also drops the
  /// file's own collision YAML (it belongs to the file's robot)
  std::string collision;
  /// the scene (sim::ScenarioNames): crossing, line-crossing or cluttered, run as the task that runs it
  std::string scene;
  double obstacle_speed = -1.0;  ///< [m/s] ≥ 0: every obstacle at this speed (reach-avoid, line-crossing); < 0: unset
  /// a YAML mapping merged over the file's task and, when the scene moves, over the scene's shipped task (as a training
  /// config's task.overrides); robot, collision and obstacle_speed above win over it
  std::string overrides_yaml;
};

/// the task a controller file runs on, moved: the file's controller sections (interface, controller, options,
/// observation, basic layer, control rate and physics timestep) on the scene, reward and randomisation of the
/// shipped task `move.scene` (the file's own task when empty), with `move.robot` and `move.obstacle_speed` applied.
/// Throws InputError naming `path` and the flag (--scenario, --obstacle-speed) for what cannot fit.
tasks::TaskConfig PolicyTaskConfig(const control::PolicyFile& file, const std::string& path, const TaskMove& move);

/// the card of a controller file as YAML text: its name, format, network, interface sizes, the task it runs on and
/// its provenance. Generated, never read back.
std::string PolicyCard(const control::PolicyFile& file, const std::string& path);

/// a training config (YAML text) as a controller file's provenance records it: what was learned, without how or where
/// the run was executed (output_dir, thread counts, logging, checkpoint cadence; a resumed run with other threads
/// learns the same bits), and init_actor_from by its run and file instead of its path on the training machine.
std::string TrainingConfigProvenance(const std::string& train_config_yaml);

/// the controller task of a training run: the task file + overrides merged (`overrides_yaml` as a training config's
/// task.overrides) with `interface` set when not empty, then the scene, reward and randomisation sections put back
/// to the task file's (training-only changes to those stay in the provenance's training config). YAML text for
/// PolicyFile::task_yaml. Throws InputError naming the file for bad YAML.
std::string ControllerTaskYaml(const std::filesystem::path& task_file, const std::string& overrides_yaml,
                               const std::string& interface);

}  // namespace rmpmarl::rl
