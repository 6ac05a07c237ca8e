#pragma once
/// What the page draws of a robot besides its capsules: the <visual> elements of its URDF (boxes, spheres,
/// cylinders and meshes), the meshes read with assimp and turned into small binary files the server serves from
/// memory. The shipped robots carry no visual elements; a user's URDF usually does.
#include <Eigen/Geometry>
#include <map>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/kinematics/urdf_geometry.h"

namespace rmpmarl::viewer {

/// One visual element: a shape posed at X_LG in its link's frame; a mesh refers to a served file.
struct VisualShape {
  kinematics::LinkShape shape;
  std::string mesh_url;  ///< mesh: the served path ("/meshes/3.bin"); "" for the primitives
};

/// The robot's visuals and the mesh files to serve.
struct RobotVisuals {
  std::vector<VisualShape> shapes;
  /// served path → body. A mesh file: uint32 vertex count V, uint32 triangle count T (little-endian), then V × 3
  /// float32 positions in the link frame (X_LG and the URDF scale applied) and T × 3 uint32 vertex indices.
  std::map<std::string, std::string> files;
  /// what was left out and why (a mesh not found, unreadable, or over the size budget)
  std::vector<std::string> warnings;
};

/// Options of LoadRobotVisuals.
struct VisualOptions {
  std::size_t max_bytes = std::size_t{64} << 20;  ///< all mesh files together
  std::vector<std::string> package_paths{};       ///< where package:// URIs are looked up first
};

/// the visuals of `robot` from its URDF (robot.urdf_path; none for a robot built in code). Never throws for a mesh:
/// what cannot be drawn is left out with a warning; the robot's capsules are always drawn.
RobotVisuals LoadRobotVisuals(const kinematics::Robot& robot, const VisualOptions& options = {});

}  // namespace rmpmarl::viewer
