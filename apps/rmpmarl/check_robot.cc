// `rmpmarl check-robot`: loads a URDF + collision YAML, validates them and prints joints, limits, capsules, end effector.
#include <fmt/core.h>

#include <cmath>

#include "commands.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"

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
  fmt::print("\nOK\n");
}

}  // namespace

void RegisterCheckRobot(CLI::App& app) {
  auto* cmd = app.add_subcommand("check-robot", "Validate a robot description (URDF + collision YAML) and print it");
  static std::string urdf, collision;
  cmd->add_option("urdf", urdf, "robot URDF file")->required();
  cmd->add_option("collision", collision, "collision YAML beside the URDF (capsules, end effector)")->required();
  cmd->callback([] { PrintRobot(kinematics::LoadRobot(urdf, collision)); });
}

}  // namespace rmpmarl::apps
