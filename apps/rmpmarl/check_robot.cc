// `rmpmarl check-robot`: loads a URDF + collision YAML (or fits one in memory), validates them and prints joints,
// limits, capsules, end effector; checks the home posture for overlapping capsules and builds the MuJoCo world.
#include <fmt/core.h>
#include <fmt/ranges.h>

#include <algorithm>
#include <cmath>
#include <filesystem>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/setup/robot_setup.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::apps {
namespace {

void PrintRobot(const kinematics::Robot& robot) {
  const kinematics::Model& model = robot.model;
  fmt::print("robot '{}': {} links, {} joints with a degree of freedom\n", robot.name, model.num_links(), model.nq());
  fmt::print("  urdf:      {}\n  collision: {}\n", robot.urdf_path.string(), robot.collision_path.string());
  fmt::print("\n  {:>2}  {:<22} {:<10} {:<20} {:>9} {:>9} {:>9} {:>8}\n", "#", "joint", "type", "child link",
             "lower", "upper", "vel", "effort");
  for (int i = 0; i < model.nq(); ++i) {
    const kinematics::Link& link = model.link(model.dof_link(i));
    const kinematics::DofLimits& l = model.limits()[i];
    fmt::print("  {:>2}  {:<22} {:<10} {:<20} {:>9.4f} {:>9.4f} {:>9.3f} {:>8.1f}\n", i, link.joint_name,
               kinematics::JointTypeName(link.joint_type), link.name, l.lower, l.upper, l.velocity, l.effort);
  }
  for (int k = 1; k < model.num_links(); ++k) {
    const kinematics::Link& link = model.link(k);
    if (link.mimic_dof < 0) continue;
    fmt::print("   -  {:<22} {:<10} {:<20} mimic: {:.4g} x {} {:+.4g}\n", link.joint_name,
               kinematics::JointTypeName(link.joint_type), link.name, link.mimic_multiplier,
               model.dof_name(link.mimic_dof), link.mimic_offset);
  }
  fmt::print("\n  capsules ({}):\n", robot.capsules.size());
  for (const kinematics::LinkCapsule& c : robot.capsules) {
    fmt::print("    {:<22} a=[{:7.4f} {:7.4f} {:7.4f}] b=[{:7.4f} {:7.4f} {:7.4f}] r={:.4f}  length {:.4f}\n",
               model.link(c.link).name, c.p_LA.x(), c.p_LA.y(), c.p_LA.z(), c.p_LB.x(), c.p_LB.y(), c.p_LB.z(),
               c.radius, (c.p_LB - c.p_LA).norm());
  }
  const Eigen::Vector3d p_LE = robot.end_effector.X_LE.translation();
  fmt::print("\n  end effector: on '{}' at [{:.4f} {:.4f} {:.4f}]\n", model.link(robot.end_effector.link).name,
             p_LE.x(), p_LE.y(), p_LE.z());
  kinematics::Data data(model);
  kinematics::CalcForwardKinematics(model, Eigen::VectorXd::Zero(model.nq()), &data);
  const Eigen::Vector3d p_WE = data.X_WL[robot.end_effector.link] * p_LE;
  fmt::print("  end effector at q = 0: [{:.4f} {:.4f} {:.4f}] m\n", p_WE.x(), p_WE.y(), p_WE.z());
  fmt::print("  self-collision exclusions: {} pairs (parent–child pairs included)\n", robot.excluded_pairs.size());
}

// the home posture (the settings' home, else mid-range) within limits and free of overlapping capsules; the MuJoCo
// world compiles. Throws InputError naming every overlapping pair with its distance.
void CheckHomeAndWorld(const kinematics::Robot& robot) {
  const kinematics::Model& model = robot.model;
  const auto settings = rmp::RmpflowConfigPath(robot);
  const rmp::RmpflowOptions options = rmp::LoadRmpflowOptions(robot);
  Eigen::VectorXd home(model.nq());
  std::string from = robot.home.size() > 0 ? "found in memory" : settings.string();
  if (!options.home.empty()) {
    if (static_cast<int>(options.home.size()) != model.nq()) {
      throw InputError(fmt::format("{}: home: expected {} values for robot '{}', got {}", settings.string(), model.nq(),
                                   robot.name, options.home.size()));
    }
    for (int i = 0; i < model.nq(); ++i) home[i] = options.home[i];
  } else {
    from = "mid-range (no home in " + settings.string() + ")";
    for (int i = 0; i < model.nq(); ++i) {
      const auto& l = model.limits()[i];
      home[i] = std::isfinite(l.lower) && std::isfinite(l.upper) ? 0.5 * (l.lower + l.upper) : 0.0;
    }
  }
  std::string values;
  for (int i = 0; i < model.nq(); ++i) values += fmt::format("{}{:.3f}", i ? " " : "", home[i]);
  fmt::print("  home posture: [{}] ({})\n", values, from);
  for (int i = 0; i < model.nq(); ++i) {
    if (home[i] < model.limits()[i].lower || home[i] > model.limits()[i].upper) {
      throw InputError(fmt::format("home[{}] ({}) = {} is outside [{}, {}] ({})", i, model.dof_name(i), home[i],
                                   model.limits()[i].lower, model.limits()[i].upper, from));
    }
  }
  fmt::print("  manipulability at home: {:.4g}\n", setup::Manipulability(robot, home));
  const auto overlapping = setup::SelfCollisionPairsWithin(robot, home, 0.0);
  if (!overlapping.empty()) {
    std::string pairs;
    for (const auto& p : overlapping) {
      pairs += fmt::format("\n  {} – {}: {:.1f} mm", model.link(p.link_a).name, model.link(p.link_b).name,
                           1000 * p.distance);
    }
    throw InputError(fmt::format("{} capsule pair(s) of non-excluded links overlap at the home posture (add them to "
                                 "self_collision_exclude, shrink the (self-collision) capsules or change home):{}", overlapping.size(),
                                 pairs));
  }
  const setup::ClosestPair closest = setup::ClosestSelfCollisionPair(robot, home);
  if (closest.link_a >= 0) {
    fmt::print("  closest checked pair at home: {} – {}, {:.1f} mm\n", model.link(closest.link_a).name,
               model.link(closest.link_b).name, 1000 * closest.distance);
  }
  const sim::WorldModel world(robot);
  fmt::print("  MuJoCo world: compiles ({} bodies, {} geoms)\n", world.mj_model()->nbody, world.mj_model()->ngeom);
}

}  // namespace

