// A controller file's task: the whole task it runs on (moved to another robot or scene), its card, and the
// controller task of a training run.
#include "rmpmarl/rl/policy_task.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <vector>

#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::rl {

using control::DenseLayer;
using control::kPolicyFormatVersion;
using control::PolicyFile;
using control::PolicyWeights;

tasks::TaskConfig PolicyTaskConfig(const control::PolicyFile& file, const std::string& path) {
  if (!file.has_task()) {
    throw InputError(fmt::format("policy file {} carries no task (a policy of a task outside the manipulator "
                                 "tasks): evaluate it on a task named with `rmpmarl eval FILE --task NAME`", path));
  }
  return tasks::ParseTaskConfig(file.task_yaml, path + " (its task)");
}

tasks::TaskConfig PolicyTaskConfig(const control::PolicyFile& file, const std::string& path, const TaskMove& move) {
  tasks::TaskConfig own = PolicyTaskConfig(file, path);
  if (!move.overrides_yaml.empty()) {
    YAML::Node root = internal::LoadYamlText(file.task_yaml, path);
    const YAML::Node over = internal::LoadYamlText(move.overrides_yaml, "--overrides");
    if (!over.IsNull()) {
      if (!over.IsMap()) throw InputError("--overrides: expected a YAML mapping, e.g. '{episode: {max_steps: 200}}'");
      internal::MergeYamlMaps(root, over, "--overrides");
    }
    own = tasks::ParseTaskConfig(YAML::Dump(root), path + " (its task) + --overrides");
  }
  tasks::TaskConfig config = own;
  if (!move.scene.empty()) {
    if (!sim::HasScenario(move.scene)) {
      throw InputError(fmt::format("{}: --scenario {}: expected one of the scenes {}", path, move.scene,
                                   fmt::join(sim::ScenarioNames(), ", ")));
    }
    if (!tasks::IsArmTaskScene(move.scene)) {
      throw InputError(fmt::format("{}: --scenario {}: a learned controller runs in the scenes of the arm tasks: "
                                   "crossing (reach-avoid), line-crossing, cluttered, cells (the other scenes run "
                                   "RMPflow alone: `rmpmarl demo --policy rmpflow --scenario {}`)", path, move.scene,
                                   move.scene));
    }
    const std::string task(tasks::TaskKindName(tasks::TaskOfScene(move.scene)));
    if (task != tasks::TaskKindName(own.task)) {
      // the scene, reward and randomisation of the shipped task, with the same --overrides as the controller
      config = move.overrides_yaml.empty() ? tasks::LoadShippedTaskConfig(task)
                                           : tasks::LoadTaskConfig(tasks::TaskConfigPath(task), move.overrides_yaml);
      config.robot = own.robot;
      config.collision = own.collision;
      config.interface = own.interface;
      config.controller = own.controller;
      config.options = own.options;
      config.observation = own.observation;
      config.observation.max_obstacles = std::max(own.observation.max_obstacles,
                                                  tasks::LoadShippedTaskConfig(task).observation.max_obstacles);
      config.basic_layer = own.basic_layer;
      config.direct = own.direct;
      config.episode.control_rate = own.episode.control_rate;
      config.episode.physics_timestep = own.episode.physics_timestep;
      config.source = path + " (its controller) on " + config.source;
    }
  }
  if (!move.robot.empty()) {
    config.robot = move.robot;
    config.collision = move.collision;  // a collision YAML belongs to its robot; "" = beside the URDF, else fitted
  } else if (!move.collision.empty()) {
    config.collision = move.collision;
  }
  if (move.obstacle_speed >= 0.0) {
    switch (config.task) {
      case tasks::TaskKind::kReachAvoid:
        config.scenario.crossing.obstacle_speed = move.obstacle_speed;
        config.scenario.crossing.obstacle_speed_max = 0.0;
        break;
      case tasks::TaskKind::kLineCrossing:
        config.scenario.line_speeds = {move.obstacle_speed};
        break;
      case tasks::TaskKind::kCells:  // its crossing cubes
        config.scenario.cells.crossing_speed = move.obstacle_speed;
        config.scenario.cells.crossing_speed_max = 0.0;
        break;
      default:
        throw InputError(fmt::format("{}: --obstacle-speed: the {} scene's obstacles do not move (reach-avoid, "
                                     "line-crossing and cells have moving ones)", path,
                                     tasks::TaskKindName(config.task)));
    }
  }
  tasks::ValidateTaskConfig(config, config.source);
  return config;
}

