#include "rmpmarl/viewer/visuals.h"

#include <fmt/format.h>

#include <cstring>
#include <fstream>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/setup/mesh.h"

namespace rmpmarl::viewer {
namespace {

template <typename T>
void Append(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));
  out->append(bytes, sizeof(T));
}

}  // namespace

RobotVisuals LoadRobotVisuals(const kinematics::Robot& robot, const VisualOptions& options) {
  RobotVisuals visuals;
  if (robot.urdf_path.empty()) return visuals;
  std::ifstream in(robot.urdf_path);
  if (!in) {
    visuals.warnings.push_back(fmt::format("{}: cannot read the URDF for its visuals", robot.urdf_path.string()));
    return visuals;
  }
  std::stringstream xml;
  xml << in.rdbuf();
  std::vector<kinematics::LinkShape> shapes;
  try {
    shapes = kinematics::ParseUrdfShapes(xml.str(), robot.model, robot.urdf_path.string(),
                                         kinematics::UrdfShapeSource::kVisualFirst);
  } catch (const InputError& e) {
    visuals.warnings.push_back(e.what());
    return visuals;
  }
  std::size_t bytes = 0;
  for (const kinematics::LinkShape& shape : shapes) {
    VisualShape v;
    v.shape = shape;
    if (shape.kind == kinematics::ShapeKind::kMesh) {
      const std::string& link = robot.model.link(shape.link).name;
      if (!setup::MeshReadingAvailable()) {
        visuals.warnings.push_back(fmt::format("link '{}': mesh '{}' left out (built without assimp)", link,
                                               shape.mesh_uri));
        continue;
      }
      const std::vector<std::filesystem::path> packages(options.package_paths.begin(), options.package_paths.end());
      const std::filesystem::path path = setup::ResolveMeshUri(shape.mesh_uri, robot.urdf_path, packages);
      if (path.empty()) {
        visuals.warnings.push_back(fmt::format("link '{}': mesh '{}' not found", link, shape.mesh_uri));
        continue;
      }
      setup::TriangleMesh mesh;
      try {
        mesh = setup::ReadMesh(path, shape.mesh_scale);
      } catch (const InputError& e) {
        visuals.warnings.push_back(fmt::format("link '{}': {}", link, e.what()));
        continue;
      }
      const std::size_t size = 8 + 12 * static_cast<std::size_t>(mesh.p_M.cols()) + 12 * mesh.triangles.size();
      if (bytes + size > options.max_bytes) {
        visuals.warnings.push_back(fmt::format("link '{}': mesh '{}' left out ({} triangles: over the {} MB of "
                                               "meshes the viewer sends)", link, shape.mesh_uri,
                                               mesh.triangles.size(), options.max_bytes >> 20));
        continue;
      }
      bytes += size;
      std::string body;
      body.reserve(size);
      Append(&body, static_cast<std::uint32_t>(mesh.p_M.cols()));
      Append(&body, static_cast<std::uint32_t>(mesh.triangles.size()));
      for (Eigen::Index c = 0; c < mesh.p_M.cols(); ++c) {
        const Eigen::Vector3d p_L = shape.X_LG * Eigen::Vector3d(mesh.p_M.col(c));
        for (int i = 0; i < 3; ++i) Append(&body, static_cast<float>(p_L[i]));
      }
      for (const Eigen::Vector3i& t : mesh.triangles) {
        for (int i = 0; i < 3; ++i) Append(&body, static_cast<std::uint32_t>(t[i]));
      }
      v.mesh_url = fmt::format("/meshes/{}.bin", visuals.files.size());
      visuals.files[v.mesh_url] = std::move(body);
    }
    visuals.shapes.push_back(std::move(v));
  }
  return visuals;
}

}  // namespace rmpmarl::viewer
