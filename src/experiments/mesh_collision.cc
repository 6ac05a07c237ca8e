// The robot's collision meshes against a scene's primitives with FCL: the model read from the URDF's <collision>
// elements, and the clearance query with its lower bounds (experiments/mesh_collision.h).
#include "rmpmarl/experiments/mesh_collision.h"

#include <fcl/geometry/bvh/BVH_model.h>
#include <fcl/geometry/shape/box.h>
#include <fcl/geometry/shape/cylinder.h>
#include <fcl/geometry/shape/sphere.h>
#include <fcl/math/bv/OBBRSS.h>
#include <fcl/narrowphase/collision.h>
#include <fcl/narrowphase/distance.h>
#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <string_view>
#include <fstream>
#include <map>
#include <sstream>
#include <utility>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/urdf_geometry.h"
#include "rmpmarl/setup/mesh.h"

namespace rmpmarl::experiments {
namespace fs = std::filesystem;

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
// contacts FCL reports of one colliding pair at most (their deepest gives the penetration depth)
constexpr std::size_t kMaxContacts = 1000;

using Mesh = fcl::BVHModel<fcl::OBBRSSd>;

// an axis-aligned box in W: centre and half sizes
struct WorldBox {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half = Eigen::Vector3d::Zero();
};

// the distance between two axis-aligned boxes (0 when they overlap): a lower bound on their contents' distance
double BoxBoxDistance(const WorldBox& a, const WorldBox& b) {
  return ((a.centre - b.centre).cwiseAbs() - a.half - b.half).cwiseMax(0.0).norm();
}

// the box of `half` half sizes about the origin of frame F, posed at X_WF, bounded in W
WorldBox BoundBox(const Eigen::Isometry3d& X_WF, const Eigen::Vector3d& p_FC, const Eigen::Vector3d& half) {
  return {X_WF * p_FC, X_WF.linear().cwiseAbs() * half};
}

// the obstacle's signed distance at p_W (1-Lipschitz: less a sphere's radius it bounds the sphere's distance below)
double ObstacleSignedDistance(const rmp::Obstacle& o, const Eigen::Vector3d& p_W) {
  switch (o.shape) {
    case rmp::ObstacleShape::kSphere: return (p_W - o.sphere.p_WC).norm() - o.sphere.radius;
    case rmp::ObstacleShape::kBox: {
      const Eigen::Vector3d q = (o.box.X_WB.inverse() * p_W).cwiseAbs() - o.box.half_size;
      return q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0);
    }
    case rmp::ObstacleShape::kCylinder: return math::CylinderSignedDistance(o.cylinder, p_W);
    case rmp::ObstacleShape::kPoints: break;
  }
  return -kInf;
}

// the obstacle's box in W
WorldBox ObstacleBox(const rmp::Obstacle& o) {
  switch (o.shape) {
    case rmp::ObstacleShape::kSphere: return {o.sphere.p_WC, Eigen::Vector3d::Constant(o.sphere.radius)};
    case rmp::ObstacleShape::kBox: return BoundBox(o.box.X_WB, Eigen::Vector3d::Zero(), o.box.half_size);
    case rmp::ObstacleShape::kCylinder:
      return BoundBox(o.cylinder.X_WC, Eigen::Vector3d::Zero(),
                      Eigen::Vector3d(o.cylinder.radius, o.cylinder.radius, o.cylinder.half_length));
    case rmp::ObstacleShape::kPoints: break;
  }
  return {};
}

