#pragma once
/// The robot's collision meshes against a scene's primitives, with FCL (the Flexible Collision Library, the checker
/// MoveIt uses): the benchmark's second referee (docs/benchmarks.md), independent of the capsule model the
/// controllers and the planner run on.
///
/// MeshCollisionModel holds, per <collision> element of the robot's URDF, one FCL geometry — a BVHModel<OBBRSS> of a
/// mesh (setup::ReadMesh, its package:// resolved by setup::ResolveMeshUri), or an FCL sphere, box or
/// cylinder — with its link L and its origin X_LG; it is built once per robot and shared (read only) by threads.
/// CalcMeshClearance poses every geometry at X_WL · X_LG from the link poses of kinematics::Data and returns the
/// smallest signed distance to a list of rmp::Obstacle (spheres, boxes, cylinders) with the link and the obstacle
/// attaining it.
///
/// Cost: a pair is given to FCL only when a lower bound on its distance — the distance between the geometry's and the
/// obstacle's world boxes, and the obstacle's signed distance at the geometry's bounding-sphere centre less its radius
/// — is below the cap (MeshCollisionOptions::distance_cap) and below the smallest distance found so far; the pairs
/// are taken nearest bound first, and FCL's distance traversal starts from the best distance found, pruning with it.
/// A pair whose bounds overlap is first given to FCL's collision query (with contacts, for the depth); once a
/// collision is found only overlapping pairs are tested, for a deeper one.
///
/// Limits: FCL treats a mesh as its triangles, so an obstacle wholly inside a link's mesh (touching no triangle) is
/// not seen — a small sphere inside a hand; the cells' boards and a link wholly inside a board are seen (the board is
/// solid). The penetration depth is FCL's deepest contact (exact for sphere–triangle); for a mesh in a box or
/// cylinder, where libccd's EPA depth of a triangle across a board can be metres off, that is bounded by the
/// primitive's smallest half size (nothing lies deeper in it) and raised to the deepest mesh vertex's depth (minus the
/// primitive's signed distance there).
///
/// Self-collision (CheckMeshSelfCollision): the geometries of two links the robot checks against each other — distinct
/// links that kinematics::Robot::IsExcludedPair does not exclude, so not parent and child, not a pair its SRDF
/// disables, not a pair setup-robot found never close — are given to FCL's collision query when their world boxes
/// overlap; the first pair in contact is reported.
///
/// FCL stays out of this header (pimpl): only the experiments library links it.
#include <Eigen/Core>
#include <filesystem>
#include <limits>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "rmpmarl/kinematics/model.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::experiments {

/// Options of MeshCollisionModel.
struct MeshCollisionOptions {
  /// folders holding the packages of package:// meshes (setup::ResolveMeshUri, then ROS_PACKAGE_PATH and the
  /// URDF's ancestor folders)
  std::vector<std::filesystem::path> package_paths{};
  /// clearances are exact up to this distance [m], > 0; a configuration with nothing within it has clearance +inf
  /// (farther pairs are never given to FCL: this bounds the cost)
  double distance_cap = 0.15;
};

/// The smallest signed distance between the robot's collision geometry and a list of obstacles.
struct MeshClearance {
  /// [m]: > 0 the exact distance when it is below the model's distance_cap, +inf when nothing is within the cap;
  /// <= 0 in collision: minus the deepest penetration over the colliding pairs (see the file comment; 0 when touching)
  double distance = std::numeric_limits<double>::infinity();
  int link = -1;        ///< the link attaining it (-1: nothing within the cap)
  int obstacle = -1;    ///< its obstacle's index in the list (-1: nothing within the cap)
  int exact_pairs = 0;  ///< pairs given to FCL (the others were ruled out by the lower bounds): the query's cost
  /// touching or inside, or a non-finite state (NaN distance: nothing can be said to be clear)
  bool in_collision() const { return !(distance > 0.0); }
};

/// Two of the robot's own collision geometries in contact (CheckMeshSelfCollision).
struct MeshSelfContact {
  int link = -1;        ///< the first pair found in contact (-1: none)
  int other_link = -1;
  int exact_pairs = 0;  ///< pairs given to FCL (the others' boxes were apart)
  bool in_collision() const { return link >= 0; }
};

