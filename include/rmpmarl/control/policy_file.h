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

#include "rmpmarl/control/agent_config.h"
#include "rmpmarl/control/policy_runtime.h"

namespace rmpmarl::control {

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

/// the agents' configuration of the file's task (control::ParseAgentConfig, messages naming `path`). Throws
/// InputError when the file carries no task.
AgentConfig PolicyAgentConfig(const PolicyFile& file, const std::string& path);

}  // namespace rmpmarl::control
