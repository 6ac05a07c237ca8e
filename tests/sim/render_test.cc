// Offscreen rendering through EGL and the video writers.
#include "rmpmarl/sim/render.h"

#include <gtest/gtest.h>
#include <mujoco/mujoco.h>
#include <unistd.h>

#if defined(__SANITIZE_ADDRESS__)
#include <dlfcn.h>
#include <link.h>

#include <cstring>
#endif

#include <fstream>

#include "rmpmarl/sim/mjcf.h"

namespace rmpmarl::sim {
namespace {

const char* kScene = R"(<mujoco><worldbody><light pos="0 0 3"/>
  <geom type="plane" size="2 2 .1" rgba=".8 .8 .8 1"/>
  <body pos="0 0 0.5"><joint type="hinge"/><geom type="capsule" fromto="0 0 0 0.3 0 0.3" size="0.05" rgba="1 0.5 0 1"/></body>
</worldbody></mujoco>)";

std::filesystem::path TempDir() {
  const auto dir = std::filesystem::temp_directory_path() / ("rmpmarl_render_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

#if defined(__SANITIZE_ADDRESS__)
// Mesa's EGL loads its driver (llvmpipe here) with dlopen and unloads it at exit; LeakSanitizer then reports the
// driver's own unfreed allocations as "<unknown module>", which no suppression can name. Keeping the graphics
// libraries loaded (RTLD_NODELETE, promoted with RTLD_NOLOAD) lets the report name the library, so
// fuzz/lsan.supp can suppress exactly that third-party library and nothing of ours.
void KeepGraphicsLibrariesLoaded() {
  dl_iterate_phdr(
      [](dl_phdr_info* info, size_t, void*) {
        const char* name = info->dlpi_name;
        if (name != nullptr && (std::strstr(name, "dri") || std::strstr(name, "mesa") ||
                                std::strstr(name, "gallium") || std::strstr(name, "LLVM") ||
                                std::strstr(name, "libGL") || std::strstr(name, "libgbm"))) {
          dlopen(name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
        }
        return 0;
      },
      nullptr);
}
#else
void KeepGraphicsLibrariesLoaded() {}
#endif

TEST(RenderTest, RendersTheSceneHeadlessThroughEgl) {
  const std::shared_ptr<mjModel> model = CompileMjcf(kScene, "render_test");
  mjData* data = mj_makeData(model.get());
  mj_forward(model.get(), data);
  std::string why_not;
  RenderOptions options;
  options.width = 320;
  options.height = 240;
  options.lookat = Eigen::Vector3d(0.1, 0.0, 0.6);
  options.distance = 1.2;
  auto renderer = OffscreenRenderer::Create(model.get(), options, &why_not);
  ASSERT_NE(renderer, nullptr) << "offscreen rendering unavailable: " << why_not;
  std::vector<std::uint8_t> rgb;
  renderer->Render(data, &rgb);
  KeepGraphicsLibrariesLoaded();
  ASSERT_EQ(rgb.size(), 320u * 240u * 3u);
  // the orange capsule (R high, B low) must be visible near the image centre, and the floor (grey) elsewhere
  int orange = 0, grey = 0;
  for (size_t i = 0; i < rgb.size(); i += 3) {
    if (rgb[i] > 150 && rgb[i + 2] < 80) ++orange;
    if (std::abs(rgb[i] - rgb[i + 1]) < 8 && std::abs(rgb[i + 1] - rgb[i + 2]) < 8 && rgb[i] > 60) ++grey;
  }
  EXPECT_GT(orange, 100) << "renderer " << renderer->gl_renderer();
  EXPECT_GT(grey, 5000);
  mj_deleteData(data);
}

TEST(RenderTest, PngHasSignatureHeaderAndSize) {
  const auto path = TempDir() / "frame.png";
  std::vector<std::uint8_t> rgb(4 * 2 * 3, 200);
  WritePng(path, rgb, 4, 2);
  std::ifstream file(path, std::ios::binary);
  std::string bytes((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  ASSERT_GT(bytes.size(), 33u);
  EXPECT_EQ(bytes.substr(0, 8), std::string("\x89PNG\r\n\x1a\n", 8));
  EXPECT_EQ(bytes.substr(12, 4), "IHDR");
  EXPECT_EQ(static_cast<unsigned char>(bytes[19]), 4u);  // width, big-endian
  EXPECT_EQ(static_cast<unsigned char>(bytes[23]), 2u);  // height
}

TEST(RenderTest, VideoWriterProducesAnMp4OrPngFrames) {
  const auto path = TempDir() / "clip.mp4";
  VideoWriter writer(path, 64, 48, 10.0);
  std::vector<std::uint8_t> rgb(64 * 48 * 3);
  for (int f = 0; f < 5; ++f) {
    std::fill(rgb.begin(), rgb.end(), static_cast<std::uint8_t>(40 * f));
    writer.AddFrame(rgb);
  }
  const bool mp4 = writer.writes_mp4();
  const auto written = writer.Close();
  EXPECT_EQ(writer.frames(), 5);
  if (mp4) {
    EXPECT_EQ(written, path);
    EXPECT_GT(std::filesystem::file_size(path), 100u);
  } else {
    EXPECT_TRUE(std::filesystem::exists(written / "00004.png"));
  }
}

}  // namespace
}  // namespace rmpmarl::sim
