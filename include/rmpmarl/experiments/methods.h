#pragma once
/// The methods the experiments compare, as data: one YAML file per method, named by its key.
///   configs/methods/<key>.yaml    the methods a user sees (the paper's and the project's)
///   configs/ablations/<key>.yaml  the study's variants (run by key with `experiment NAME --methods KEY`)
///   configs/layers/<name>.yaml    basic-layer variants (task config overrides) that methods refer to by name
///   configs/experiments/<name>.yaml  an experiment's default method keys
/// docs/experiments.md describes the file format.
#include <array>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rmpmarl/experiments/evaluation.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::experiments {

/// How a learned method is trained: a training config, its task's changes, its pre-training and budget.
struct TrainingRecipe {
  std::string config;           ///< configs/train/<config>.yaml
  std::string init;             ///< method key whose run of the same seed initialises the actor ("" none)
  bool two_link = false;        ///< trained on the two-link arm (pretrain-2link): no experiment obstacle slots
  int updates = 0;              ///< > 0: at most this many updates (a cheaper budget than the experiment's)
  std::string overrides;        ///< task overrides of training only (a YAML flow mapping, "" none)
  std::string reward;           ///< the `reward` section of training, on the training and the mix task ("" none)
  std::string mix_task;         ///< a second training task on half the envs ("" none)
  std::string mix_overrides;    ///< its own overrides
  double seconds_per_update = 0.0;  ///< measured training cost on the reference machine (0: unknown), for estimates
};

/// One method, as its file states it.
struct MethodSpec {
  std::string key;                ///< the file's stem; run ids are <key>-seed<s>
  std::string label;              ///< row and legend label
  std::filesystem::path file;
  enum class Kind { kLearned, kBasicLayer, kRmpflow, kRrt } kind = Kind::kRmpflow;
  std::optional<TrainingRecipe> training;  ///< kLearned
  tasks::InterfaceMode interface = tasks::InterfaceMode::kPerJointRmp;  ///< kLearned: from the training config
  std::string shipped;            ///< kLearned: models/policies/<shipped> evaluated by `--shipped` ("" none)
  std::string layer;              ///< configs/layers/<layer>.yaml ("" the task's own layer)
  std::string layer_yaml;         ///< that file's overrides as a YAML flow mapping
  int option = 0;                 ///< kBasicLayer: 0 target, 1 collision, 2 target-then-collision
  std::array<float, control::RmpActionLayout::kNumContinuous> parameters{};  ///< kBasicLayer: raw u (0: unit scales)
  std::optional<Method::ThreatGate> gate;  ///< kBasicLayer: the hand rule on the look-ahead block
  std::string evaluate;           ///< kBasicLayer: evaluation task overrides after the layer ("" none)
  std::string rmpflow;            ///< kRmpflow: overrides of the robot's configs/rmpflow file ("" none)
};

/// configs/ (beside the task configs).
std::filesystem::path ConfigsDirectory();
/// configs/train/<name>.yaml.
std::filesystem::path TrainConfigPath(const std::string& name);
/// reads one method file (`key` names it in runs and messages). Throws InputError naming the file and key for unknown
/// keys, a missing label or kind, keys of another kind, a missing layer or training config, out-of-range values.
MethodSpec LoadMethodFile(const std::string& key, const std::filesystem::path& file);
/// the spec of a method key (configs/methods/ first, then configs/ablations/). Throws InputError naming the file and
/// key for a malformed one, and listing the known keys for an unknown one.
const MethodSpec& FindMethod(const std::string& key);
/// every method key: configs/methods/ (sorted), then configs/ablations/ (sorted).
std::vector<std::string> MethodKeys();
/// the keys in configs/methods/ (the methods a user sees).
std::vector<std::string> ProductMethodKeys();
/// an experiment's default method keys (configs/experiments/<name>.yaml `methods`).
std::vector<std::string> DefaultMethods(const std::string& experiment);
/// the evaluation method of a spec: a learned one evaluated from `policy_path`; its task changes (layer, evaluate)
/// are applied to the evaluation task by adjust_task.
Method MakeMethod(const MethodSpec& spec, const std::string& policy_path = "");
/// a layer file's overrides as a YAML flow mapping. Throws InputError for a missing or malformed file.
std::string LayerOverrides(const std::string& layer);

}  // namespace rmpmarl::experiments
