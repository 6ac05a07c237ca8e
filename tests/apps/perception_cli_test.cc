// --perception depth and --cloud from the outside: demo, eval and experiment run their controllers on what a
// simulated depth camera or a recorded cloud shows, and refuse what cannot work with the reason.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/cloud_io.h"
#include "run_cli.h"

namespace {
namespace fs = std::filesystem;
using rmpmarl::test::RunCli;

bool NoOffscreenRendering(const rmpmarl::test::CommandResult& r) {
  return r.output.find("offscreen rendering") != std::string::npos;
}

TEST(PerceptionCliTest, DemoRunsBothControllersOnTheCameraAndDrawsItsPoints) {
  const fs::path video = fs::temp_directory_path() / "rmpmarl_perception_cli" / "depth.mp4";
  fs::remove_all(video.parent_path());
  const auto r = RunCli("demo --perception depth --scenario cluttered --seed 1 --duration 2 --width 320 --height 240 "
                        "--video " + video.string());
  if (NoOffscreenRendering(r)) GTEST_SKIP() << r.output;
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("perception: depth (one 320x240 camera at 30 Hz"), std::string::npos) << r.output;
  // a camera line for each controller: 60 frames in 2 s
  EXPECT_NE(r.output.find("camera marl-rmp-residual    60 frames"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("camera RMPflow              60 frames"), std::string::npos) << r.output;
  const fs::path learned = video.parent_path() / "depth-marl-rmp-residual.mp4";
  EXPECT_TRUE(fs::exists(learned) || fs::exists(video.parent_path() / "depth-marl-rmp-residual_frames")) << r.output;
  fs::remove_all(video.parent_path());
}

TEST(PerceptionCliTest, DemoReplaysARecordedCloud) {
  const fs::path dir = fs::temp_directory_path() / "rmpmarl_perception_cli_cloud";
  fs::remove_all(dir);
  fs::create_directories(dir);
  Eigen::Matrix3Xd box(3, 200);
  for (int i = 0; i < 200; ++i) box.col(i) = Eigen::Vector3d(0.45 + 0.001 * (i % 50), 0.2, 0.5 + 0.02 * (i / 50));
  rmpmarl::control::WritePcd(dir / "wall.pcd", box);
  const auto r = RunCli("demo --policy rmpflow --scenario static-reach --duration 1 --cloud " + (dir / "wall.pcd").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("perception: the recorded cloud"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("30 frames"), std::string::npos) << r.output;
  const auto missing = RunCli("demo --policy rmpflow --duration 1 --cloud " + (dir / "nothing.ply").string());
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("nothing.ply"), std::string::npos) << missing.output;
  fs::remove_all(dir);
}

TEST(PerceptionCliTest, WhatCannotWorkIsRefusedWithTheReason) {
  const auto bad = RunCli("demo --perception lidar");
  EXPECT_NE(bad.exit_code, 0);
  EXPECT_NE(bad.output.find("lidar"), std::string::npos) << bad.output;
  if (RunCli("eval --help").exit_code == 0) {  // built with libtorch
    const auto eval = RunCli("eval " + (rmpmarl::kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string() +
                            " --perception depth --episodes 1");
    EXPECT_EQ(eval.exit_code, 2) << eval.output;
    EXPECT_NE(eval.output.find("--as-controller"), std::string::npos) << eval.output;
  }
}

}  // namespace
