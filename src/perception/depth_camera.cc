// A simulated depth camera: MuJoCo's offscreen renderer through EGL, depth read back and made metric.
#include "rmpmarl/perception/depth_camera.h"

#include <GL/gl.h>
#include <fmt/format.h>
#include <mujoco/mujoco.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "rmpmarl/common/error.h"
#include "rmpmarl/sim/world.h"
#include "rmpmarl/sim/gl_context.h"

namespace rmpmarl::perception {

namespace {

constexpr int kMaxImageSide = 8192;  // [px] within every OpenGL implementation's renderbuffer limit
constexpr double kRigidTolerance = 1e-6;

bool IsFinite(const Eigen::Isometry3d& X) { return X.matrix().allFinite(); }

// true when X is a finite rigid transform: orthonormal rotation with determinant +1, last row (0, 0, 0, 1).
bool IsRigid(const Eigen::Isometry3d& X) {
  if (!IsFinite(X)) return false;
  const Eigen::Matrix3d R = X.linear();
  return (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < kRigidTolerance &&
         R.determinant() > 0.0 && X.matrix().row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1));
}

std::string FormatPose(const Eigen::Isometry3d& X) {
  std::string out = "[";
  for (int r = 0; r < 3; ++r) {
    out += fmt::format("{}[{}, {}, {}, {}]", r == 0 ? "" : ", ", X(r, 0), X(r, 1), X(r, 2), X(r, 3));
  }
  return out + "]";
}

void CheckPose(const Eigen::Isometry3d& X, const char* field) {
  if (!IsRigid(X)) {
    throw InputError(fmt::format("{}: expected a finite rigid transform (orthonormal rotation with determinant +1), "
                                 "got {}",
                                 field, FormatPose(X)));
  }
}

// SplitMix64 (Steele, Lea & Flood 2014) used as a counter-based generator: the draws of pixel i in frame k do not
// depend on the other pixels or on how many draws came before.
std::uint64_t Mix(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// the two 32-bit halves of a 64-bit word as uniforms in [0, 1).
inline double HighUniform(std::uint64_t h) { return static_cast<double>(h >> 32) * 0x1.0p-32; }
inline double LowUniform(std::uint64_t h) { return static_cast<double>(h & 0xffffffffULL) * 0x1.0p-32; }

// sets both (stereo) scene cameras to the pinhole camera at X_WC: OpenGL looks along `forward` with `up` up in the
// image, i.e. along optical +z with optical −y up; a symmetric frustum whose horizontal half-width MuJoCo sets to
// (width / height) · half_height, so pixels are square.
void SetGlCameras(const Eigen::Isometry3d& X_WC, double half_height, double z_near, double z_far, mjvScene* scene) {
  for (mjvGLCamera& gl : scene->camera) {
    for (int i = 0; i < 3; ++i) {
      gl.pos[i] = static_cast<float>(X_WC.translation()[i]);
      gl.forward[i] = static_cast<float>(X_WC.linear()(i, 2));
      gl.up[i] = static_cast<float>(-X_WC.linear()(i, 1));
    }
    gl.frustum_center = 0.0f;
    gl.frustum_top = static_cast<float>(half_height);
    gl.frustum_bottom = static_cast<float>(-half_height);
    gl.frustum_near = static_cast<float>(z_near);
    gl.frustum_far = static_cast<float>(z_far);
  }
}

}  // namespace

struct DepthCamera::Impl {
  std::unique_ptr<sim::OffscreenGlContext> gl;
  mjModel* model = nullptr;  // a private copy: offscreen size, no multisampling, no shadow map
  mjvScene scene;
  mjvCamera camera;
  mjvOption option;
  mjrContext context_mj;
  bool scene_made = false;
  bool context_made = false;
  std::vector<char> physical;    // per MuJoCo geom id: drawn in the depth image (robot, obstacle, floor)
  std::vector<float> raw_depth;  // OpenGL depth buffer in [0, 1], bottom row first
  double z_near = 0.0, z_far = 0.0;  // [m] clip planes of the projection

