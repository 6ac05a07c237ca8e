#pragma once
/// Offscreen rendering of a world with MuJoCo's renderer through EGL (headless: Mesa's software rasteriser works
/// without a display or GPU), and video output: an MP4 through ffmpeg, or numbered PNG frames when ffmpeg is absent.
#include <mujoco/mjdata.h>
#include <mujoco/mjmodel.h>

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace rmpmarl::sim {

/// Camera and image options of the offscreen renderer.
struct RenderOptions {
  int width = 960;                                             ///< [px]
  int height = 720;                                            ///< [px]
  Eigen::Vector3d lookat = Eigen::Vector3d(0.25, 0.0, 0.45);  ///< camera target point in world [m]
  double distance = 2.2;                                       ///< camera distance from lookat [m]
  double azimuth = 140.0;                                      ///< [deg]
  double elevation = -22.0;                                    ///< [deg]
  bool show_warning_contacts = false;                          ///< draw contact points (including sensing-only ones)
  bool draw_ground = true;                                     ///< a visual-only ground plane at z = 0
};

struct Workspace;

/// a camera looking at a robot's workspace from the front-left, far enough to see the whole reach (top-down-ish for
/// a planar arm), for images of width × height.
RenderOptions CameraForWorkspace(const Workspace& workspace, int width, int height);

/// An EGL context + MuJoCo render context for one model. Not thread-safe; use from the thread that created it.
class OffscreenRenderer {
 public:
  /// creates the renderer, or returns nullptr and sets `*why_not` when offscreen rendering is unavailable here.
  static std::unique_ptr<OffscreenRenderer> Create(const mjModel* model, const RenderOptions& options,
                                                   std::string* why_not);
  ~OffscreenRenderer();
  OffscreenRenderer(const OffscreenRenderer&) = delete;
  OffscreenRenderer& operator=(const OffscreenRenderer&) = delete;

  /// renders the state in `data` into `rgb` (width × height × 3, top row first). With `points` (3 × N, world frame),
  /// also draws them as small cyan cubes of half side `point_radius` (a sensor's cloud; at most 10 000 of them).
  void Render(const mjData* data, std::vector<std::uint8_t>* rgb, const Eigen::Matrix3Xd* points = nullptr,
              double point_radius = 0.01);

  int width() const { return options_.width; }
  int height() const { return options_.height; }
  /// the GL renderer string (e.g. "llvmpipe" for software rendering).
  const std::string& gl_renderer() const { return gl_renderer_; }

 private:
  OffscreenRenderer() = default;
  struct Impl;
  std::unique_ptr<Impl> impl_;
  RenderOptions options_;
  std::string gl_renderer_;
  std::vector<std::uint8_t> flipped_;
};

/// Writes RGB frames to an MP4 (H.264 through an ffmpeg child process) or, without ffmpeg, to PNG frames in a folder.
class VideoWriter {
 public:
  /// opens `path` for frames of width × height at `fps`. If ffmpeg is missing, writes `<path stem>_frames/NNNNN.png`.
  VideoWriter(const std::filesystem::path& path, int width, int height, double fps);
  ~VideoWriter();
  VideoWriter(const VideoWriter&) = delete;
  VideoWriter& operator=(const VideoWriter&) = delete;

  /// appends one frame (width × height × 3, top row first).
  void AddFrame(const std::vector<std::uint8_t>& rgb);
  /// finishes the file; returns the path written (the MP4 or the frames folder).
  std::filesystem::path Close();
  /// true when writing an MP4 through ffmpeg, false when writing PNG frames.
  bool writes_mp4() const { return pipe_ != nullptr; }
  int frames() const { return frames_; }

 private:
  std::filesystem::path path_;
  std::filesystem::path frames_dir_;
  int width_, height_;
  FILE* pipe_ = nullptr;
  int frames_ = 0;
  bool closed_ = false;
};

/// true when an `ffmpeg` executable is on PATH.
bool FfmpegAvailable();

/// writes an 8-bit RGB PNG (zlib-compressed) of width × height pixels, top row first.
void WritePng(const std::filesystem::path& path, const std::vector<std::uint8_t>& rgb, int width, int height);

}  // namespace rmpmarl::sim