// the obstacle as an FCL shape (on the stack: FCL's queries take geometry by pointer) and its pose in W
struct ObstacleShape {
  explicit ObstacleShape(const rmp::Obstacle& o)
      : sphere(o.shape == rmp::ObstacleShape::kSphere ? o.sphere.radius : 1.0),
        box(o.shape == rmp::ObstacleShape::kBox ? Eigen::Vector3d(2.0 * o.box.half_size) : Eigen::Vector3d::Ones()),
        cylinder(o.shape == rmp::ObstacleShape::kCylinder ? o.cylinder.radius : 1.0,
                 o.shape == rmp::ObstacleShape::kCylinder ? 2.0 * o.cylinder.half_length : 1.0) {
    switch (o.shape) {
      case rmp::ObstacleShape::kSphere:
        geometry = &sphere;
        X_WO.setIdentity();
        X_WO.translation() = o.sphere.p_WC;
        break;
      case rmp::ObstacleShape::kBox:
        geometry = &box;
        X_WO = o.box.X_WB;
        break;
      case rmp::ObstacleShape::kCylinder:
        geometry = &cylinder;
        X_WO = o.cylinder.X_WC;
        break;
      case rmp::ObstacleShape::kPoints: break;
    }
  }
  fcl::Sphered sphere;
  fcl::Boxd box;
  fcl::Cylinderd cylinder;
  const fcl::CollisionGeometryd* geometry = nullptr;
  Eigen::Isometry3d X_WO = Eigen::Isometry3d::Identity();
};

std::string ReadText(const fs::path& path) {
  std::ifstream in(path);
  if (!in) return {};
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace

struct MeshCollisionModel::Impl {
  // one <collision> element: its FCL geometry (meshes shared between elements of the same file and scale), its
  // link, its pose X_LG and its bounding box in G (centre, half sizes)
  struct Geometry {
    std::shared_ptr<const fcl::CollisionGeometryd> fcl;
    std::shared_ptr<const Eigen::Matrix3Xd> p_GV;  // a mesh's vertices in G (null for a primitive)
    int link = -1;
    Eigen::Isometry3d X_LG = Eigen::Isometry3d::Identity();
    Eigen::Vector3d p_GC = Eigen::Vector3d::Zero();
    Eigen::Vector3d half = Eigen::Vector3d::Zero();
  };
  // reads the <collision> elements of robot.urdf_path into `geometries`, or leaves none and says why in
  // unavailable_reason
  void Read(const kinematics::Robot& robot);

  MeshCollisionOptions options;
  std::vector<Geometry> geometries;
  std::vector<std::string> link_names;
  // the geometry pairs of two links the robot checks against each other (distinct, not excluded)
  std::vector<std::pair<int, int>> self_pairs;
  std::string unavailable_reason;
  bool geometry_missing = false;  // the URDF has <collision> geometry that could not be read
  std::string summary;
};

struct MeshCollisionData::Impl {
  // a pair that the lower bounds do not rule out: geometry g, obstacle k, and the bound
  struct Candidate {
    double bound = 0.0;
    int geometry = 0, obstacle = 0;
  };
  std::shared_ptr<const MeshCollisionModel::Impl> model;
  std::vector<Eigen::Isometry3d> X_WG;           // per geometry
  std::vector<WorldBox> geometry_box;            // per geometry, in W
  std::vector<Eigen::Vector4d> geometry_sphere;  // per geometry: bounding sphere (centre, radius) in W
  std::vector<Candidate> candidates;             // the pairs within the cap, nearest bound first
  // the geometries' world poses, boxes and spheres at the link poses of `kinematics`; the link of the first
  // non-finite pose (-1: all finite)
  int Pose(const kinematics::Data& kinematics);
  // the scratch of `data` for a query `who` of `model` at `kinematics`, after checking them (InputError: the model
  // unavailable, link poses of another robot, data of another model)
  static Impl& Checked(std::string_view who, const MeshCollisionModel& model, const kinematics::Data& kinematics,
                       MeshCollisionData* data);
};

namespace {

// the depth of a colliding geometry (posed at X_WG) in an obstacle, from FCL's contacts `r`: the deepest contact's —
// FCL 0.7 gives a sphere–triangle depth negated (sphereTriangleIntersect), the others positive, so the magnitude — and
// for a mesh in a box or cylinder the deepest vertex's (minus the primitive's signed distance there), the contacts'
// bounded by the primitive's smallest half size: nothing lies deeper in it, and libccd's EPA depth of a triangle
// across a board can be metres off
// (p_GV: a mesh's vertices, null for a URDF primitive)
double PenetrationDepth(const Eigen::Matrix3Xd* p_GV, const Eigen::Isometry3d& X_WG, const rmp::Obstacle& o,
                        const fcl::CollisionResultd& r) {
  double depth = 0.0;
  for (size_t c = 0; c < r.numContacts(); ++c) depth = std::max(depth, std::abs(r.getContact(c).penetration_depth));
  if (p_GV == nullptr || o.shape == rmp::ObstacleShape::kSphere) return depth;
  depth = std::min(depth, o.shape == rmp::ObstacleShape::kBox ? o.box.half_size.minCoeff()
                                                              : std::min(o.cylinder.radius, o.cylinder.half_length));
  for (Eigen::Index v = 0; v < p_GV->cols(); ++v) {
    depth = std::max(depth, -ObstacleSignedDistance(o, X_WG * Eigen::Vector3d(p_GV->col(v))));
  }
  return depth;
}

}  // namespace

MeshCollisionModel::MeshCollisionModel(const kinematics::Robot& robot, const MeshCollisionOptions& options) {
  if (!(options.distance_cap > 0.0) || std::isnan(options.distance_cap)) {
    throw InputError(fmt::format("MeshCollisionOptions.distance_cap: expected a distance > 0 m, got {}",
                                 options.distance_cap));
  }
  auto impl = std::make_shared<Impl>();
  impl->options = options;
  for (const kinematics::Link& link : robot.model.links()) impl->link_names.push_back(link.name);
  impl->Read(robot);
  const int n = static_cast<int>(impl->geometries.size());
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const int la = impl->geometries[a].link, lb = impl->geometries[b].link;
      if (la != lb && !robot.IsExcludedPair(la, lb)) impl->self_pairs.emplace_back(a, b);
    }
  }
  impl_ = impl;
}