std::string PolicyCard(const control::PolicyFile& file, const std::string& path) {
  const control::PolicyWeights& w = file.weights;
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "policy" << YAML::Value << std::filesystem::path(path).filename().string();
  out << YAML::Key << "format" << YAML::Value << control::kPolicyFormatVersion;
  out << YAML::Key << "network" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "observation" << YAML::Value << w.obs_dim;
  std::vector<int> hidden;
  for (const control::DenseLayer& l : w.hidden) hidden.push_back(static_cast<int>(l.weight.rows()));
  out << YAML::Key << "hidden" << YAML::Value << YAML::Flow << hidden;
  out << YAML::Key << "activation" << YAML::Value << (w.activation == 0 ? "relu" : "tanh");
  out << YAML::Key << "options" << YAML::Value << w.num_options;
  out << YAML::Key << "continuous" << YAML::Value << w.num_continuous;
  out << YAML::Key << "termination" << YAML::Value << w.has_termination;
  out << YAML::EndMap;
  if (file.has_task()) {
    const tasks::TaskConfig task = PolicyTaskConfig(file, path);
    out << YAML::Key << "runs_on" << YAML::Value << YAML::BeginMap;
    out << YAML::Key << "task" << YAML::Value << std::string(tasks::TaskKindName(task.task));
    out << YAML::Key << "robot" << YAML::Value << task.robot;
    out << YAML::Key << "interface" << YAML::Value << std::string(tasks::InterfaceModeName(task.interface));
    out << YAML::EndMap;
    out << YAML::Key << "task" << YAML::Value << internal::LoadYamlText(file.task_yaml, path);
  }
  if (!file.provenance_yaml.empty()) {
    out << YAML::Key << "provenance" << YAML::Value << internal::LoadYamlText(file.provenance_yaml, path);
  }
  out << YAML::EndMap;
  return std::string("# generated from ") + std::filesystem::path(path).filename().string() +
         " by `rmpmarl policy show`; the policy file is the source, this card is never read\n" + out.c_str() + "\n";
}

std::string TrainingConfigProvenance(const std::string& train_config_yaml) {
  YAML::Node training = internal::LoadYamlText(train_config_yaml, "training config");
  if (!training.IsMap()) throw InputError("training config: expected a YAML mapping");
  for (const char* key : {"output_dir", "env_threads", "torch_threads", "logging", "checkpoint_every"}) {
    training.remove(key);
  }
  if (const YAML::Node from = training["init_actor_from"]; from && from.IsScalar() && !from.Scalar().empty()) {
    const std::filesystem::path path(from.Scalar());
    training["init_actor_from"] = (path.parent_path().filename() / path.filename()).string();
  }
  return YAML::Dump(training);
}

std::string ControllerTaskYaml(const std::filesystem::path& task_file, const std::string& overrides_yaml,
                               const std::string& interface) {
  const std::string source = task_file.string();
  std::ifstream in(task_file);
  if (!in) throw InputError(fmt::format("{}: cannot open task config (missing or unreadable)", source));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  YAML::Node merged = internal::LoadYamlText(text, source);
  const YAML::Node shipped = internal::LoadYamlText(text, source);
  if (!overrides_yaml.empty()) {
    const YAML::Node over = internal::LoadYamlText(overrides_yaml, source + " + overrides");
    if (!over.IsNull()) {
      if (!over.IsMap() || !merged.IsMap()) {
        throw InputError(fmt::format("{} + overrides: expected the file and the overrides to be mappings", source));
      }
      internal::MergeYamlMaps(merged, over, source + " + overrides");
    }
  }
  if (!interface.empty()) merged["interface"] = interface;
  for (const char* scene_key : {"scenario", "reward", "randomization"}) {
    if (shipped[scene_key]) {
      merged[scene_key] = YAML::Clone(shipped[scene_key]);
    } else {
      merged.remove(scene_key);
    }
  }
  tasks::ParseTaskConfig(YAML::Dump(merged), source + " + overrides");  // validated now, not when the controller is loaded
  return YAML::Dump(merged);
}

}  // namespace rmpmarl::rl
