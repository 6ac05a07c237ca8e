// Mesh files of URDF links: package:// resolution and reading with assimp (when rmpmarl is built with it).
#include <fmt/format.h>

#include <cstdlib>
#include <functional>

#include "rmpmarl/common/error.h"
#include "rmpmarl/setup/mesh.h"

#ifdef RMPMARL_HAS_ASSIMP
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#endif

namespace rmpmarl::setup {
namespace {

namespace fs = std::filesystem;

// directory called `package` at or below `root` (at most `depth` levels down), or an empty path.
fs::path FindPackageDirectory(const fs::path& root, const std::string& package, int depth) {
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return {};
  if (root.filename() == package) return root;
  if (fs::is_directory(root / package, ec)) return root / package;
  if (depth <= 0) return {};
  for (fs::directory_iterator it(root, fs::directory_options::skip_permission_denied, ec), end; !ec && it != end;
       it.increment(ec)) {
    if (!it->is_directory(ec) || it->path().filename().string().starts_with(".")) continue;
    if (fs::path found = FindPackageDirectory(it->path(), package, depth - 1); !found.empty()) return found;
  }
  return {};
}

std::vector<fs::path> RosPackagePath() {
  std::vector<fs::path> dirs;
  const char* env = std::getenv("ROS_PACKAGE_PATH");
  if (env == nullptr) return dirs;
  std::string s(env);
  size_t start = 0;
  while (start <= s.size()) {
    const size_t end = s.find(':', start);
    const std::string part = s.substr(start, end == std::string::npos ? std::string::npos : end - start);
    if (!part.empty()) dirs.emplace_back(part);
    if (end == std::string::npos) break;
    start = end + 1;
  }
  return dirs;
}

}  // namespace

fs::path ResolveMeshUri(const std::string& uri, const fs::path& urdf_path, const std::vector<fs::path>& package_paths,
                        std::string* tried) {
  std::error_code ec;
  std::vector<std::string> places;
  auto found = [&](const fs::path& p) {
    places.push_back(p.string());
    return fs::is_regular_file(p, ec);
  };
  fs::path result;
  const fs::path urdf_dir = urdf_path.has_parent_path() ? urdf_path.parent_path() : fs::path(".");
  if (uri.starts_with("package://")) {
    const std::string rest = uri.substr(10);
    const size_t slash = rest.find('/');
    const std::string package = rest.substr(0, slash);
    const fs::path relative = slash == std::string::npos ? fs::path() : fs::path(rest.substr(slash + 1));
    std::vector<fs::path> roots = package_paths;
    for (const fs::path& p : RosPackagePath()) roots.push_back(p);
    for (const fs::path& root : roots) {
      const fs::path dir = FindPackageDirectory(root, package, 3);
      if (!dir.empty() && found(dir / relative)) return dir / relative;
      if (dir.empty()) places.push_back(fmt::format("{} (no package directory '{}')", root.string(), package));
    }
    // the vendor layout: PACKAGE/urdf/robot.urdf with PACKAGE/meshes/...
    for (fs::path dir = fs::absolute(urdf_dir, ec); !dir.empty(); dir = dir.parent_path()) {
      if (dir.filename() == package && found(dir / relative)) return dir / relative;
      if (dir == dir.root_path()) break;
    }
    places.push_back(fmt::format("ancestors of {} named '{}'", urdf_dir.string(), package));
  } else if (uri.starts_with("file://")) {
    if (found(fs::path(uri.substr(7)))) return fs::path(uri.substr(7));
  } else {
    const fs::path p = fs::path(uri).is_absolute() ? fs::path(uri) : urdf_dir / uri;
    if (found(p)) return p;
  }
  if (tried != nullptr) {
    *tried = "";
    for (const std::string& p : places) *tried += (tried->empty() ? "" : ", ") + p;
    if (uri.starts_with("package://") && package_paths.empty() && RosPackagePath().empty()) {
      *tried += " (pass --package-path DIR or set ROS_PACKAGE_PATH)";
    }
  }
  return result;
}

#ifdef RMPMARL_HAS_ASSIMP

bool MeshReadingAvailable() { return true; }

TriangleMesh ReadMesh(const fs::path& path, const Eigen::Vector3d& scale) {
  Assimp::Importer importer;
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  const aiScene* scene = importer.ReadFile(path.string(), aiProcess_Triangulate | aiProcess_JoinIdenticalVertices);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    throw InputError(fmt::format("{}: cannot read mesh: {}", path.string(), importer.GetErrorString()));
  }
  TriangleMesh mesh;
  std::vector<Eigen::Vector3d> vertices;
  std::function<void(const aiNode*, const Eigen::Matrix4d&)> visit = [&](const aiNode* node, const Eigen::Matrix4d& X) {
    Eigen::Matrix4d local;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) local(r, c) = node->mTransformation[r][c];
    }
    const Eigen::Matrix4d X_node = X * local;
    for (unsigned m = 0; m < node->mNumMeshes; ++m) {
      const aiMesh* am = scene->mMeshes[node->mMeshes[m]];
      const int offset = static_cast<int>(vertices.size());
      for (unsigned v = 0; v < am->mNumVertices; ++v) {
        const Eigen::Vector4d p(am->mVertices[v].x, am->mVertices[v].y, am->mVertices[v].z, 1.0);
        vertices.push_back((X_node * p).head<3>().cwiseProduct(scale));
      }
      for (unsigned f = 0; f < am->mNumFaces; ++f) {
        const aiFace& face = am->mFaces[f];
        if (face.mNumIndices != 3) continue;
        mesh.triangles.emplace_back(offset + static_cast<int>(face.mIndices[0]),
                                    offset + static_cast<int>(face.mIndices[1]),
                                    offset + static_cast<int>(face.mIndices[2]));
      }
    }
    for (unsigned c = 0; c < node->mNumChildren; ++c) visit(node->mChildren[c], X_node);
  };
  visit(scene->mRootNode, Eigen::Matrix4d::Identity());
  if (vertices.empty()) throw InputError(fmt::format("{}: mesh has no vertices", path.string()));
  mesh.p_M.resize(3, static_cast<Eigen::Index>(vertices.size()));
  for (size_t i = 0; i < vertices.size(); ++i) mesh.p_M.col(static_cast<Eigen::Index>(i)) = vertices[i];
  if (!mesh.p_M.allFinite()) throw InputError(fmt::format("{}: mesh has non-finite vertices", path.string()));
  return mesh;
}

#else

bool MeshReadingAvailable() { return false; }

TriangleMesh ReadMesh(const fs::path& path, const Eigen::Vector3d&) {
  throw InputError(fmt::format("{}: rmpmarl was built without assimp and cannot read meshes (install libassimp-dev, "
                               "scripts/install-deps, and rebuild)", path.string()));
}

#endif

}  // namespace rmpmarl::setup