void MeshCollisionModel::Impl::Read(const kinematics::Robot& robot) {
  const std::string urdf = robot.urdf_path.filename().string();
  auto unavailable = [this](std::string why) {
    unavailable_reason = std::move(why);
    geometries.clear();
  };
  if (robot.urdf_path.empty()) return unavailable(fmt::format("robot '{}' has no URDF file", robot.name));
  const std::string xml = ReadText(robot.urdf_path);
  if (xml.empty()) return unavailable(fmt::format("cannot read the URDF '{}'", robot.urdf_path.string()));
  const std::vector<kinematics::LinkShape> shapes =
      kinematics::ParseUrdfShapes(xml, robot.model, robot.urdf_path.string());
  // the meshes read, by file and scale: their BVH and their vertices
  std::map<std::pair<std::string, std::vector<double>>,
           std::pair<std::shared_ptr<const Mesh>, std::shared_ptr<const Eigen::Matrix3Xd>>> meshes;
  int num_meshes = 0, num_primitives = 0;
  std::size_t triangles = 0;
  std::vector<int> links;
  for (const kinematics::LinkShape& shape : shapes) {
    if (shape.visual) continue;  // a link without <collision>: nothing of it collides
    const std::string& link = link_names[shape.link];
    Geometry g;
    g.link = shape.link;
    g.X_LG = shape.X_LG;
    switch (shape.kind) {
      case kinematics::ShapeKind::kSphere:
        g.fcl = std::make_shared<fcl::Sphered>(shape.radius);
        g.half = Eigen::Vector3d::Constant(shape.radius);
        break;
      case kinematics::ShapeKind::kBox:
        g.fcl = std::make_shared<fcl::Boxd>(shape.size);
        g.half = 0.5 * shape.size;
        break;
      case kinematics::ShapeKind::kCylinder:
        g.fcl = std::make_shared<fcl::Cylinderd>(shape.radius, shape.length);
        g.half = Eigen::Vector3d(shape.radius, shape.radius, 0.5 * shape.length);
        break;
      case kinematics::ShapeKind::kMesh: {
        if (!setup::MeshReadingAvailable()) {
          geometry_missing = true;
          return unavailable(fmt::format("link '{}': mesh '{}' cannot be read: rmpmarl was built without assimp", link,
                                         shape.mesh_uri));
        }
        std::string tried;
        const fs::path path = setup::ResolveMeshUri(shape.mesh_uri, robot.urdf_path, options.package_paths,
                                                         &tried);
        if (path.empty()) {
          geometry_missing = true;
          return unavailable(fmt::format("link '{}': collision mesh '{}' not found (looked in {}; give its package's "
                                         "folder with --package-path)", link, shape.mesh_uri, tried));
        }
        const auto key = std::make_pair(fs::weakly_canonical(path).string(),
                                        std::vector<double>(shape.mesh_scale.data(), shape.mesh_scale.data() + 3));
        auto& [mesh, p_GV] = meshes[key];
        if (!mesh) {
          setup::TriangleMesh read;
          try {
            read = setup::ReadMesh(path, shape.mesh_scale);
          } catch (const InputError& e) {
            geometry_missing = true;
            return unavailable(fmt::format("link '{}': {}", link, e.what()));
          }
          if (read.triangles.empty()) {
            geometry_missing = true;
            return unavailable(fmt::format("link '{}': collision mesh '{}' has no triangles", link, path.string()));
          }
          std::vector<fcl::Vector3d> vertices(read.p_M.cols());
          for (Eigen::Index i = 0; i < read.p_M.cols(); ++i) vertices[i] = read.p_M.col(i);
          std::vector<fcl::Triangle> tris;
          tris.reserve(read.triangles.size());
          for (const Eigen::Vector3i& t : read.triangles) tris.emplace_back(t[0], t[1], t[2]);
          auto bvh = std::make_shared<Mesh>();
          bvh->beginModel(static_cast<int>(tris.size()), static_cast<int>(vertices.size()));
          bvh->addSubModel(vertices, tris);
          bvh->endModel();
          bvh->computeLocalAABB();
          mesh = bvh;
          p_GV = std::make_shared<const Eigen::Matrix3Xd>(std::move(read.p_M));
          triangles += tris.size();
        }
        g.fcl = mesh;
        g.p_GV = p_GV;
        g.p_GC = 0.5 * (mesh->aabb_local.min_ + mesh->aabb_local.max_);
        g.half = 0.5 * (mesh->aabb_local.max_ - mesh->aabb_local.min_);
        ++num_meshes;
        break;
      }
    }
    if (shape.kind != kinematics::ShapeKind::kMesh) ++num_primitives;
    geometries.push_back(std::move(g));
    if (std::find(links.begin(), links.end(), shape.link) == links.end()) links.push_back(shape.link);
  }
  if (geometries.empty()) {
    return unavailable(fmt::format("'{}' has no <collision> element", urdf));
  }
  summary = fmt::format("{} collision mesh{} ({} triangles){} on {} link{} of {}", num_meshes,
                              num_meshes == 1 ? "" : "es", triangles,
                              num_primitives > 0 ? fmt::format(" and {} primitives", num_primitives) : "",
                              links.size(), links.size() == 1 ? "" : "s", urdf);
}

