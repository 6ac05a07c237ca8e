#pragma once
/// The geometry a URDF gives its links (<collision>, else <visual>: sphere, box, cylinder, mesh), mesh files found
/// through package:// and relative paths, and meshes read with assimp (STL, OBJ, DAE, ...).
#include <Eigen/Geometry>
#include <filesystem>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/model.h"

namespace rmpmarl::kinematics {

enum class ShapeKind { kSphere, kBox, kCylinder, kMesh };

/// name of a shape kind as in URDF ("sphere", "box", "cylinder", "mesh").
std::string_view ShapeKindName(ShapeKind kind);

/// One <collision> or <visual> element of a link: shape G posed at X_LG in the link frame L.
struct LinkShape {
  int link = -1;
  ShapeKind kind = ShapeKind::kSphere;
  bool visual = false;                                       ///< from <visual> (the link has no <collision>)
  Eigen::Isometry3d X_LG = Eigen::Isometry3d::Identity();
  double radius = 0.0;                                       ///< sphere, cylinder [m]
  double length = 0.0;                                       ///< cylinder, along z of G [m]
  Eigen::Vector3d size = Eigen::Vector3d::Zero();            ///< box: full side lengths [m]
  std::string mesh_uri;                                      ///< mesh: filename as written in the URDF
  Eigen::Vector3d mesh_scale = Eigen::Vector3d::Ones();      ///< mesh: <mesh scale>
};

/// Which of a link's elements ParseUrdfShapes reads.
enum class UrdfShapeSource {
  kCollisionFirst,  ///< its <collision> elements, or its <visual> ones when it has none (what to fit capsules to)
  kVisualFirst,     ///< its <visual> elements, or its <collision> ones when it has none (what to draw)
};

/// the shapes of every link of `model` (parsed from the same URDF text): a link's <collision> elements, or its
/// <visual> elements when it has no <collision> (`which` swaps the two); links with neither contribute nothing
/// (frame-only links).
/// Throws InputError (naming `source`) on non-finite or non-positive sizes.
std::vector<LinkShape> ParseUrdfShapes(const std::string& urdf_xml, const Model& model, const std::string& source,
                                       UrdfShapeSource which = UrdfShapeSource::kCollisionFirst);

/// where the mesh `uri` of a URDF at `urdf_path` lives: "package://PKG/rest" in a directory PKG found under one of
/// `package_paths`, then ROS_PACKAGE_PATH, then among the URDF's ancestor directories (the vendor layout
/// PKG/urdf/robot.urdf); "file:///abs"; otherwise relative to the URDF's directory. Returns an empty path when no file
/// exists; `tried` (when given) then lists the places looked at.
std::filesystem::path ResolveMeshUri(const std::string& uri, const std::filesystem::path& urdf_path,
                                     const std::vector<std::filesystem::path>& package_paths,
                                     std::string* tried = nullptr);

/// A triangle mesh: vertices (in the mesh file's frame, scaled, metres) and triangles as vertex indices.
struct TriangleMesh {
  Eigen::Matrix3Xd p_M;
  std::vector<Eigen::Vector3i> triangles;
};

/// true when rmpmarl was built with assimp (meshes can be read).
bool MeshReadingAvailable();

/// reads a mesh file (STL, OBJ, DAE and the other formats assimp knows) with every node transform applied (COLLADA
/// <unit> honoured, its up axis ignored as ROS does) and `scale` per axis. Throws InputError naming the file.
TriangleMesh ReadMesh(const std::filesystem::path& path, const Eigen::Vector3d& scale = Eigen::Vector3d::Ones());

}  // namespace rmpmarl::kinematics
