// A user's robot for check-robot and demo: its collision YAML when there is one, else fitted in memory.
#include <fmt/core.h>

#include "commands.h"
#include "rmpmarl/kinematics/robot_setup.h"

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

}  // namespace rmpmarl::apps