MeshCollisionModel::~MeshCollisionModel() = default;
MeshCollisionModel::MeshCollisionModel(const MeshCollisionModel&) = default;
MeshCollisionModel& MeshCollisionModel::operator=(const MeshCollisionModel&) = default;

bool MeshCollisionModel::available() const { return impl_->unavailable_reason.empty(); }
bool MeshCollisionModel::geometry_missing() const { return impl_->geometry_missing; }
const std::string& MeshCollisionModel::unavailable_reason() const { return impl_->unavailable_reason; }
std::string MeshCollisionModel::Summary() const {
  return available() ? impl_->summary : "no collision meshes: " + impl_->unavailable_reason;
}
const MeshCollisionOptions& MeshCollisionModel::options() const { return impl_->options; }
int MeshCollisionModel::num_geometries() const { return static_cast<int>(impl_->geometries.size()); }
int MeshCollisionModel::geometry_link(int g) const { return impl_->geometries.at(g).link; }
int MeshCollisionModel::num_links() const { return static_cast<int>(impl_->link_names.size()); }
const std::string& MeshCollisionModel::link_name(int link) const { return impl_->link_names.at(link); }

MeshCollisionData::MeshCollisionData(const MeshCollisionModel& model) : impl_(std::make_unique<Impl>()) {
  impl_->model = model.impl_;
  const size_t n = model.impl_->geometries.size();
  impl_->X_WG.resize(n);
  impl_->geometry_box.resize(n);
  impl_->geometry_sphere.resize(n);
}

