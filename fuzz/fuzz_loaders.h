#pragma once
/// The loaders that meet the fuzzers (fuzz/*_fuzzer.cc) and their regression inputs (tests/data/fuzz/<loader>/, read
/// by tests/rl_torch/fuzz_regression_test.cc): each feeds an input's bytes to a loader the way a user's file reaches
/// it. A loader must end in a loaded object or an rmpmarl::InputError; anything else (another exception, a crash, a
/// sanitizer report, a hang) is a bug.
///
/// fuzz_loaders.cc holds the torch-free loaders (built from the loaders' translation units only, see CMakeLists.txt);
/// fuzz_checkpoint_loader.cc the checkpoint one, which needs librmpmarl_torch.
#include <string>
#include <string_view>

#include "rmpmarl/common/error.h"

namespace rmpmarl::fuzz {

enum class Loader {
  kRobot,         ///< URDF + collision YAML (kinematics::LoadRobot), one input split at kCollisionSeparator
  kTaskConfig,    ///< task config YAML (tasks::LoadTaskConfig)
  kTrainConfig,   ///< training config YAML (rl::LoadTrainConfig)
  kRmpflowConfig, ///< RMPflow parameters YAML (rmp::LoadRmpflowOptions)
  kCheckpoint,    ///< training checkpoint (rl::ReadCheckpointConfig, rl::ExportCheckpointPolicy)
  kPolicy,        ///< exported policy file (control::LoadPolicyFile, then an control::PolicyRuntime and one Act)
};

/// the directory name of a loader's inputs (tests/data/fuzz/<name>/) and its fuzzer (<name>_fuzzer).
std::string_view LoaderName(Loader loader);

/// the line between the URDF and the collision YAML in a kRobot input; without it the collision file is empty.
inline constexpr std::string_view kCollisionSeparator = "\n#--- collision.yaml ---\n";

/// kCheckpoint and kPolicy inputs get their checksum (and the checkpoint header's payload size) rewritten to match
/// their bytes before loading, so a mutation reaches the parser behind the checksum instead of stopping at it.
std::string WithValidChecksum(Loader loader, std::string bytes);

/// each writes `bytes` to files in a per-process temporary directory and loads them; throws what the loader throws.
void LoadRobotInput(std::string_view bytes);
void LoadTaskConfigInput(std::string_view bytes);
void LoadTrainConfigInput(std::string_view bytes);
void LoadRmpflowConfigInput(std::string_view bytes);
void LoadPolicyInput(std::string_view bytes);       ///< after WithValidChecksum
void LoadCheckpointInput(std::string_view bytes);   ///< after WithValidChecksum (fuzz_checkpoint_loader.cc)

/// true for a loaded object, false for an rmpmarl::InputError; every other exception propagates.
template <typename Load>
bool LoadsOrInputError(Load&& load, std::string_view bytes) {
  try {
    load(bytes);
  } catch (const InputError&) {
    return false;
  }
  return true;
}

/// the loader `loader` on `bytes` through LoadsOrInputError.
inline bool LoadFuzzInput(Loader loader, std::string_view bytes) {
  switch (loader) {
    case Loader::kRobot: return LoadsOrInputError(LoadRobotInput, bytes);
    case Loader::kTaskConfig: return LoadsOrInputError(LoadTaskConfigInput, bytes);
    case Loader::kTrainConfig: return LoadsOrInputError(LoadTrainConfigInput, bytes);
    case Loader::kRmpflowConfig: return LoadsOrInputError(LoadRmpflowConfigInput, bytes);
    case Loader::kCheckpoint: return LoadsOrInputError(LoadCheckpointInput, bytes);
    case Loader::kPolicy: return LoadsOrInputError(LoadPolicyInput, bytes);
  }
  return false;
}

/// the path of a file named `name` holding `bytes` in this process's temporary directory (removed at exit).
std::string WriteTempFile(const std::string& name, std::string_view bytes);

}  // namespace rmpmarl::fuzz
