// The torch-free loaders behind the fuzz targets: input bytes → temporary files → the loader a user's file goes
// through.
#include "fuzz_loaders.h"

#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/tasks/task_config.h"
#include "rmpmarl/rl/torch/trainer.h"
#include "rmpmarl/rmp/rmpflow.h"

namespace rmpmarl::fuzz {
namespace {

namespace fs = std::filesystem;

// a temporary directory per process, removed at exit.
const fs::path& TempDir() {
  static const fs::path dir = [] {
    std::string pattern = (fs::temp_directory_path() / "rmpmarl-fuzz-XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) std::abort();
    std::atexit([] {
      std::error_code ec;
      fs::remove_all(TempDir(), ec);
    });
    return fs::path(pattern);
  }();
  return dir;
}

}  // namespace

std::string WriteTempFile(const std::string& name, std::string_view bytes) {
  const fs::path path = TempDir() / name;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  return path.string();
}

std::string_view LoaderName(Loader loader) {
  switch (loader) {
    case Loader::kRobot: return "robot";
    case Loader::kTaskConfig: return "task_config";
    case Loader::kTrainConfig: return "train_config";
    case Loader::kRmpflowConfig: return "rmpflow_config";
    case Loader::kCheckpoint: return "checkpoint";
    case Loader::kPolicy: return "policy";
  }
  return "unknown";
}

std::string WithValidChecksum(Loader loader, std::string bytes) {
  if (loader == Loader::kPolicy && bytes.size() >= 12) {
    const std::uint32_t crc = control::Crc32c(bytes.data(), bytes.size() - 4);
    std::memcpy(bytes.data() + bytes.size() - 4, &crc, 4);
  }
  // checkpoint header: magic (8) · version (4) · payload size (8) · crc32c of the payload (4)
  constexpr std::size_t kHeader = 24;
  if (loader == Loader::kCheckpoint && bytes.size() >= kHeader) {
    const std::uint64_t size = bytes.size() - kHeader;
    const std::uint32_t crc = control::Crc32c(bytes.data() + kHeader, size);
    std::memcpy(bytes.data() + 12, &size, 8);
    std::memcpy(bytes.data() + 20, &crc, 4);
  }
  return bytes;
}

void LoadRobotInput(std::string_view bytes) {
  const std::size_t split = bytes.find(kCollisionSeparator);
  const std::string_view urdf = bytes.substr(0, split);
  const std::string_view collision =
      split == std::string_view::npos ? std::string_view() : bytes.substr(split + kCollisionSeparator.size());
  kinematics::LoadRobot(WriteTempFile("robot.urdf", urdf), WriteTempFile("collision.yaml", collision));
}

void LoadTaskConfigInput(std::string_view bytes) { tasks::LoadTaskConfig(WriteTempFile("task.yaml", bytes)); }

void LoadTrainConfigInput(std::string_view bytes) { rl::LoadTrainConfig(WriteTempFile("train.yaml", bytes)); }

void LoadRmpflowConfigInput(std::string_view bytes) { rmp::LoadRmpflowOptions(WriteTempFile("rmpflow.yaml", bytes)); }

void LoadPolicyInput(std::string_view bytes) {
  const std::string fixed = WithValidChecksum(Loader::kPolicy, std::string(bytes));
  const std::string path = WriteTempFile("policy.rmpp", fixed);
  const control::PolicyFile file = control::LoadPolicyFile(path);
  if (file.has_task()) rl::PolicyTaskConfig(file, path);  // the task it carries parses or throws InputError
  const control::PolicyWeights& weights = file.weights;
  control::PolicyRuntime runtime(weights, 1);
  std::vector<float> obs(static_cast<std::size_t>(weights.obs_dim), 0.5f);
  std::vector<float> actions(static_cast<std::size_t>(weights.action_size()));
  runtime.Act(obs.data(), 1, actions.data());
}

}  // namespace rmpmarl::fuzz