MeshCollisionData::~MeshCollisionData() = default;
MeshCollisionData::MeshCollisionData(MeshCollisionData&&) noexcept = default;
MeshCollisionData& MeshCollisionData::operator=(MeshCollisionData&&) noexcept = default;

MeshCollisionData::Impl& MeshCollisionData::Impl::Checked(std::string_view who, const MeshCollisionModel& model,
                                                          const kinematics::Data& kinematics,
                                                          MeshCollisionData* data) {
  if (!model.available()) {
    throw InputError(fmt::format("{}: the mesh model is not available: {}", who, model.unavailable_reason()));
  }
  if (kinematics.X_WL.size() != model.impl_->link_names.size()) {
    throw InputError(fmt::format("{}: expected the link poses of a robot with {} links, got {}", who,
                                 model.impl_->link_names.size(), kinematics.X_WL.size()));
  }
  if (data == nullptr || data->impl_->model != model.impl_) {
    throw InputError(fmt::format("{}: expected a MeshCollisionData made for this model", who));
  }
  return *data->impl_;
}

int MeshCollisionData::Impl::Pose(const kinematics::Data& kinematics) {
  const MeshCollisionModel::Impl& m = *model;
  for (size_t g = 0; g < m.geometries.size(); ++g) {
    const MeshCollisionModel::Impl::Geometry& geometry = m.geometries[g];
    if (!kinematics.X_WL[geometry.link].matrix().allFinite()) return geometry.link;
    X_WG[g] = kinematics.X_WL[geometry.link] * geometry.X_LG;
    geometry_box[g] = BoundBox(X_WG[g], geometry.p_GC, geometry.half);
    geometry_sphere[g] << geometry_box[g].centre, geometry.half.norm();
  }
  return -1;
}

MeshSelfContact CheckMeshSelfCollision(const MeshCollisionModel& model, const kinematics::Data& kinematics,
                                       MeshCollisionData* data) {
  MeshCollisionData::Impl& d = MeshCollisionData::Impl::Checked("CheckMeshSelfCollision", model, kinematics, data);
  const MeshCollisionModel::Impl& m = *model.impl_;
  MeshSelfContact contact;
  if (d.Pose(kinematics) >= 0) return contact;
  const fcl::CollisionRequestd request;  // yes or no: one contact, no depth
  for (const auto& [a, b] : m.self_pairs) {
    if (BoxBoxDistance(d.geometry_box[a], d.geometry_box[b]) > 0.0) continue;
    ++contact.exact_pairs;
    fcl::CollisionResultd r;
    fcl::collide(m.geometries[a].fcl.get(), d.X_WG[a], m.geometries[b].fcl.get(), d.X_WG[b], request, r);
    if (r.isCollision()) {
      contact.link = m.geometries[a].link;
      contact.other_link = m.geometries[b].link;
      return contact;
    }
  }
  return contact;
}