class MeshCollisionModel;
class MeshCollisionData;

/// the smallest signed clearance of the robot at the link poses of `kinematics` (kinematics::CalcForwardKinematics
/// run on it, for the model's robot) from `obstacles` (spheres, boxes, cylinders). Throws InputError when the model
/// is not available (with its reason), when `kinematics` is not of its robot or `data` not of this model, or for a
/// point-set obstacle (naming its index).
MeshClearance CalcMeshClearance(const MeshCollisionModel& model, const kinematics::Data& kinematics,
                                std::span<const rmp::Obstacle> obstacles, MeshCollisionData* data);

/// whether the robot's collision geometries of two links it checks against each other touch at the link poses of
/// `kinematics` (see the file comment); a non-finite pose reports nothing (CalcMeshClearance counts it). Throws
/// InputError as CalcMeshClearance.
MeshSelfContact CheckMeshSelfCollision(const MeshCollisionModel& model, const kinematics::Data& kinematics,
                                       MeshCollisionData* data);

/// The collision geometry of a robot's URDF, for FCL (see the file comment).
class MeshCollisionModel {
 public:
  /// reads the <collision> elements of `robot.urdf_path` (links with only <visual> elements have no collision
  /// geometry, as in MoveIt). Missing geometry is not an error here: the model is then unavailable and
  /// unavailable_reason() says why — no URDF, no <collision> element, a mesh not found (with the places looked at) or
  /// unreadable, rmpmarl built without assimp. Throws InputError for a distance_cap that is not > 0, or a URDF that
  /// does not parse.
  MeshCollisionModel(const kinematics::Robot& robot, const MeshCollisionOptions& options = {});
  ~MeshCollisionModel();
  MeshCollisionModel(const MeshCollisionModel&);
  MeshCollisionModel& operator=(const MeshCollisionModel&);

  /// true when every <collision> element of every link was read: the model covers the robot as its URDF says.
  bool available() const;
  /// why the model is not available ("" when it is).
  const std::string& unavailable_reason() const;
  /// true when the URDF has <collision> geometry that could not be read (a mesh not found or unreadable), as opposed to
  /// a URDF without any: the robot is then not what its URDF says, and a caller should not judge it on less.
  bool geometry_missing() const;
  /// one line on what the model holds, e.g. "11 collision meshes (9530 triangles) on 11 links of panda.urdf".
  std::string Summary() const;
  const MeshCollisionOptions& options() const;
  /// the number of collision geometries read (one per <collision> element that was read).
  int num_geometries() const;
  /// the link of geometry g.
  int geometry_link(int g) const;
  /// the link count of the robot's kinematic model (the size CalcMeshClearance expects of Data::X_WL).
  int num_links() const;
  /// the name of link `link` of the robot's kinematic model.
  const std::string& link_name(int link) const;

 private:
  friend class MeshCollisionData;
  friend MeshClearance CalcMeshClearance(const MeshCollisionModel&, const kinematics::Data&,
                                         std::span<const rmp::Obstacle>, MeshCollisionData*);
  friend MeshSelfContact CheckMeshSelfCollision(const MeshCollisionModel&, const kinematics::Data&, MeshCollisionData*);
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

/// Scratch of CalcMeshClearance (the geometries' world poses and bounds), one per thread; it keeps its model's
/// geometry alive.
class MeshCollisionData {
 public:
  explicit MeshCollisionData(const MeshCollisionModel& model);
  ~MeshCollisionData();
  MeshCollisionData(MeshCollisionData&&) noexcept;
  MeshCollisionData& operator=(MeshCollisionData&&) noexcept;

 private:
  friend MeshClearance CalcMeshClearance(const MeshCollisionModel&, const kinematics::Data&,
                                         std::span<const rmp::Obstacle>, MeshCollisionData*);
  friend MeshSelfContact CheckMeshSelfCollision(const MeshCollisionModel&, const kinematics::Data&, MeshCollisionData*);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rmpmarl::experiments