void RegisterCheckRobot(CLI::App& app) {
  auto* cmd = app.add_subcommand("check-robot", "Validate a robot description (URDF + collision YAML, or capsules "
                                                "fitted in memory) and print it");
  static std::string urdf, collision;
  static std::vector<std::string> package_paths;
  cmd->add_option("urdf", urdf, "robot URDF file")->required();
  cmd->add_option("collision", collision, "collision YAML (default: <stem>.collision.yaml or collision.yaml beside "
                                          "the URDF, else capsules fitted in memory as setup-robot does)");
  cmd->add_option("--package-path", package_paths, "directory holding the packages of package:// meshes");
  cmd->callback([] {
    if (!std::filesystem::is_regular_file(urdf)) {
      const std::vector<std::string> names = kinematics::ShippedRobotNames();
      const std::filesystem::path robots = kinematics::ModelsDirectory() / "robots";
      if (std::find(names.begin(), names.end(), urdf) != names.end()) {
        throw InputError(fmt::format("check-robot {}: no such file; '{}' is a shipped robot, whose description is {}",
                                     urdf, urdf, (robots / urdf / (urdf + ".urdf")).string()));
      }
      throw InputError(fmt::format("check-robot {}: no such file (expected a .urdf file; the shipped robots' are "
                                   "{}/<name>/<name>.urdf, <name> one of {})", urdf, robots.string(),
                                   fmt::join(names, ", ")));
    }
    const UserRobot user = LoadUserRobot(urdf, collision, package_paths);
    if (user.setup) PrintLinkFits(*user.setup);
    PrintRobot(user.robot);
    CheckHomeAndWorld(user.robot);
    fmt::print("\nOK\n");
  });
}

}  // namespace rmpmarl::apps