MeshClearance CalcMeshClearance(const MeshCollisionModel& model, const kinematics::Data& kinematics,
                                std::span<const rmp::Obstacle> obstacles, MeshCollisionData* data) {
  MeshCollisionData::Impl& d = MeshCollisionData::Impl::Checked("CalcMeshClearance", model, kinematics, data);
  const MeshCollisionModel::Impl& m = *model.impl_;
  if (const int diverged = d.Pose(kinematics); diverged >= 0) {
    // a diverged state: no clearance, and counted as a collision (MeshClearance::in_collision)
    MeshClearance nan;
    nan.distance = std::numeric_limits<double>::quiet_NaN();
    nan.link = diverged;
    return nan;
  }
  // the pairs whose lower bound — the boxes' distance, and the obstacle's signed distance at the geometry's bounding
  // sphere less its radius — is below the cap, nearest first: the best distance then falls early and rules out the
  // rest
  d.candidates.clear();
  for (size_t k = 0; k < obstacles.size(); ++k) {
    const rmp::Obstacle& o = obstacles[k];
    if (o.shape == rmp::ObstacleShape::kPoints) {
      throw InputError(fmt::format("CalcMeshClearance: obstacle {}: expected a sphere, box or cylinder, got a point "
                                   "set", k));
    }
    const WorldBox box = ObstacleBox(o);
    for (size_t g = 0; g < m.geometries.size(); ++g) {
      const Eigen::Vector4d& sphere = d.geometry_sphere[g];
      const double bound = std::max(BoxBoxDistance(d.geometry_box[g], box),
                                    ObstacleSignedDistance(o, sphere.head<3>()) - sphere[3]);
      if (bound < m.options.distance_cap) d.candidates.push_back({bound, static_cast<int>(g), static_cast<int>(k)});
    }
  }
  std::sort(d.candidates.begin(), d.candidates.end(),
            [](const auto& a, const auto& b) { return a.bound < b.bound; });

  MeshClearance result;
  double best = m.options.distance_cap;  // pairs at or beyond it are not wanted
  const fcl::DistanceRequestd distance_request;  // no nearest points, no signed distance: collide() gives the depth
  const fcl::CollisionRequestd contact_request(kMaxContacts, /*enable_contact=*/true);
  for (const MeshCollisionData::Impl::Candidate& pair : d.candidates) {
    // in order of bound: once it reaches the best distance (or, with a collision found, exceeds 0) no pair is nearer
    if (best > 0.0 ? pair.bound >= best : pair.bound > 0.0) break;
    const ObstacleShape shape(obstacles[pair.obstacle]);
    const fcl::CollisionGeometryd* geometry = m.geometries[pair.geometry].fcl.get();
    const Eigen::Isometry3d& X_WG = d.X_WG[pair.geometry];
    ++result.exact_pairs;
    // overlapping bounds: FCL's collision query first — its distance query is not used in contact (for a sphere it
    // leaves the distance of an intersecting triangle unset)
    double distance = kInf;
    bool colliding = false;
    if (pair.bound <= 0.0) {
      fcl::CollisionResultd r;
      fcl::collide(geometry, X_WG, shape.geometry, shape.X_WO, contact_request, r);
      if (r.isCollision()) {
        colliding = true;
        distance = -PenetrationDepth(m.geometries[pair.geometry].p_GV.get(), X_WG, obstacles[pair.obstacle], r);
      }
    }
    if (colliding) {
      if (best <= 0.0 && !(distance < best)) continue;  // not deeper than a collision found already
    } else {
      if (best <= 0.0) continue;
      // apart: the distance, FCL's traversal pruning with the best found so far (its result's starting distance)
      fcl::DistanceResultd r;
      r.min_distance = best;
      fcl::distance(geometry, X_WG, shape.geometry, shape.X_WO, distance_request, r);
      distance = std::max(r.min_distance, 0.0);  // <= 0: a contact the collision query did not report: touching
      if (!(distance < best)) continue;
    }
    best = distance;
    result.distance = distance;
    result.link = m.geometries[pair.geometry].link;
    result.obstacle = pair.obstacle;
  }
  return result;
}

}  // namespace rmpmarl::experiments
