// Offscreen MuJoCo rendering through EGL, and MP4 / PNG video output.
#include "rmpmarl/sim/render.h"

#include "rmpmarl/sim/scenario.h"

#include <GL/gl.h>
#include <fmt/format.h>
#include <mujoco/mujoco.h>
#include <zlib.h>

#include <cstdlib>
#include <algorithm>
#include <cstring>
#include <fstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/sim/gl_context.h"

namespace rmpmarl::sim {

struct OffscreenRenderer::Impl {
  std::unique_ptr<OffscreenGlContext> gl;
  mjModel* model = nullptr;  // a private copy whose offscreen buffer size matches the options
  mjvScene scene;
  mjvCamera camera;
  mjvOption option;
  mjrContext context_mj;
  bool scene_made = false;
  bool context_made = false;
};

namespace {

// colours and lighting of the renderer's private model copy (the shared physics model is never touched): obstacles in
// the paper's red, green, yellow, blue (then repeating), a red target, a light robot, a brighter headlight.
void StyleModel(mjModel* m) {
  static const float kPalette[4][3] = {{0.85f, 0.2f, 0.2f}, {0.2f, 0.7f, 0.3f}, {0.95f, 0.8f, 0.2f}, {0.2f, 0.4f, 0.9f}};
  int obstacle = 0;
  for (int g = 0; g < m->ngeom; ++g) {
    const char* name = mj_id2name(m, mjOBJ_GEOM, g);
    const std::string geom_name = name != nullptr ? name : "";
    float* rgba = m->geom_rgba + 4 * g;
    if (geom_name.rfind("scene/obstacle", 0) == 0) {
      const float* c = kPalette[obstacle++ % 4];
      rgba[0] = c[0], rgba[1] = c[1], rgba[2] = c[2], rgba[3] = 1.0f;
    } else if (geom_name.rfind("scene/target", 0) == 0) {
      rgba[0] = 1.0f, rgba[1] = 0.1f, rgba[2] = 0.1f, rgba[3] = 0.8f;
      m->geom_size[3 * g] = std::max<mjtNum>(m->geom_size[3 * g], 0.025);
    } else if (geom_name.find("/capsule") != std::string::npos) {  // robot capsules (MjcfNames::CapsuleGeom)
      rgba[0] = 0.92f, rgba[1] = 0.92f, rgba[2] = 0.95f, rgba[3] = 1.0f;
    }
  }
  m->vis.headlight.ambient[0] = m->vis.headlight.ambient[1] = m->vis.headlight.ambient[2] = 0.35f;
  m->vis.headlight.diffuse[0] = m->vis.headlight.diffuse[1] = m->vis.headlight.diffuse[2] = 0.65f;
  m->vis.headlight.specular[0] = m->vis.headlight.specular[1] = m->vis.headlight.specular[2] = 0.2f;
}

// a ground plane at z = 0 drawn into the scene (visual only: it is not part of the physics model).
void AddGround(mjvScene* scene) {
  if (scene->ngeom >= scene->maxgeom) return;
  const mjtNum size[3] = {3.0, 3.0, 0.1};
  const mjtNum pos[3] = {0.0, 0.0, -0.001};
  const mjtNum mat[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const float rgba[4] = {0.55f, 0.57f, 0.6f, 1.0f};
  mjv_initGeom(&scene->geoms[scene->ngeom++], mjGEOM_PLANE, size, pos, mat, rgba);
}

// replaces the black background with a vertical grey-blue gradient.
void PaintBackground(std::vector<std::uint8_t>* rgb, int width, int height) {
  for (int y = 0; y < height; ++y) {
    const double t = static_cast<double>(y) / height;
    const std::uint8_t r = static_cast<std::uint8_t>(200 - 60 * t), g = static_cast<std::uint8_t>(210 - 60 * t),
                       b = static_cast<std::uint8_t>(225 - 50 * t);
    std::uint8_t* row = rgb->data() + static_cast<size_t>(y) * width * 3;
    for (int x = 0; x < width; ++x) {
      std::uint8_t* p = row + 3 * x;
      if (p[0] == 0 && p[1] == 0 && p[2] == 0) p[0] = r, p[1] = g, p[2] = b;
    }
  }
}

}  // namespace

std::unique_ptr<OffscreenRenderer> OffscreenRenderer::Create(const mjModel* model, const RenderOptions& options,
                                                             std::string* why_not) {
  if (options.width <= 0 || options.height <= 0) {
    throw InputError(fmt::format("render size: expected positive width and height, got {} x {}", options.width,
                                 options.height));
  }
  std::unique_ptr<OffscreenRenderer> renderer(new OffscreenRenderer());
  renderer->options_ = options;
  renderer->impl_ = std::make_unique<Impl>();
  Impl& impl = *renderer->impl_;
  impl.gl = OffscreenGlContext::Create(why_not);
  if (!impl.gl) return nullptr;
  const char* gl_renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  renderer->gl_renderer_ = gl_renderer != nullptr ? gl_renderer : "unknown";

  impl.model = mj_copyModel(nullptr, model);
  impl.model->vis.global.offwidth = options.width;
  impl.model->vis.global.offheight = options.height;
  StyleModel(impl.model);
  mjv_defaultScene(&impl.scene);
  mjv_defaultCamera(&impl.camera);
  mjv_defaultOption(&impl.option);
  mjr_defaultContext(&impl.context_mj);
  mjv_makeScene(impl.model, &impl.scene, 12000);  // the model's geoms and a sensor's points
  impl.scene_made = true;
  mjr_makeContext(impl.model, &impl.context_mj, mjFONTSCALE_100);
  impl.context_made = true;
  mjr_setBuffer(mjFB_OFFSCREEN, &impl.context_mj);
  if (impl.context_mj.currentBuffer != mjFB_OFFSCREEN) {
    *why_not = "MuJoCo could not create an offscreen framebuffer";
    return nullptr;
  }
  impl.camera.type = mjCAMERA_FREE;
  for (int i = 0; i < 3; ++i) impl.camera.lookat[i] = options.lookat[i];
  impl.camera.distance = options.distance;
  impl.camera.azimuth = options.azimuth;
  impl.camera.elevation = options.elevation;
  impl.option.flags[mjVIS_CONTACTPOINT] = options.show_warning_contacts ? 1 : 0;
  renderer->flipped_.resize(static_cast<size_t>(options.width) * options.height * 3);
  return renderer;
}

OffscreenRenderer::~OffscreenRenderer() {
  if (!impl_) return;
  if (impl_->gl) impl_->gl->MakeCurrent();  // MuJoCo's GL objects are freed in their context
  if (impl_->context_made) mjr_freeContext(&impl_->context_mj);
  if (impl_->scene_made) mjv_freeScene(&impl_->scene);
  if (impl_->model != nullptr) mj_deleteModel(impl_->model);
  impl_->gl.reset();  // the display stays (OffscreenGlContext)
}

void OffscreenRenderer::Render(const mjData* data, std::vector<std::uint8_t>* rgb, const Eigen::Matrix3Xd* points,
                               double point_radius) {
  Impl& impl = *impl_;
  impl.gl->MakeCurrent();
  const mjrRect viewport{0, 0, options_.width, options_.height};
  // mjv_updateScene takes a non-const mjData (it may write warnings); the state itself is not modified.
  mjv_updateScene(impl.model, const_cast<mjData*>(data), &impl.option, nullptr, &impl.camera, mjCAT_ALL, &impl.scene);
  if (options_.draw_ground) AddGround(&impl.scene);
  if (points != nullptr) {
    const mjtNum size[3] = {point_radius, point_radius, point_radius};
    const mjtNum mat[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const float rgba[4] = {0.1f, 0.85f, 0.95f, 1.0f};
    for (long i = 0; i < points->cols() && impl.scene.ngeom < impl.scene.maxgeom; ++i) {
      const mjtNum pos[3] = {(*points)(0, i), (*points)(1, i), (*points)(2, i)};
      mjv_initGeom(&impl.scene.geoms[impl.scene.ngeom++], mjGEOM_BOX, size, pos, mat, rgba);
    }
  }
  mjr_render(viewport, &impl.scene, &impl.context_mj);
  mjr_readPixels(flipped_.data(), nullptr, viewport, &impl.context_mj);
  rgb->resize(flipped_.size());
  const size_t row = static_cast<size_t>(options_.width) * 3;
  for (int y = 0; y < options_.height; ++y) {  // OpenGL reads bottom row first
    std::memcpy(rgb->data() + y * row, flipped_.data() + (options_.height - 1 - y) * row, row);
  }
  PaintBackground(rgb, options_.width, options_.height);
}

bool FfmpegAvailable() { return std::system("command -v ffmpeg >/dev/null 2>&1") == 0; }

VideoWriter::VideoWriter(const std::filesystem::path& path, int width, int height, double fps)
    : path_(path), width_(width), height_(height) {
  if (width <= 0 || height <= 0 || width % 2 != 0 || height % 2 != 0 || !(fps > 0.0)) {
    throw InputError(fmt::format("video: expected even positive width/height and fps > 0, got {} x {} at {} fps",
                                 width, height, fps));
  }
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  if (FfmpegAvailable()) {
    const std::string command = fmt::format(
        "ffmpeg -loglevel error -y -f rawvideo -pix_fmt rgb24 -s {}x{} -r {} -i - -c:v libx264 -preset veryfast "
        "-crf 23 -pix_fmt yuv420p -movflags +faststart '{}'",
        width, height, fps, path.string());
    pipe_ = popen(command.c_str(), "w");
  }
  if (pipe_ == nullptr) {
    frames_dir_ = path.parent_path() / (path.stem().string() + "_frames");
    std::filesystem::create_directories(frames_dir_);
  }
}

VideoWriter::~VideoWriter() {
  if (!closed_) Close();
}

void VideoWriter::AddFrame(const std::vector<std::uint8_t>& rgb) {
  RMPMARL_ASSERT(rgb.size() == static_cast<size_t>(width_) * height_ * 3, "frame has the wrong size");
  if (pipe_ != nullptr) {
    std::fwrite(rgb.data(), 1, rgb.size(), pipe_);
  } else {
    WritePng(frames_dir_ / fmt::format("{:05d}.png", frames_), rgb, width_, height_);
  }
  ++frames_;
}

std::filesystem::path VideoWriter::Close() {
  closed_ = true;
  if (pipe_ != nullptr) {
    const int status = pclose(pipe_);
    pipe_ = nullptr;
    if (status != 0) throw InputError(fmt::format("ffmpeg failed writing '{}' (status {})", path_.string(), status));
    return path_;
  }
  return frames_dir_;
}

namespace {

// appends a big-endian 32-bit integer.
void PutU32(std::string* out, std::uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<char>((v >> shift) & 0xff));
}

// appends a PNG chunk: length, type, data, CRC over type + data (PNG spec §5.3).
void PutChunk(std::string* out, const char* type, const std::string& data) {
  PutU32(out, static_cast<std::uint32_t>(data.size()));
  const std::string body = std::string(type, 4) + data;
  out->append(body);
  PutU32(out, static_cast<std::uint32_t>(crc32(0L, reinterpret_cast<const Bytef*>(body.data()), body.size())));
}

}  // namespace

void WritePng(const std::filesystem::path& path, const std::vector<std::uint8_t>& rgb, int width, int height) {
  RMPMARL_ASSERT(rgb.size() == static_cast<size_t>(width) * height * 3, "image has the wrong size");
  std::string raw;  // each row: filter byte 0 (None) + RGB bytes
  raw.reserve(static_cast<size_t>(height) * (width * 3 + 1));
  for (int y = 0; y < height; ++y) {
    raw.push_back(0);
    raw.append(reinterpret_cast<const char*>(rgb.data()) + static_cast<size_t>(y) * width * 3, width * 3);
  }
  uLongf compressed_size = compressBound(raw.size());
  std::string compressed(compressed_size, '\0');
  compress2(reinterpret_cast<Bytef*>(compressed.data()), &compressed_size,
            reinterpret_cast<const Bytef*>(raw.data()), raw.size(), 6);
  compressed.resize(compressed_size);
  std::string png("\x89PNG\r\n\x1a\n", 8);
  std::string header;
  PutU32(&header, width);
  PutU32(&header, height);
  header += std::string("\x08\x02\x00\x00\x00", 5);  // 8-bit depth, colour type 2 (RGB), deflate, no filter/interlace
  PutChunk(&png, "IHDR", header);
  PutChunk(&png, "IDAT", compressed);
  PutChunk(&png, "IEND", "");
  std::ofstream file(path, std::ios::binary);
  if (!file) throw InputError(fmt::format("{}: cannot write PNG", path.string()));
  file.write(png.data(), static_cast<std::streamsize>(png.size()));
}

RenderOptions CameraForWorkspace(const Workspace& ws, int width, int height) {
  RenderOptions options;
  options.width = width;
  options.height = height;
  options.lookat = 0.5 * (ws.box.center() + Eigen::Vector3d(0.0, 0.0, ws.p_WS.z()));
  if (ws.planar) options.lookat.z() = ws.box.center().z();
  options.distance = 1.9 * std::max(ws.reach, 0.4);
  options.draw_ground = !ws.planar;
  // MuJoCo's azimuth is the camera heading in degrees; look along `front` from a point front-left of the robot
  const double front_deg = std::atan2(ws.front.y(), ws.front.x()) * 180.0 / M_PI;
  options.azimuth = front_deg + 180.0 - 40.0;
  options.elevation = ws.planar ? -70.0 : -20.0;
  return options;
}

}  // namespace rmpmarl::sim
