#pragma once
/// MoveIt's Semantic Robot Description Format (SRDF, the <robot> file beside a robot's URDF in its moveit_config):
/// the link pairs its authors disabled for self-collision checks, its end effectors, groups and virtual joints.
/// `rmpmarl setup-robot` (setup::SetupRobot) excludes the disabled pairs and takes the end effector's parent
/// link as the robot's end effector; see docs/robot-description.md. Group states and passive joints are not read.
#include <filesystem>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/model.h"

namespace rmpmarl::setup {

/// <disable_collisions link1 link2 reason/>: a pair never checked against each other.
struct SrdfDisabledPair {
  std::string link1, link2;
  std::string reason;  ///< as written ("Adjacent", "Never", "Default", "User"); "" when absent
  int line = 0;        ///< line in the SRDF (for messages)
};

/// <end_effector name parent_link group parent_group/>: the group `group` attached to `parent_link`.
struct SrdfEndEffector {
  std::string name, parent_link, group, parent_group;
  int line = 0;
};

/// <virtual_joint name type parent_frame child_link/>: how the robot is attached to the world ("fixed", "floating",
/// "planar").
struct SrdfVirtualJoint {
  std::string name, type, parent_frame, child_link;
  int line = 0;
};

/// <chain base_link tip_link/> of a group.
struct SrdfChain {
  std::string base_link, tip_link;
};

/// <group name>: its members as written (subgroups are not expanded).
struct SrdfGroup {
  std::string name;
  std::vector<SrdfChain> chains;
  std::vector<std::string> links, joints;
  std::vector<std::string> subgroups;  ///< <group name=".."/> inside the group
  int line = 0;
};

/// A parsed SRDF, elements in file order.
struct Srdf {
  std::string source;      ///< the file it was read from, as it names it in messages
  std::string robot_name;  ///< <robot name>
  std::vector<SrdfDisabledPair> disabled_collisions;
  std::vector<SrdfEndEffector> end_effectors;
  std::vector<SrdfVirtualJoint> virtual_joints;
  std::vector<SrdfGroup> groups;
};

/// parses SRDF text; `source` names it in messages. Throws InputError naming the source for malformed XML, a root
/// other than <robot>, or an element without an attribute it needs (link1/link2, name/parent_link, ...).
Srdf ParseSrdf(const std::string& xml, const std::string& source);

/// reads and parses an SRDF file. Throws InputError when it cannot be read or parsed.
Srdf LoadSrdf(const std::filesystem::path& path);

/// checks the SRDF's link and joint names against a URDF's model. Where the SRDF would attach the robot to links it
/// does not have (an end effector's parent_link, a virtual joint's child_link) it is not this robot's: throws
/// InputError naming the SRDF, the element, the link and the URDF's links. Where MoveIt only warns and skips the
/// element (a disabled pair or a group member naming an unknown link or joint, another robot name) returns a
/// warning per element; those pairs are not excluded.
std::vector<std::string> CheckSrdfAgainstModel(const Srdf& srdf, const kinematics::Model& model);

}  // namespace rmpmarl::setup
