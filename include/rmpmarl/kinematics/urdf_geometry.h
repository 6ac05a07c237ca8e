#pragma once
/// The geometry a URDF gives its links (<collision>, else <visual>: sphere, box, cylinder, mesh). Mesh files are found
/// and read by the setup module (setup/mesh.h).
#include <Eigen/Geometry>
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

}  // namespace rmpmarl::kinematics
