// A user's URDF seen by the page: its <visual> boxes, cylinders and meshes, the meshes served as binary files in
// the link frame; what cannot be drawn is left out with a warning.
#include "rmpmarl/viewer/visuals.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "rmpmarl/kinematics/urdf_geometry.h"
#include "rmpmarl/setup/mesh.h"
#include "rmpmarl/viewer/protocol.h"

namespace rmpmarl::viewer {
namespace {

TEST(VisualsTest, UrdfVisualsAndMeshesInTheLinkFrame) {
  const auto dir = std::filesystem::temp_directory_path() / fmt::format("rmpmarl-visuals-{}", ::getpid());
  std::filesystem::create_directories(dir / "meshes");
  std::ofstream(dir / "meshes" / "tri.stl") << "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                              "vertex 0 1 0\nendloop\nendfacet\nendsolid t\n";
  std::ofstream(dir / "arm.urdf") << R"(<robot name="arm">
  <link name="base"><visual><origin xyz="0 0 0.05"/><geometry><box size="0.2 0.2 0.1"/></geometry></visual>
    <collision><geometry><cylinder radius="0.1" length="0.1"/></geometry></collision></link>
  <link name="upper"><visual><origin xyz="0 0 0.1" rpy="0 0 1.5707963267948966"/>
    <geometry><mesh filename="meshes/tri.stl" scale="2 2 2"/></geometry></visual></link>
  <link name="lower"><visual><geometry><mesh filename="meshes/missing.stl"/></geometry></visual></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><parent link="upper"/><child link="lower"/><origin xyz="0 0 0.3"/>
    <axis xyz="0 1 0"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
</robot>)";
  kinematics::Robot robot;
  robot.model = kinematics::LoadUrdfModel(dir / "arm.urdf");
  robot.urdf_path = dir / "arm.urdf";
  const RobotVisuals v = LoadRobotVisuals(robot);
  if (!setup::MeshReadingAvailable()) GTEST_SKIP() << "built without assimp";
  ASSERT_EQ(v.shapes.size(), 2u);  // the box (visual before collision) and the mesh
  EXPECT_EQ(v.shapes[0].shape.kind, kinematics::ShapeKind::kBox);
  EXPECT_EQ(v.shapes[1].shape.kind, kinematics::ShapeKind::kMesh);
  ASSERT_EQ(v.warnings.size(), 1u);
  EXPECT_NE(v.warnings[0].find("link 'lower': mesh 'meshes/missing.stl' not found"), std::string::npos);
  const std::string& body = v.files.at(v.shapes[1].mesh_url);
  std::uint32_t nv = 0, nt = 0;
  std::memcpy(&nv, body.data(), 4);
  std::memcpy(&nt, body.data() + 4, 4);
  ASSERT_EQ(nv, 3u);
  ASSERT_EQ(nt, 1u);
  ASSERT_EQ(body.size(), 8u + 3 * 12 + 12);
  // vertex (1, 0, 0) scaled by 2 and turned 90° about z, lifted 0.1: (0, 2, 0.1) in the link frame
  bool found = false;
  for (std::uint32_t i = 0; i < nv; ++i) {
    float p[3];
    std::memcpy(p, body.data() + 8 + 12 * i, 12);
    if (std::abs(p[0]) < 1e-6 && std::abs(p[1] - 2.0f) < 1e-6 && std::abs(p[2] - 0.1f) < 1e-6) found = true;
  }
  EXPECT_TRUE(found);
  HelloInfo info;
  info.visuals = v.shapes;
  const auto hello = nlohmann::json::parse(EncodeHello(robot, info));
  ASSERT_EQ(hello["robot"]["visuals"].size(), 2u);
  EXPECT_EQ(hello["robot"]["visuals"][0]["kind"], "box");
  EXPECT_NEAR(hello["robot"]["visuals"][0]["X"][2].get<double>(), 0.05, 1e-12);
  EXPECT_EQ(hello["robot"]["visuals"][1]["url"], v.shapes[1].mesh_url);
  std::filesystem::remove_all(dir);
}

TEST(VisualsTest, ShippedRobotsHaveNone) {
  const RobotVisuals v = LoadRobotVisuals(kinematics::LoadShippedRobot("panda"));
  EXPECT_TRUE(v.shapes.empty());
  EXPECT_TRUE(v.warnings.empty());
}

}  // namespace
}  // namespace rmpmarl::viewer
