// `rmpmarl policy show FILE`: the card of a controller file (generated from it);
// `rmpmarl policy upgrade OLD --out NEW [--task T] [--card YAML] [--overrides YAML]`: a format-1 file (the network
// alone) with the layer and provenance its YAML card held, rewritten as one format-2 file.
#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include <array>
#include <filesystem>
#include <memory>
#include <string>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/control/agent_interface.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::apps {
namespace {

YAML::Node LoadCard(const std::filesystem::path& path) {
  try {
    const YAML::Node root = YAML::LoadFile(path.string());
    if (!root.IsMap()) throw InputError(fmt::format("{}: expected a YAML mapping (a policy card)", path.string()));
    return root;
  } catch (const YAML::Exception& e) {
    throw InputError(fmt::format("{}:{}: malformed YAML: {}", path.string(), e.mark.line + 1, e.msg));
  }
}

// a string key of the card, or "" (a non-string value is refused naming the key).
std::string CardString(const YAML::Node& node, const std::string& key, const std::filesystem::path& card) {
  const YAML::Node v = node[key];
  if (!v) return "";
  if (!v.IsScalar()) throw InputError(fmt::format("{}: key '{}': expected a string", card.string(), key));
  return v.Scalar();
}

struct UpgradeArgs {
  std::string in, out, task, card, overrides;
};

void Upgrade(const UpgradeArgs& args) {
  control::PolicyFile file;
  file.weights = control::LoadPolicyFileV1(args.in);
  std::filesystem::path card = args.card;
  if (card.empty()) {
    const std::filesystem::path beside = std::filesystem::path(args.in).replace_extension(".yaml");
    if (std::filesystem::exists(beside)) card = beside;
  }
  std::string task = args.task, interface, overrides;
  YAML::Node provenance(YAML::NodeType::Map);
  if (!card.empty()) {
    const YAML::Node root = LoadCard(card);
    const YAML::Node training = root["training_config"];
    if (training && training.IsMap() && training["task"] && training["task"].IsMap()) {
      const YAML::Node t = training["task"];
      if (task.empty()) task = CardString(t, "name", card);
      interface = CardString(t, "interface", card);
      if (t["overrides"]) overrides = YAML::Dump(t["overrides"]);
    }
    // a card's task_overrides is the basic layer the controller runs on (its training scene stays in the
    // provenance's training config)
    if (const std::string layer = CardString(root, "task_overrides", card); !layer.empty()) overrides = layer;
    for (const auto& kv : root) {
      const std::string key = kv.first.as<std::string>();
      if (key == "policy" || key == "task_overrides") continue;
      provenance[key] = kv.second;
    }
    if (const YAML::Node recorded = provenance["training_config"]; recorded && recorded.IsMap()) {
      provenance["training_config"] = YAML::Load(rl::TrainingConfigProvenance(YAML::Dump(recorded)));
    }
  }
  if (task.empty()) {
    throw InputError(fmt::format("policy upgrade {}: no card names its task: give --task (one of reach-avoid, "
                                 "line-crossing, cluttered, pretrain-2link)", args.in));
  }
  tasks::ParseTaskKind(task);
  if (!args.overrides.empty()) overrides = args.overrides;
  file.task_yaml = rl::ControllerTaskYaml(tasks::TaskConfigPath(task), overrides, interface);
  // the network must fit the task it is given: its observation size is fixed by the interface and lookahead
  const tasks::TaskConfig config = tasks::ParseTaskConfig(file.task_yaml, args.in + " (upgraded task)");
  const size_t obs = control::PerJointObservationNames(config.interface, config.observation.lookahead > 0.0).size();
  if (obs != static_cast<size_t>(file.weights.obs_dim)) {
    throw InputError(fmt::format("policy upgrade {}: the network takes {} observations per joint; task '{}' "
                                 "(interface {}, lookahead {}) gives {}: give the card it was shipped with "
                                 "(--card) or the task keys it was trained with (--overrides)",
                                 args.in, file.weights.obs_dim, task, tasks::InterfaceModeName(config.interface),
                                 config.observation.lookahead, obs));
  }
  provenance["upgraded_from"] = std::filesystem::path(args.in).filename().string();
  file.provenance_yaml = YAML::Dump(provenance);
  control::SavePolicyFile(file, args.out);
  fmt::print("wrote {} (format {}, task {}{})\n", args.out, control::kPolicyFormatVersion, task,
             card.empty() ? "" : ", layer and provenance from " + card.string());
}

}  // namespace

void RegisterPolicy(CLI::App& app) {
  auto* cmd = app.add_subcommand("policy", "Controller files (.rmpp): print one's card, upgrade an old one");
  cmd->require_subcommand(1);
  auto show_path = std::make_shared<std::string>();
  auto* show = cmd->add_subcommand("show", "Print a controller file's card (YAML, generated from the file): network, "
                                           "the task it runs on, provenance");
  show->add_option("policy", *show_path, "controller file (.rmpp)")->required();
  show->callback([show_path] {
    const control::PolicyFile file = control::LoadPolicyFile(*show_path);
    fmt::print("{}", rl::PolicyCard(file, *show_path));
  });
  auto args = std::make_shared<UpgradeArgs>();
  auto* upgrade = cmd->add_subcommand(
      "upgrade", "Rewrite a format-1 policy file (the network alone) as format 2, with the basic layer and provenance "
                 "of the YAML card beside it (<stem>.yaml) or --card");
  upgrade->add_option("policy", args->in, "format-1 policy file")->required();
  upgrade->add_option("--out", args->out, "format-2 file to write")->required();
  upgrade->add_option("--task", args->task, "the task it runs on (default: the card's training task)");
  upgrade->add_option("--card", args->card, "its YAML card (default: <stem>.yaml beside it)");
  upgrade->add_option("--overrides", args->overrides,
                      "task keys it was trained with, as YAML over the task's config (replaces the card's)");
  upgrade->callback([args] { Upgrade(*args); });
  auto annotate = std::make_shared<std::array<std::string, 2>>();
  auto* provenance = cmd->add_subcommand(
      "set-provenance", "Merge a YAML mapping (commit, wall clock, evaluation summary...) into a controller file's "
                        "provenance, key by key, rewriting the file (scripts/ship-policies)");
  provenance->add_option("policy", (*annotate)[0], "controller file (.rmpp)")->required();
  provenance->add_option("yaml", (*annotate)[1], "YAML file holding a mapping")->required();
  provenance->callback([annotate] {
    const auto& [path, yaml] = *annotate;
    control::PolicyFile file = control::LoadPolicyFile(path);
    const YAML::Node add = LoadCard(yaml);
    YAML::Node merged = file.provenance_yaml.empty() ? YAML::Node(YAML::NodeType::Map) : YAML::Load(file.provenance_yaml);
    for (const auto& kv : add) merged[kv.first.as<std::string>()] = kv.second;
    file.provenance_yaml = YAML::Dump(merged);
    control::SavePolicyFile(file, path);
    fmt::print("{}: provenance updated from {}\n", path, yaml);
  });
}

}  // namespace rmpmarl::apps
