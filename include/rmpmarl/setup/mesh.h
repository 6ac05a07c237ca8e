#pragma once
/// Mesh files of URDF links: found through package:// and relative paths, read with assimp (STL, OBJ, DAE, ...) when
/// rmpmarl is built with it. The one place that links assimp: a program linking rmpmarl::control does not.
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <vector>

namespace rmpmarl::setup {

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

}  // namespace rmpmarl::setup
