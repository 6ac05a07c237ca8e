#pragma once
/// A robot = kinematic Model (from URDF) + collision capsules, end effector and self-collision exclusions (from a
/// collision YAML beside the URDF; urdfdom 3.0.1 drops <capsule> geometry, so capsules cannot live in the URDF).
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "rmpmarl/kinematics/model.h"
#include "rmpmarl/math/geometry.h"

namespace rmpmarl::kinematics {

/// A collision capsule fixed on a link: segment [p_LA, p_LB] in the link frame, inflated by radius.
struct LinkCapsule {
  int link = -1;
  Eigen::Vector3d p_LA = Eigen::Vector3d::Zero();
  Eigen::Vector3d p_LB = Eigen::Vector3d::Zero();
  double radius = 0.0;
};

/// the capsule in the world frame W at the link poses of `data` (CalcForwardKinematics run on it).
inline math::Capsule WorldCapsule(const LinkCapsule& capsule, const Data& data) {
  const Eigen::Isometry3d& X_WL = data.X_WL[capsule.link];
  return {X_WL * capsule.p_LA, X_WL * capsule.p_LB, capsule.radius};
}

/// The end-effector frame: a point (and orientation) fixed on a link.
struct EndEffector {
  int link = -1;
  Eigen::Isometry3d X_LE = Eigen::Isometry3d::Identity();
};

/// Everything rmpmarl needs to know about a manipulator.
struct Robot {
  std::string name;
  Model model;
  /// the collision model: what is checked against obstacles and the floor, and what the RMPs and agents act on
  std::vector<LinkCapsule> capsules;
  /// a second conservative cover checked for self-collision only, when not empty (collision YAML:
  /// self_collision_capsules). A tight cover holds dozens of capsules per link, and its self pairs would be most of a
  /// planner's checks; a coarser cover of the same meshes proves two links apart as well. Empty: `capsules`.
  std::vector<LinkCapsule> self_capsules;
  EndEffector end_effector;
  /// link pairs (i < j) never checked for self-collision: declared ones plus every parent–child pair.
  std::vector<std::pair<int, int>> excluded_pairs;
  std::filesystem::path urdf_path;
  std::filesystem::path collision_path;
  /// per-robot settings (an RMPflow config: home posture, overrides) of a user's robot: <urdf stem>.rmpflow.yaml
  /// beside the collision YAML or the URDF when present; empty for the shipped robots, whose settings are
  /// configs/rmpflow/<name>.yaml (see rmp::RmpflowConfigPath(const Robot&)).
  std::filesystem::path settings_path;
  /// home posture found in memory (rmpmarl demo with no YAML: setup::SetupRobot); empty otherwise. It replaces
  /// the settings' home when set.
  Eigen::VectorXd home;
  /// true for a robot loaded from models/robots/<name>/ (or built in code): its settings are looked up by name.
  bool shipped = false;

  /// true when links i and j are excluded from self-collision checks.
  bool IsExcludedPair(int i, int j) const;
  /// the capsules checked for self-collision: self_capsules, or capsules when there is no separate set.
  const std::vector<LinkCapsule>& self_collision_capsules() const {
    return self_capsules.empty() ? capsules : self_capsules;
  }
  /// with self_capsules: the first link with capsules in one set and none in the other (-1: none, or no such set);
  /// both sets must cover the same links
  int LinkInOneCoverOnly() const;
  /// the capsules of `set` (capsules or self_capsules) on `link`
  static int CountOn(const std::vector<LinkCapsule>& set, int link);
};

/// parses a URDF file into a Model (revolute, continuous, prismatic, fixed joints; any tree). Throws InputError.
Model LoadUrdfModel(const std::filesystem::path& urdf_path);

/// parses URDF text into a Model; `source` names it in error messages. Throws InputError.
Model ParseUrdfModel(const std::string& urdf_xml, const std::string& source);

/// loads a robot from its URDF and collision YAML; validates both and throws InputError naming file and key.
/// Sets settings_path to <urdf stem>.rmpflow.yaml beside the collision YAML or the URDF when one exists, and
/// `shipped` when the URDF is a shipped robot's.
Robot LoadRobot(const std::filesystem::path& urdf_path, const std::filesystem::path& collision_path);

/// directory of the shipped robot models (source tree, or the installed share directory).
std::filesystem::path ModelsDirectory();

/// names of the shipped manipulators under models/robots/ (sorted), planar2 excluded.
std::vector<std::string> ShippedRobotNames();

/// loads a shipped robot by name: models/robots/<name>/{<name>.urdf,collision.yaml}.
Robot LoadShippedRobot(const std::string& name);

/// Options of the paper's two-link pre-training arm (link lengths are domain-randomised).
struct Planar2Options {
  double link1_length = 0.5;   ///< [m]
  double link2_length = 0.5;   ///< [m]
  double link_radius = 0.04;   ///< capsule radius [m]
  double joint_limit = 3.0;    ///< |q| bound [rad]
  double velocity_limit = 3.0; ///< |q̇| bound [rad/s]
};

/// the two-link planar arm (joints about z, links along x, moving in the z = 0 plane), built in code.
Robot MakePlanar2(const Planar2Options& options = {});

}  // namespace rmpmarl::kinematics