  // makes MuJoCo's render context and offscreen framebuffer in the current EGL context; false when it cannot.
  bool MakeRenderContext(int width, int height) {
    mjr_defaultContext(&context_mj);
    mjr_makeContext(model, &context_mj, mjFONTSCALE_100);
    context_made = true;
    mjr_setBuffer(mjFB_OFFSCREEN, &context_mj);
    return context_mj.currentBuffer == mjFB_OFFSCREEN && context_mj.offWidth >= width &&
           context_mj.offHeight >= height;
  }

  // makes the camera's context current. Another renderer on the same display (sim::OffscreenRenderer's destructor)
  // may have terminated the display, which destroys this context: then the display is initialised again and a new
  // EGL and render context made. Throws std::runtime_error when that fails too.
  void MakeCurrent(int width, int height) {
    if (gl->IsCurrent()) return;
    std::string error, why_not;
    if (gl->MakeCurrent(&error)) return;
    // the old context's GL objects died with it: nothing to free
    if (!gl->Remake(&why_not) || !MakeRenderContext(width, height)) {
      throw std::runtime_error(fmt::format("DepthCamera::Render: the camera's EGL context cannot be made current ({}) "
                                           "nor made again: {}",
                                           error, why_not.empty() ? "no offscreen framebuffer" : why_not));
    }
  }
};

Eigen::Isometry3d DepthCameraOptions::DefaultPose() {
  return LookAt(Eigen::Vector3d(1.2, 0.0, 0.9), Eigen::Vector3d(0.3, 0.0, 0.3));
}

Eigen::Isometry3d LookAt(const Eigen::Vector3d& p_WC, const Eigen::Vector3d& p_WT) {
  if (!p_WC.allFinite() || !p_WT.allFinite()) {
    throw InputError(fmt::format("LookAt: expected finite points, got p_WC = ({}, {}, {}), p_WT = ({}, {}, {})",
                                 p_WC.x(), p_WC.y(), p_WC.z(), p_WT.x(), p_WT.y(), p_WT.z()));
  }
  const Eigen::Vector3d d = p_WT - p_WC;
  if (d.norm() < 1e-9) {
    throw InputError(fmt::format("LookAt: expected distinct camera and target points, got both at ({}, {}, {})",
                                 p_WC.x(), p_WC.y(), p_WC.z()));
  }
  const Eigen::Vector3d z = d.normalized();
  const Eigen::Vector3d x_unnormalised = z.cross(Eigen::Vector3d::UnitZ());  // image right: forward × world up
  if (x_unnormalised.norm() < 1e-6) {
    throw InputError(fmt::format("LookAt: expected a viewing direction that is not vertical (world +z is the "
                                 "image's up), got direction ({}, {}, {})",
                                 z.x(), z.y(), z.z()));
  }
  const Eigen::Vector3d x = x_unnormalised.normalized();
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();
  X_WC.linear().col(0) = x;
  X_WC.linear().col(1) = z.cross(x);  // image down
  X_WC.linear().col(2) = z;
  X_WC.translation() = p_WC;
  return X_WC;
}

void ValidateDepthCameraOptions(const DepthCameraOptions& o) {
  auto fail = [](const char* field, const std::string& expected, const std::string& got) {
    throw InputError(fmt::format("DepthCameraOptions.{}: expected {}, got {}", field, expected, got));
  };
  const std::string size_range = fmt::format("an integer in [1, {}]", kMaxImageSide);
  if (o.width < 1 || o.width > kMaxImageSide) fail("width", size_range, fmt::format("{}", o.width));
  if (o.height < 1 || o.height > kMaxImageSide) fail("height", size_range, fmt::format("{}", o.height));
  if (!(o.vertical_fov_deg > 0.0 && o.vertical_fov_deg < 180.0)) {
    fail("vertical_fov_deg", "a value in (0, 180) degrees", fmt::format("{}", o.vertical_fov_deg));
  }
  CheckPose(o.X_WC, "DepthCameraOptions.X_WC");
  if (!(o.min_range > 0.0 && std::isfinite(o.min_range))) {
    fail("min_range", "a finite value > 0 [m]", fmt::format("{}", o.min_range));
  }
  if (!(o.max_range > o.min_range && std::isfinite(o.max_range))) {
    fail("max_range", fmt::format("a finite value > min_range = {} [m]", o.min_range), fmt::format("{}", o.max_range));
  }
  if (!(o.rate > 0.0 && std::isfinite(o.rate))) fail("rate", "a finite value > 0 [Hz]", fmt::format("{}", o.rate));
  if (!(o.noise.sigma_at_1m >= 0.0 && std::isfinite(o.noise.sigma_at_1m))) {
    fail("noise.sigma_at_1m", "a finite value >= 0 [m]", fmt::format("{}", o.noise.sigma_at_1m));
  }
  if (!(o.noise.dropout >= 0.0 && o.noise.dropout < 1.0)) {
    fail("noise.dropout", "a probability in [0, 1)", fmt::format("{}", o.noise.dropout));
  }
}

CameraIntrinsics IntrinsicsFor(const DepthCameraOptions& o) {
  CameraIntrinsics k;
  k.width = o.width;
  k.height = o.height;
  k.fy = 0.5 * o.height / std::tan(0.5 * o.vertical_fov_deg * M_PI / 180.0);
  k.fx = k.fy;
  k.cx = 0.5 * (o.width - 1);
  k.cy = 0.5 * (o.height - 1);
  return k;
}

std::unique_ptr<DepthCamera> DepthCamera::Create(const sim::WorldModel& model, const DepthCameraOptions& options,
                                                 std::string* why_not) {
  ValidateDepthCameraOptions(options);
  std::string ignored;
  if (why_not == nullptr) why_not = &ignored;
  std::unique_ptr<DepthCamera> camera(new DepthCamera());
  camera->options_ = options;
  camera->intrinsics_ = IntrinsicsFor(options);
  camera->impl_ = std::make_unique<Impl>();
  Impl& impl = *camera->impl_;
  impl.gl = sim::OffscreenGlContext::Create(why_not);
  if (!impl.gl) return nullptr;
  const char* gl_renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  camera->gl_renderer_ = gl_renderer != nullptr ? gl_renderer : "unknown";

  const mjModel* shared = model.mj_model();
  impl.model = mj_copyModel(nullptr, shared);
  impl.model->vis.global.offwidth = options.width;
  impl.model->vis.global.offheight = options.height;
  impl.model->vis.quality.offsamples = 0;  // one depth sample per pixel: no blended silhouettes
  impl.model->vis.quality.shadowsize = 0;  // no shadow map (only depth is read)
  impl.physical.assign(shared->ngeom, 0);
  // the target is not physical, nor a robot's separate self-collision cover (its geoms are numbered after the
  // capsules): a camera sees the robot's capsules
  const int num_capsules = static_cast<int>(model.robot().capsules.size());
  for (int g = 0; g < shared->ngeom; ++g) {
    const sim::GeomInfo& info = model.geom_info(g);
    impl.physical[g] = info.role != sim::GeomRole::kTarget &&
                       !(info.role == sim::GeomRole::kRobot && info.capsule >= num_capsules);
  }

  mjv_defaultScene(&impl.scene);
  mjv_defaultCamera(&impl.camera);
  mjv_defaultOption(&impl.option);
  for (int i = 0; i < mjNGROUP; ++i) impl.option.geomgroup[i] = 1;  // roles decide what is drawn, not groups
  mjv_makeScene(impl.model, &impl.scene, shared->ngeom + 8);
  impl.scene_made = true;
  // flat colours in one pass (MuJoCo's segmentation mode): no lighting, reflection, fog or transparency, and every
  // drawn geom writes depth
  for (int f = 0; f < mjNRNDFLAG; ++f) impl.scene.flags[f] = 0;
  impl.scene.flags[mjRND_SEGMENT] = 1;
  impl.scene.flags[mjRND_CULL_FACE] = 1;
  if (!impl.MakeRenderContext(options.width, options.height)) {
    *why_not = "MuJoCo could not create an offscreen framebuffer of the requested size";
    return nullptr;
  }
  // near plane well below min_range, so that an occluder closer than min_range still hides what is behind it (and
  // reads invalid); far plane beyond max_range, so that nothing within range is clipped
  impl.z_near = std::min(0.01, 0.5 * options.min_range);
  impl.z_far = 1.05 * options.max_range;
  impl.raw_depth.resize(static_cast<size_t>(options.width) * options.height);
  return camera;
}

DepthCamera::~DepthCamera() {
  if (!impl_) return;
  if (impl_->gl) impl_->gl->MakeCurrent();  // MuJoCo's GL objects are freed in their context
  if (impl_->context_made) mjr_freeContext(&impl_->context_mj);
  if (impl_->scene_made) mjv_freeScene(&impl_->scene);
  if (impl_->model != nullptr) mj_deleteModel(impl_->model);
  impl_->gl.reset();
}

void DepthCamera::set_pose(const Eigen::Isometry3d& X_WC) {
  CheckPose(X_WC, "DepthCamera::set_pose X_WC");
  options_.X_WC = X_WC;
}

void DepthCamera::Render(const mjData* data, DepthImage* image) {
  if (data == nullptr || image == nullptr) {
    throw InputError(fmt::format("DepthCamera::Render: expected non-null data and image, got data = {}, image = {}",
                                 fmt::ptr(data), fmt::ptr(image)));
  }
  Impl& impl = *impl_;
  impl.MakeCurrent(options_.width, options_.height);
  const double half_height = impl.z_near * std::tan(0.5 * options_.vertical_fov_deg * M_PI / 180.0);
  // MuJoCo re-centres infinite planes (the floor) under the scene camera while adding geoms, and then overwrites the
  // scene camera from its own camera: set the depth camera before and after
  SetGlCameras(options_.X_WC, half_height, impl.z_near, impl.z_far, &impl.scene);
  // mjv_updateScene takes a non-const mjData (it may write warnings); the state itself is not modified.
  mjv_updateScene(impl.model, const_cast<mjData*>(data), &impl.option, nullptr, &impl.camera,
                  mjCAT_STATIC | mjCAT_DYNAMIC, &impl.scene);
  SetGlCameras(options_.X_WC, half_height, impl.z_near, impl.z_far, &impl.scene);
  // keep the physical geoms only (the target marker and any decoration are dropped)
  int kept = 0;
  for (int i = 0; i < impl.scene.ngeom; ++i) {
    const mjvGeom& geom = impl.scene.geoms[i];
    if (geom.objtype != mjOBJ_GEOM || geom.objid < 0 || geom.objid >= static_cast<int>(impl.physical.size()) ||
        !impl.physical[geom.objid]) {
      continue;
    }
    impl.scene.geoms[kept] = geom;
    impl.scene.geoms[kept].segid = kept;
    impl.scene.geoms[kept].rgba[3] = 1.0f;
    ++kept;
  }
  impl.scene.ngeom = kept;
  impl.scene.enabletransform = 0;
  const int width = options_.width, height = options_.height;
  const mjrRect viewport{0, 0, width, height};
  mjr_render(viewport, &impl.scene, &impl.context_mj);
  mjr_readPixels(nullptr, impl.raw_depth.data(), viewport, &impl.context_mj);

  // window depth d ∈ [0, 1] of a perspective projection with clip planes n, f (glFrustum, glDepthRange(0, 1)) is
  //   d = (1/n − 1/z) / (1/n − 1/f)   ⇔   z = n f / (f − d (f − n)),
  // with z the depth along the optical axis; d = 1 is the cleared background (nothing drawn).
  const size_t num_pixels = static_cast<size_t>(width) * height;
  if (image->depth.size() != num_pixels) image->depth.resize(num_pixels);
  const double n = impl.z_near, f = impl.z_far;
  const double min_range = options_.min_range, max_range = options_.max_range;
  for (int v = 0; v < height; ++v) {
    const float* src = impl.raw_depth.data() + static_cast<size_t>(height - 1 - v) * width;  // bottom row first
    float* dst = image->depth.data() + static_cast<size_t>(v) * width;
    for (int u = 0; u < width; ++u) {
      const double d = src[u];
      const double z = d < 1.0 ? n * f / (f - d * (f - n)) : 0.0;
      dst[u] = (z >= min_range && z <= max_range) ? static_cast<float>(z) : 0.0f;
    }
  }
  image->intrinsics = intrinsics_;
  image->X_WC = options_.X_WC;
  image->time = data->time;
  ApplyNoise(image);
  ++frame_count_;
}

// σ(z) = sigma_at_1m z² axial noise and dropout, from a per-frame key and the pixel index: pixels 2j and 2j + 1
// share one Box–Muller pair (from the word Mix(key ^ 2j)) and one word of dropout draws (Mix(key ^ (2j + 1))).
void DepthCamera::ApplyNoise(DepthImage* image) {
  const DepthNoise& noise = options_.noise;
  const bool axial = noise.sigma_at_1m > 0.0, dropout = noise.dropout > 0.0;
  if (!axial && !dropout) return;
  const std::uint64_t key = Mix(noise.seed ^ Mix(frame_count_ ^ 0x6a09e667f3bcc909ULL));
  const float sigma_at_1m = static_cast<float>(noise.sigma_at_1m);
  float* depth = image->depth.data();
  const size_t num_pixels = image->depth.size();
  for (size_t i = 0; i < num_pixels; i += 2) {
    const bool second = i + 1 < num_pixels;
    if (depth[i] <= 0.0f && (!second || depth[i + 1] <= 0.0f)) continue;  // nothing valid to perturb
    float normal[2] = {0.0f, 0.0f};
    if (axial) {  // Box–Muller in single precision (ample for noise): two standard normals from one word
      const std::uint64_t h = Mix(key ^ i);
      const float radius = std::sqrt(-2.0f * std::log(static_cast<float>(1.0 - HighUniform(h))));  // 1 − U ∈ (0, 1]
      const float angle = static_cast<float>(2.0 * M_PI * LowUniform(h));
      normal[0] = radius * std::cos(angle);
      normal[1] = radius * std::sin(angle);
    }
    double dropout_draw[2] = {1.0, 1.0};
    if (dropout) {
      const std::uint64_t h = Mix(key ^ (i + 1));
      dropout_draw[0] = HighUniform(h);
      dropout_draw[1] = LowUniform(h);
    }
    for (size_t k = 0; k < (second ? 2u : 1u); ++k) {
      float& z = depth[i + k];
      if (z <= 0.0f) continue;
      if (dropout_draw[k] < noise.dropout) {
        z = 0.0f;
        continue;
      }
      const float noisy = z + sigma_at_1m * z * z * normal[k];
      z = noisy > 0.0f ? noisy : 0.0f;
    }
  }
}

int DepthToWorldPoints(const DepthImage& image, int stride, Eigen::Matrix3Xd* p_W) {
  const CameraIntrinsics& k = image.intrinsics;
  if (stride < 1) throw InputError(fmt::format("DepthToWorldPoints stride: expected an integer >= 1, got {}", stride));
  if (p_W == nullptr) throw InputError("DepthToWorldPoints p_W: expected an output matrix, got nullptr");
  if (k.width < 1 || k.height < 1 || image.depth.size() != static_cast<size_t>(k.width) * k.height) {
    throw InputError(fmt::format("DepthToWorldPoints image: expected {} x {} = {} depths, got {}", k.width, k.height,
                                 static_cast<long>(k.width) * k.height, image.depth.size()));
  }
  if (!(k.fx > 0.0 && k.fy > 0.0 && std::isfinite(k.cx) && std::isfinite(k.cy))) {
    throw InputError(fmt::format("DepthToWorldPoints image.intrinsics: expected fx, fy > 0 and a finite principal "
                                 "point, got fx = {}, fy = {}, cx = {}, cy = {}",
                                 k.fx, k.fy, k.cx, k.cy));
  }
  const int nu = (k.width + stride - 1) / stride, nv = (k.height + stride - 1) / stride;
  if (p_W->cols() != static_cast<Eigen::Index>(nu) * nv) p_W->resize(3, static_cast<Eigen::Index>(nu) * nv);
  const Eigen::Matrix3d R_WC = image.X_WC.linear();
  const Eigen::Vector3d p_WC = image.X_WC.translation();
  const double inv_fx = 1.0 / k.fx, inv_fy = 1.0 / k.fy;
  int count = 0;
  for (int v = 0; v < k.height; v += stride) {
    const float* row = image.depth.data() + static_cast<size_t>(v) * k.width;
    const double y_over_z = (v - k.cy) * inv_fy;
    for (int u = 0; u < k.width; u += stride) {
      const double z = row[u];
      if (!(z > 0.0)) continue;
      const Eigen::Vector3d p_C((u - k.cx) * inv_fx * z, y_over_z * z, z);
      p_W->col(count++) = R_WC * p_C + p_WC;
    }
  }
  return count;
}

}  // namespace rmpmarl::perception
