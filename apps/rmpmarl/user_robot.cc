// A user's robot for check-robot, demo and view: its collision YAML when there is one, else fitted in memory; the
// robot and scenario options and the default controller those commands share.
#include <fmt/core.h>

#include "commands.h"
#include "rmpmarl/kinematics/robot_setup.h"
#include "rmpmarl/sim/scenario.h"

namespace rmpmarl::apps {

UserRobot LoadUserRobot(const std::string& urdf, const std::string& collision,
                        const std::vector<std::string>& package_paths) {
  UserRobot out;
  kinematics::RobotSetupOptions options;
  for (const std::string& p : package_paths) options.package_paths.emplace_back(p);
  out.robot = kinematics::LoadOrFitRobot(urdf, collision, options, &out.setup);
  if (!out.setup) return out;
  fmt::print("{}: no collision YAML: capsules fitted in memory from the URDF's geometry, {} exclusions sampled, home "
             "searched (rmpmarl setup-robot {} writes them to files)\n", urdf, out.setup->exclusions.size(), urdf);
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
  cmd->add_option("--robot", *robot, "shipped robot: " + robots)->capture_default_str();
  cmd->add_option("--urdf", *urdf, "your robot's URDF instead of --robot (its collision YAML: --collision, else "
                                  "<stem>.collision.yaml or collision.yaml beside it, else capsules fitted in memory)");
  cmd->add_option("--collision", *collision, "collision YAML of --urdf (rmpmarl setup-robot writes one)");
  cmd->add_option("--scenario", *scenario, "scenario: " + scenarios)->capture_default_str();
  cmd->add_option("--seed", *seed, "episode seed")->capture_default_str();
}

}  // namespace rmpmarl::apps
