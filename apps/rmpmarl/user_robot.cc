// A user's robot for check-robot, demo and view: its collision YAML when there is one, else fitted in memory; the
// robot and scenario options and the default controller those commands share.
#include <fmt/core.h>

#include <algorithm>
#include <filesystem>

#include "commands.h"
#include "rmpmarl/setup/robot_setup.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::apps {

UserRobot LoadUserRobot(const std::string& urdf, const std::string& collision,
                        const std::vector<std::string>& package_paths) {
  UserRobot out;
  setup::RobotSetupOptions options;
  for (const std::string& p : package_paths) options.package_paths.emplace_back(p);
  out.robot = setup::LoadOrFitRobot(urdf, collision, options, &out.setup);
  if (!out.setup) return out;
  fmt::print("{}: no collision YAML: capsules fitted in memory from the URDF's geometry, {} exclusions {}, home "
             "searched (rmpmarl setup-robot {} writes them to files)\n", urdf, out.setup->exclusions.size(),
             out.setup->srdf.empty() ? std::string("sampled") : "from " + out.setup->srdf.string() + " and sampled",
             urdf);
  for (const std::string& w : out.setup->warnings) fmt::print("  WARNING: {}\n", w);
  return out;
}

std::filesystem::path ShippedDefaultPolicyPath() {
  return kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp";
}

void AddRobotAndScenarioOptions(CLI::App* cmd, std::string* robot, std::string* urdf, std::string* collision,
                                std::string* scenario, std::uint64_t* seed) {
  std::string robots, scenarios;
  for (const auto& n : kinematics::ShippedRobotNames()) robots += (robots.empty() ? "" : ", ") + n;
  for (const auto& n : sim::ScenarioNames()) scenarios += (scenarios.empty() ? "" : ", ") + n;
  cmd->add_option("--robot", *robot, "shipped robot: " + robots)
      ->check(CLI::Validator(
          [robots](std::string& name) {
            const std::vector<std::string> names = kinematics::ShippedRobotNames();
            if (std::find(names.begin(), names.end(), name) != names.end()) return std::string();
            return "expected a shipped robot, one of " + robots + " (a robot of your own: --urdf FILE), got '" + name +
                   "'";
          },
          "ROBOT"))
      ->capture_default_str();
  cmd->add_option("--urdf", *urdf, "your robot's URDF instead of --robot (its collision YAML: --collision, else "
                                  "<stem>.collision.yaml or collision.yaml beside it, else capsules fitted in memory)")
      ->check(CLI::Validator(
          [](std::string& path) {
            return std::filesystem::is_regular_file(path) ? std::string()
                                                          : "expected an existing .urdf file, got '" + path +
                                                                "' (no such file)";
          },
          "FILE"));
  cmd->add_option("--collision", *collision, "collision YAML of --urdf (rmpmarl setup-robot writes one)");
  cmd->add_option("--scenario", *scenario, "scenario: " + scenarios)->capture_default_str();
  cmd->add_option("--seed", *seed, "episode seed")->check(SeedCheck())->capture_default_str();
}

}  // namespace rmpmarl::apps
