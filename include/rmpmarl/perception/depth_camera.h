#pragma once
/// A simulated depth camera: MuJoCo's renderer through EGL (headless, as sim::OffscreenRenderer) draws the physical
/// geoms of a world (robot, obstacles, floor) from a pinhole camera and the depth buffer is read back as metric depth
/// along the optical axis, with an optional structured-light/stereo noise model.
///
/// Conventions (OpenCV): pixel (u, v) has u to the right and v down, integer values at pixel centres, u ∈ [0, width),
/// v ∈ [0, height), the top-left pixel is (0, 0); the optical frame C has z forward (along the optical axis), x to
/// the right and y down in the image. A point p_C = (x, y, z) with z > 0 projects to
///   u = fx x / z + cx,   v = fy y / z + cy,
/// with square pixels and the principal point at the image centre:
///   fx = fy = (height / 2) / tan(vertical_fov / 2),   cx = (width − 1) / 2,   cy = (height − 1) / 2.
#include <mujoco/mjdata.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace rmpmarl::sim {
class WorldModel;
}

namespace rmpmarl::perception {

/// Pinhole intrinsics (OpenCV convention, see the file comment): focal lengths and principal point in pixels.
struct CameraIntrinsics {
  int width = 0;    ///< [px]
  int height = 0;   ///< [px]
  double fx = 0.0;  ///< [px]
  double fy = 0.0;  ///< [px]
  double cx = 0.0;  ///< [px]
  double cy = 0.0;  ///< [px]
};

/// Depth noise of a structured-light/stereo sensor, applied to every valid pixel independently.
struct DepthNoise {
  /// axial noise: z' = z + σ(z) n with n ~ N(0, 1) and σ(z) = sigma_at_1m · z² [m] (z in metres), e.g. 0.001–0.003
  /// for a RealSense D435.
  double sigma_at_1m = 0.0;
  double dropout = 0.0;    ///< probability that a valid pixel is reported invalid (0 depth), in [0, 1)
  std::uint64_t seed = 0;  ///< noise is deterministic given the seed and the frame count of the camera
};

/// Options of a DepthCamera. Defaults are those of a RealSense D435 depth stream at a quarter of its resolution.
struct DepthCameraOptions {
  int width = 320;                 ///< [px]
  int height = 240;                ///< [px]
  double vertical_fov_deg = 58.0;  ///< full vertical field of view [deg], in (0, 180)
  /// pose of the optical frame C in world (see the file comment); default: DefaultPose().
  Eigen::Isometry3d X_WC = DefaultPose();
  double min_range = 0.1;          ///< [m] depth below → invalid (0)
  double max_range = 3.0;          ///< [m] depth above → invalid (0)
  double rate = 30.0;              ///< [Hz] frames per simulated second (the caller decides when to render)
  DepthNoise noise;

  /// the default X_WC: LookAt(p_WC = (1.2, 0, 0.9), p_WT = (0.3, 0, 0.3)), an external camera in front of a robot at
  /// the origin facing +x, looking down at its workspace.
  static Eigen::Isometry3d DefaultPose();
};

/// a camera pose X_WC at p_WC whose optical axis points at p_WT, with world +z up in the image. Throws InputError when
/// a point is not finite, the points coincide, or the axis is (nearly) vertical (the image's up is then undefined).
Eigen::Isometry3d LookAt(const Eigen::Vector3d& p_WC, const Eigen::Vector3d& p_WT);

/// One depth frame.
struct DepthImage {
  CameraIntrinsics intrinsics;
  Eigen::Isometry3d X_WC = Eigen::Isometry3d::Identity();  ///< camera pose when the frame was rendered
  /// width × height depths, row-major, top row first (index v · width + u): metres along the optical axis z
  /// (not along the ray), 0 = invalid (nothing within [min_range, max_range], or dropped out).
  std::vector<float> depth;
  double time = 0.0;  ///< simulation time of the rendered state [s]
};

/// checks every field of `options`; throws InputError naming the field, the expected and the received value.
void ValidateDepthCameraOptions(const DepthCameraOptions& options);

/// the intrinsics a camera with `options` renders with (the formulas in the file comment).
/// \pre ValidateDepthCameraOptions(options) passed.
CameraIntrinsics IntrinsicsFor(const DepthCameraOptions& options);

/// A depth camera on a world: an EGL context, a MuJoCo render context and a private copy of the world's mjModel (the
/// shared model is never modified). Not thread-safe; use it from the thread that created it.
class DepthCamera {
 public:
  /// creates the camera (after ValidateDepthCameraOptions, which throws InputError), or returns nullptr and sets
  /// `*why_not` when offscreen rendering is unavailable here.
  static std::unique_ptr<DepthCamera> Create(const sim::WorldModel& model, const DepthCameraOptions& options,
                                             std::string* why_not);
  ~DepthCamera();
  DepthCamera(const DepthCamera&) = delete;
  DepthCamera& operator=(const DepthCamera&) = delete;

  /// renders what the camera sees in `data` (a state of the model the camera was created for) into `*image`: robot,
  /// obstacles and floor, never the target marker (not a physical object) or decorations; then applies the range
  /// limits and the noise model. `image` is resized on the first call only (no allocation after that). Throws
  /// std::runtime_error when the camera's EGL context has become unusable.
  /// \pre the geom poses in `data` are current: sim::World::Reset, Step and QueryContacts leave them so; after
  /// World::SetObstaclePose or SetTargetPosition call QueryContacts() (or Step()) before rendering.
  void Render(const mjData* data, DepthImage* image);

  const CameraIntrinsics& intrinsics() const { return intrinsics_; }
  const DepthCameraOptions& options() const { return options_; }
  /// moves the camera (e.g. a wrist camera) for the next frames; throws InputError unless X_WC is a finite rigid
  /// transform.
  void set_pose(const Eigen::Isometry3d& X_WC);
  /// frames rendered so far (the noise of frame k depends on the seed and k).
  std::uint64_t frame_count() const { return frame_count_; }
  /// the GL renderer string (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)" for software rendering).
  const std::string& gl_renderer() const { return gl_renderer_; }

 private:
  DepthCamera() = default;
  void ApplyNoise(DepthImage* image);

  struct Impl;
  std::unique_ptr<Impl> impl_;
  DepthCameraOptions options_;
  CameraIntrinsics intrinsics_;
  std::string gl_renderer_;
  std::uint64_t frame_count_ = 0;
};

/// back-projects the valid pixels (depth > 0) of `image` into world-frame points, visiting every `stride`-th pixel in
/// u and v (stride ≥ 1), row by row from the top-left pixel: p_W = X_WC · ((u − cx) z / fx, (v − cy) z / fy, z).
/// Columns [0, N) of `*p_W` hold the points and N is returned. `*p_W` is resized to 3 × (number of visited pixels)
/// only when it has a different size, so repeated calls on frames of one size allocate nothing; columns from N on are
/// left unspecified. Throws InputError for stride < 1 or an image whose depth size does not match its intrinsics.
int DepthToWorldPoints(const DepthImage& image, int stride, Eigen::Matrix3Xd* p_W);

}  // namespace rmpmarl::perception
