#pragma once
/// A controller file (`.rmpp`): the trained actor AND everything that rebuilds its controller — the task config it
/// runs on (basic layer, observation, options, interface, robot) and its provenance (training config, seed, commit,
/// wall clock, evaluation summary). A readable card is generated from it (`rmpmarl policy show`), never read back.
///
/// Format version 2 (all integers uint32 little-endian, all reals float32 little-endian):
///   magic "RMPMPOL\0" (8 bytes) · version · obs_dim · num_options · num_continuous · has_termination ·
///   activation (0 relu, 1 tanh) · num_hidden L · hidden sizes[L] ·
///   obs_clip (float; 0: no clipping) · obs_mean[obs_dim] · obs_inv_std[obs_dim] ·
///   for each hidden layer then the head: weight[out × in] (row-major, out rows) · bias[out] ·
///   log_std[num_continuous] · low[num_continuous] · high[num_continuous] ·
///   task length · task YAML (UTF-8) · provenance length · provenance YAML (UTF-8) ·
///   crc32c (uint32) of every preceding byte.
/// Format 1 ended after `high` (the network alone; its layer lived in a YAML beside it): it is refused with the
/// command that upgrades it (`rmpmarl policy upgrade`).
/// The head's outputs are [option logits (num_options) | Gaussian means (num_continuous) | termination logit (1 if
/// has_termination)], sized from the ActionSpec. The normalised observation is clamp((o − mean) · inv_std, ±clip).
#include <cstddef>
#include <cstdint>
#include <string>

#include "rmpmarl/rl/policy_runtime.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::rl {

/// the format version SavePolicyFile writes and LoadPolicyFile reads.
inline constexpr std::uint32_t kPolicyFormatVersion = 2;

/// CRC-32C (Castagnoli) of `size` bytes, continuing from `crc` (0 to start).
std::uint32_t Crc32c(const void* data, std::size_t size, std::uint32_t crc = 0);

/// Everything a controller file holds.
struct PolicyFile {
  PolicyWeights weights;
  /// the task config the controller runs on, whole (ParseTaskConfig reads it); "" for a policy of a task outside the
  /// manipulator tasks (toy-reach), which then needs one named where it is evaluated.
  std::string task_yaml;
  /// a YAML mapping: training config, seed, commit, wall clock, evaluation summary ("" or "{}": none recorded).
  std::string provenance_yaml;

  /// true when the file carries its task.
  bool has_task() const { return !task_yaml.empty(); }
};

/// writes `file` to `path` atomically (temporary file + rename). Throws InputError on I/O failure, inconsistent
/// weights, or a task/provenance text that is not a YAML mapping.
void SavePolicyFile(const PolicyFile& file, const std::string& path);
/// reads a controller file; a wrong magic, a format-1 file (with the upgrade command), a truncated file or a checksum
/// mismatch throws InputError naming it.
PolicyFile LoadPolicyFile(const std::string& path);
/// reads the network of a format-1 file (for the upgrade only). Throws InputError like LoadPolicyFile.
PolicyWeights LoadPolicyFileV1(const std::string& path);

/// the file's task config: ParseTaskConfig(task_yaml) with messages naming `path`. Throws InputError when the file
/// carries no task, naming the flag that supplies one.
tasks::TaskConfig PolicyTaskConfig(const PolicyFile& file, const std::string& path);

/// Where a controller runs besides its own task: another robot, scene or obstacle speed (empty / unset: the file's).
struct TaskMove {
  std::string robot;  ///< a shipped arm, "planar2", or a path to a user's .urdf (collision YAML beside it, else fitted)
  /// the .urdf's collision YAML ("": beside it, else capsules fitted in memory); with `robot` set, "" also drops the
  /// file's own collision YAML (it belongs to the file's robot)
  std::string collision;
  /// the scene: a task (reach-avoid, line-crossing, cluttered) or the scenario it runs (crossing = reach-avoid)
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
tasks::TaskConfig PolicyTaskConfig(const PolicyFile& file, const std::string& path, const TaskMove& move);

/// the card of a controller file as YAML text: its name, format, network, interface sizes, the task it runs on and
/// its provenance. Generated, never read back.
std::string PolicyCard(const PolicyFile& file, const std::string& path);

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
