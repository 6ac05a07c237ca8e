#pragma once
/// The agent config's YAML sections and checks, for readers of files that hold them as part of a larger config (the
/// task config of tasks/task_config.h reads the same sections as part of a whole task).
#include <yaml-cpp/yaml.h>

#include <set>
#include <string>
#include <string_view>

#include "rmpmarl/common/config_check.h"
#include "rmpmarl/common/yaml_reader.h"
#include "rmpmarl/control/agent_config.h"

namespace rmpmarl::control {

/// reads the controller sections present in `root` (interface, episode's max_steps, control_rate and
/// physics_timestep, controller, options, direct, observation, rmp) onto `config`; the others keep their values.
/// `episode_also`: the other keys the caller reads from the episode section (nullptr: any other key is left alone).
void ReadAgentSections(const rmpmarl::internal::YamlReader& r, const YAML::Node& root, AgentConfig* config,
                       const std::set<std::string>* episode_also);

/// a clearance [m] compared with the look-ahead block's predicted passes: −inf (off, meaning `off`) or finite, and
/// finite only with the block on (observation.lookahead > 0) and on an interface that has it (`interface_ok`,
/// described as `interfaces`).
void CheckPassClearance(const rmpmarl::internal::ConfigChecker& check, const AgentConfig& c, double clearance,
                        const std::string& key, std::string_view off, bool interface_ok, std::string_view interfaces);

}  // namespace rmpmarl::control
