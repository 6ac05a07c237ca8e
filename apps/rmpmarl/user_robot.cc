// A user's robot for check-robot and demo: its collision YAML when there is one, else fitted in memory.
#include <fmt/core.h>

#include "commands.h"
#include "rmpmarl/kinematics/robot_setup.h"

namespace rmpmarl::apps {

UserRobot LoadUserRobot(const std::string& urdf, const std::string& collision,
                        const std::vector<std::string>& package_paths) {
  UserRobot out;
  std::filesystem::path yaml = collision;
  if (yaml.empty()) {
    const std::filesystem::path urdf_path(urdf);
    const std::filesystem::path dir = urdf_path.has_parent_path() ? urdf_path.parent_path() : std::filesystem::path(".");
    // setup-robot's <stem>.collision.yaml, else the shipped layout's collision.yaml
    for (const std::filesystem::path& beside : {kinematics::CollisionYamlPathFor(urdf_path, dir), dir / "collision.yaml"}) {
      if (std::filesystem::is_regular_file(beside)) {
        yaml = beside;
        break;
      }
    }
  }
  if (!yaml.empty()) {
    out.robot = kinematics::LoadRobot(urdf, yaml);
    return out;
  }
  kinematics::RobotSetupOptions options;
  for (const std::string& p : package_paths) options.package_paths.emplace_back(p);
  out.setup = kinematics::SetupRobot(urdf, options);
  out.robot = out.setup->robot;
  out.robot.home = out.setup->home;
  fmt::print("{}: no collision YAML: capsules fitted in memory from the URDF's geometry, {} exclusions sampled, home "
             "searched (rmpmarl setup-robot {} writes them to files)\n", urdf, out.setup->exclusions.size(), urdf);
  for (const std::string& w : out.setup->warnings) fmt::print("  WARNING: {}\n", w);
  return out;
}

}  // namespace rmpmarl::apps
