// A robot description from a URDF alone: capsules fitted to primitives and to a mesh the test writes itself (checked
// against dense sampling), package:// resolution, the missing-mesh fallback, frame-only links, deterministic
// exclusion sampling, the home posture, the YAML round trip, per-robot settings and the xacro message.
#include "rmpmarl/setup/robot_setup.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <optional>
#include <random>

#include "rmpmarl/common/error.h"
#include "rmpmarl/setup/capsule_fit.h"
#include "rmpmarl/kinematics/urdf_geometry.h"
#include "rmpmarl/setup/mesh.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "../support/temp_files.h"

namespace rmpmarl::setup {

using namespace kinematics;  // the robot description being set up: kinematics' types throughout
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return test::FreshTempDir("setup", name); }

void Write(const fs::path& path, const std::string& text) { test::WriteTextFile(path, text); }

// an ASCII STL of a box of full sizes `size` centred at `centre`, in millimetres (the URDF scales it by 0.001).
std::string BoxStlMillimetres(const Eigen::Vector3d& size, const Eigen::Vector3d& centre) {
  const Eigen::Vector3d h = 500.0 * size, c = 1000.0 * centre;
  auto v = [&](int i) {
    return Eigen::Vector3d(c.x() + (i & 1 ? h.x() : -h.x()), c.y() + (i & 2 ? h.y() : -h.y()),
                           c.z() + (i & 4 ? h.z() : -h.z()));
  };
  const int faces[6][4] = {{0, 1, 3, 2}, {4, 6, 7, 5}, {0, 4, 5, 1}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 5, 7, 3}};
  std::string out = "solid box\n";
  for (const auto& f : faces) {
    for (const auto& tri : {std::array<int, 3>{f[0], f[1], f[2]}, std::array<int, 3>{f[0], f[2], f[3]}}) {
      out += " facet normal 0 0 0\n  outer loop\n";
      for (int i : tri) out += fmt::format("   vertex {} {} {}\n", v(i).x(), v(i).y(), v(i).z());
      out += "  endloop\n endfacet\n";
    }
  }
  return out + "endsolid box\n";
}

// a vendor-style arm: root `world`, primitives, a package:// mesh, a <visual>-only link and frame-only tool links.
std::string ArmUrdf(const std::string& mesh_uri) {
  return fmt::format(R"(<?xml version="1.0"?>
<robot name="vendor_arm">
  <link name="world"/>
  <link name="base_link"><collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.08" length="0.1"/></geometry></collision></link>
  <link name="link1"><collision><origin xyz="0 0 0.1"/><geometry><box size="0.12 0.12 0.2"/></geometry></collision></link>
  <link name="link2"><collision><origin xyz="0 0 0" rpy="0 0 0.3"/><geometry><mesh filename="{}" scale="0.001 0.001 0.001"/></geometry></collision></link>
  <link name="link3"><visual><origin xyz="0 0 0.125"/><geometry><cylinder radius="0.04" length="0.25"/></geometry></visual></link>
  <link name="link4"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="flange"/>
  <link name="tool0"/>
  <joint name="world_joint" type="fixed"><parent link="world"/><child link="base_link"/></joint>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="link1"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="2" effort="10"/></joint>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="2" effort="10"/></joint>
  <joint name="j3" type="revolute"><parent link="link2"/><child link="link3"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="2.5" velocity="2" effort="10"/></joint>
  <joint name="j4" type="revolute"><parent link="link3"/><child link="link4"/><origin xyz="0 0 0.25"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="2" effort="10"/></joint>
  <joint name="f" type="fixed"><parent link="link4"/><child link="flange"/><origin xyz="0 0 0.05"/></joint>
  <joint name="t" type="fixed"><parent link="flange"/><child link="tool0"/><origin xyz="0 0 0.01"/></joint>
</robot>
)", mesh_uri);
}

const Eigen::Vector3d kMeshSize(0.08, 0.06, 0.3), kMeshCentre(0.0, 0.0, 0.15);

// writes the vendor layout <dir>/vendor_arm_description/{urdf/vendor_arm.urdf, meshes/link2.stl}.
fs::path WriteVendorArm(const fs::path& dir, const std::string& mesh_uri, bool with_mesh = true) {
  const fs::path package = dir / "vendor_arm_description";
  if (with_mesh) Write(package / "meshes" / "link2.stl", BoxStlMillimetres(kMeshSize, kMeshCentre));
  const fs::path urdf = package / "urdf" / "vendor_arm.urdf";
  Write(urdf, ArmUrdf(mesh_uri));
  return urdf;
}

// options: package path `dir` (none when empty), `samples` configurations, `seed`, optional home.
RobotSetupOptions Options(const fs::path& dir, int samples = 10000, std::uint64_t seed = 1,
                          std::optional<Eigen::VectorXd> home = std::nullopt) {
  RobotSetupOptions options;
  if (!dir.empty()) options.package_paths = {dir};
  options.samples = samples;
  options.seed = seed;
  options.home = std::move(home);
  return options;
}

const LinkFit& FitOf(const RobotSetup& setup, const std::string& link) {
  return setup.links[setup.robot.model.LinkIndex(link)];
}

TEST(RobotSetup, ReadsAMeshTheTestWroteAndFitsItTightly) {
  if (!MeshReadingAvailable()) GTEST_SKIP() << "built without assimp";
  const fs::path dir = TempDir("mesh");
  const fs::path stl = dir / "box.stl";
  Write(stl, BoxStlMillimetres(kMeshSize, kMeshCentre));
  const TriangleMesh mesh = ReadMesh(stl, Eigen::Vector3d::Constant(0.001));
  EXPECT_EQ(mesh.p_M.cols(), 8);  // identical vertices joined
  EXPECT_EQ(mesh.triangles.size(), 12u);
  EXPECT_NEAR(mesh.p_M.row(2).maxCoeff(), 0.3, 1e-9);

  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  RobotSetupOptions options = Options(dir);
  options.cover.tolerance = 0.05;  // one capsule: compared with the box's closed form below
  const RobotSetup setup = FitRobot(urdf, options);
  EXPECT_TRUE(setup.warnings.empty()) << setup.warnings.front();
  const LinkFit& fit = FitOf(setup, "link2");
  ASSERT_EQ(fit.capsules.size(), 1u);
  EXPECT_FALSE(fit.fallback);
  EXPECT_NE(fit.source.find("8 vertices"), std::string::npos) << fit.source;
  const LinkCapsule& cap = setup.robot.capsules[fit.capsules[0]];
  const math::Capsule c{cap.p_LA, cap.p_LB, cap.radius};
  // dense samples of the box faces (rotated by the <origin rpy>) all inside, and the capsule as small as the
  // closed-form cover of the same box within 1 %
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  double worst = -1.0;
  constexpr int n = 30;
  for (int axis = 0; axis < 3; ++axis) {
    for (int a = 0; a <= n; ++a) {
      for (int b = 0; b <= n; ++b) {
        for (double sign : {-0.5, 0.5}) {
          Eigen::Vector3d p;
          const int i = (axis + 1) % 3, j = (axis + 2) % 3;
          p[axis] = sign * kMeshSize[axis];
          p[i] = (a / double(n) - 0.5) * kMeshSize[i];
          p[j] = (b / double(n) - 0.5) * kMeshSize[j];
          worst = std::max(worst, CapsuleSignedDistance(c, R * (p + kMeshCentre)));
        }
      }
    }
  }
  EXPECT_LE(worst, 1e-9);
  EXPECT_GE(worst, -0.01 * cap.radius) << "not tight";
  EXPECT_LE(CapsuleVolume(c), 1.01 * CapsuleVolume(CapsuleCoveringBox(kMeshSize)));
  // the capsule's surface beside the middle of the box's wide face (3 cm from the axis) is radius − 3 cm from it
  EXPECT_GE(fit.excess, cap.radius - 0.03 - 0.002);
  EXPECT_LT(fit.excess, cap.radius);
  EXPECT_LE(fit.outside, 1e-9);
  EXPECT_TRUE(fit.within_tolerance);
  // at the default tolerance (1 cm) the same box is split until no capsule sticks out more than 1 cm, still covered
  const RobotSetup tight = FitRobot(urdf, Options(dir));
  const LinkFit& split = FitOf(tight, "link2");
  EXPECT_GT(split.capsules.size(), 1u);
  EXPECT_LT(split.excess, fit.excess);
  EXPECT_LE(split.outside, 1e-9);
  // the link's own tolerance instead of the cover's: the one capsule again, the other links as the default fit
  RobotSetupOptions own = Options(dir);
  own.link_tolerance["link2"] = 0.05;
  const RobotSetup per_link = FitRobot(urdf, own);
  EXPECT_EQ(FitOf(per_link, "link2").capsules.size(), 1u);
  EXPECT_EQ(FitOf(per_link, "link2").excess, fit.excess);
  for (const LinkFit& other : per_link.links) {
    if (per_link.robot.model.link(other.link).name == "link2") continue;
    EXPECT_EQ(other.capsules.size(), tight.links[other.link].capsules.size());
    EXPECT_EQ(other.excess, tight.links[other.link].excess);
  }
  own.link_tolerance = {{"no_such_link", 0.02}};
  try {
    FitRobot(urdf, own);
    ADD_FAILURE() << "an unknown link's tolerance was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no link named 'no_such_link'"), std::string::npos) << e.what();
  }
  own.link_tolerance = {{"link2", -1.0}};
  EXPECT_THROW(FitRobot(urdf, own), InputError);
}

TEST(RobotSetup, ReadsObjAndColladaWithItsUnitAndWithoutItsUpAxis) {
  if (!MeshReadingAvailable()) GTEST_SKIP() << "built without assimp";
  const fs::path dir = TempDir("formats");
  Write(dir / "tet.obj", "v 0 0 0\nv 0.1 0 0\nv 0 0.2 0\nv 0 0 0.3\nf 1 2 3\nf 1 2 4\nf 1 3 4\nf 2 3 4\n");
  const TriangleMesh obj = ReadMesh(dir / "tet.obj", Eigen::Vector3d(1, 2, 1));
  ASSERT_EQ(obj.p_M.cols(), 4);
  EXPECT_NEAR(obj.p_M.row(1).maxCoeff(), 0.4, 1e-6);  // y scaled by 2 (assimp reads floats)
  EXPECT_NEAR(obj.p_M.row(2).maxCoeff(), 0.3, 1e-6);
  EXPECT_EQ(obj.triangles.size(), 4u);
  // a COLLADA file in millimetres with Z up, one triangle (0,0,0) (100,0,0) (0,200,300)
  Write(dir / "tri.dae", R"(<?xml version="1.0" encoding="utf-8"?>
<COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1">
  <asset><unit name="millimeter" meter="0.001"/><up_axis>Z_UP</up_axis></asset>
  <library_geometries><geometry id="g" name="g"><mesh>
    <source id="g-pos"><float_array id="g-pos-array" count="9">0 0 0 100 0 0 0 200 300</float_array>
      <technique_common><accessor source="#g-pos-array" count="3" stride="3">
        <param name="X" type="float"/><param name="Y" type="float"/><param name="Z" type="float"/></accessor>
      </technique_common></source>
    <vertices id="g-vtx"><input semantic="POSITION" source="#g-pos"/></vertices>
    <triangles count="1"><input semantic="VERTEX" source="#g-vtx" offset="0"/><p>0 1 2</p></triangles>
  </mesh></geometry></library_geometries>
  <library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node></visual_scene>
  </library_visual_scenes>
  <scene><instance_visual_scene url="#s"/></scene>
</COLLADA>
)");
  const TriangleMesh dae = ReadMesh(dir / "tri.dae");
  ASSERT_EQ(dae.p_M.cols(), 3);
  Eigen::Vector3d hi = dae.p_M.rowwise().maxCoeff();
  EXPECT_NEAR(hi.x(), 0.1, 1e-6);
  EXPECT_NEAR(hi.y(), 0.2, 1e-6);
  EXPECT_NEAR(hi.z(), 0.3, 1e-6);
  EXPECT_THROW(ReadMesh(dir / "nothing.stl"), InputError);
}

TEST(RobotSetup, PrimitivesFrameOnlyLinksAndVisualFallback) {
  const fs::path dir = TempDir("primitives");
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  const RobotSetup setup = FitRobot(urdf, Options(dir));
  for (const char* frame : {"world", "flange", "tool0"}) {
    EXPECT_TRUE(FitOf(setup, frame).capsules.empty()) << frame;
    EXPECT_NE(FitOf(setup, frame).source.find("frame only"), std::string::npos);
  }
  EXPECT_NE(FitOf(setup, "link3").source.find("visual cylinder"), std::string::npos);
  const LinkCapsule& sphere = setup.robot.capsules[FitOf(setup, "link4").capsules[0]];
  EXPECT_DOUBLE_EQ(sphere.radius, 0.05);
  EXPECT_NEAR(FitOf(setup, "link4").excess, 0.0, 0.002);  // on its own surface, to the samples' spacing
  // the squat cylinder (r 8 cm, 10 cm long, moved 5 cm up by its <origin>): its closed-form capsule sticks out more
  // than the tolerance, so it is covered instead, no worse than the closed form
  const LinkFit& base_fit = FitOf(setup, "base_link");
  Eigen::Isometry3d X_LG = Eigen::Isometry3d::Identity();
  X_LG.translation().z() = 0.05;
  CoverGeometry cylinder;
  AppendCylinderSurface(X_LG, 0.08, 0.1, 64, false, &cylinder);
  const CapsuleCover closed = MeasureCapsuleCover(cylinder, {[&] {
                                                    math::Capsule c = CapsuleCoveringCylinder(0.08, 0.1);
                                                    c.p_WA.z() += 0.05;
                                                    c.p_WB.z() += 0.05;
                                                    return c;
                                                  }()});
  EXPECT_GT(closed.max_excess, 0.01);
  EXPECT_LE(base_fit.excess, closed.max_excess + 1e-9);
  EXPECT_LE(base_fit.outside, 1e-9);
  // a sphere keeps its closed form (itself)
  EXPECT_NE(FitOf(setup, "link4").source.find("closed form"), std::string::npos) << FitOf(setup, "link4").source;
  EXPECT_EQ(setup.robot.model.link(setup.robot.end_effector.link).name, "tool0");
}

TEST(RobotSetup, MissingMeshFallsBackToJointOriginsWithAWarningNamingTheFile) {
  const fs::path dir = TempDir("missing");
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/nowhere.stl", false);
  const RobotSetup setup = FitRobot(urdf);
  const LinkFit& fit = FitOf(setup, "link2");
  EXPECT_TRUE(fit.fallback);
  ASSERT_EQ(setup.warnings.size(), 1u);
  EXPECT_NE(setup.warnings[0].find("nowhere.stl"), std::string::npos) << setup.warnings[0];
  EXPECT_NE(setup.warnings[0].find("link2"), std::string::npos) << setup.warnings[0];
  const LinkCapsule& cap = setup.robot.capsules[fit.capsules[0]];
  // covers both joint origins (link2's own and link3's at z = 0.3) with the fallback radius
  EXPECT_LE(CapsuleSignedDistance({cap.p_LA, cap.p_LB, cap.radius}, Eigen::Vector3d::Zero()), -0.04 + 1e-9);
  EXPECT_LE(CapsuleSignedDistance({cap.p_LA, cap.p_LB, cap.radius}, Eigen::Vector3d(0, 0, 0.3)), -0.04 + 1e-9);
}

TEST(RobotSetup, PackageUrisResolveThroughPackagePathsAndTheUrdfsAncestors) {
  const fs::path dir = TempDir("resolve");
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  const fs::path expected = dir / "vendor_arm_description" / "meshes" / "link2.stl";
  EXPECT_TRUE(fs::equivalent(ResolveMeshUri("package://vendor_arm_description/meshes/link2.stl", urdf, {dir}), expected));
  // no package path: found among the URDF's ancestors (vendor layout)
  EXPECT_TRUE(fs::equivalent(ResolveMeshUri("package://vendor_arm_description/meshes/link2.stl", urdf, {}), expected));
  EXPECT_TRUE(fs::equivalent(ResolveMeshUri("../meshes/link2.stl", urdf, {}), expected));
  EXPECT_TRUE(fs::equivalent(ResolveMeshUri("file://" + expected.string(), urdf, {}), expected));
  std::string tried;
  EXPECT_TRUE(ResolveMeshUri("package://other_pkg/meshes/x.stl", urdf, {dir}, &tried).empty());
  EXPECT_NE(tried.find("other_pkg"), std::string::npos) << tried;
}

TEST(RobotSetup, ExclusionSamplingIsDeterministicForASeed) {
  const fs::path dir = TempDir("determinism");
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  const RobotSetup fit = FitRobot(urdf, Options(dir));
  RobotSetupOptions options = Options(dir, 2000, 42);
  const auto a = SampleSelfCollision(fit.robot, options);
  const auto b = SampleSelfCollision(fit.robot, options);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_FALSE(a.empty());
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a[i].contacts, b[i].contacts);
    EXPECT_EQ(a[i].min_distance, b[i].min_distance);  // bit-identical
  }
  options.seed = 43;
  const auto c = SampleSelfCollision(fit.robot, options);
  bool differs = false;
  for (size_t i = 0; i < a.size(); ++i) differs |= a[i].min_distance != c[i].min_distance;
  EXPECT_TRUE(differs);
  // the whole setup, written out, is identical for a seed
  options.seed = 42;
  EXPECT_EQ(CollisionYamlText(SetupRobot(urdf, options)), CollisionYamlText(SetupRobot(urdf, options)));
  EXPECT_EQ(SettingsYamlText(SetupRobot(urdf, options)), SettingsYamlText(SetupRobot(urdf, options)));
}

TEST(RobotSetup, ExclusionsByReason) {
  // two links welded side by side (always in contact) and a far-away link on the base (never close)
  const fs::path dir = TempDir("reasons");
  const fs::path urdf = dir / "r.urdf";
  Write(urdf, R"(<?xml version="1.0"?>
<robot name="r">
  <link name="base"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="far"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="arm"><collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.04 0.04"/></geometry></collision></link>
  <link name="frame"/>
  <link name="twin"><collision><origin xyz="0.15 0 0"/><geometry><box size="0.3 0.04 0.04"/></geometry></collision></link>
  <joint name="jf" type="fixed"><parent link="base"/><child link="far"/><origin xyz="3 0 0"/></joint>
  <joint name="j1" type="revolute"><parent link="base"/><child link="arm"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
  <joint name="jframe" type="fixed"><parent link="arm"/><child link="frame"/><origin xyz="0 0 0"/></joint>
  <joint name="jt" type="fixed"><parent link="frame"/><child link="twin"/><origin xyz="0 0.03 0"/></joint>
</robot>
)");
  const RobotSetup setup = SetupRobot(urdf, Options({}, 500));
  const Model& m = setup.robot.model;
  auto reason_of = [&](const std::string& a, const std::string& b) -> std::optional<ExclusionReason> {
    const int i = std::min(m.LinkIndex(a), m.LinkIndex(b)), j = std::max(m.LinkIndex(a), m.LinkIndex(b));
    for (const Exclusion& e : setup.exclusions) {
      if (e.link_a == i && e.link_b == j) return e.reason;
    }
    return std::nullopt;
  };
  EXPECT_EQ(reason_of("arm", "twin"), ExclusionReason::kAdjacent);  // across the frame-only link
  EXPECT_EQ(reason_of("far", "arm"), ExclusionReason::kNeverClose);
  EXPECT_EQ(reason_of("far", "twin"), ExclusionReason::kNeverClose);
  EXPECT_TRUE(setup.robot.IsExcludedPair(m.LinkIndex("arm"), m.LinkIndex("twin")));
  EXPECT_TRUE(setup.robot.IsExcludedPair(m.LinkIndex("base"), m.LinkIndex("arm")));  // parent–child
}

TEST(RobotSetup, HomeIsWithinLimitsCollisionFreeAndWellConditioned) {
  const fs::path dir = TempDir("home");
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  const RobotSetup setup = SetupRobot(urdf, Options(dir, 2000));
  const Model& m = setup.robot.model;
  ASSERT_EQ(setup.home.size(), m.nq());
  for (int i = 0; i < m.nq(); ++i) {
    EXPECT_GE(setup.home[i], m.limits()[i].lower);
    EXPECT_LE(setup.home[i], m.limits()[i].upper);
  }
  EXPECT_GE(ClosestSelfCollisionPair(setup.robot, setup.home).distance, 0.02);
  // mid-range is the straight-up singular posture of this arm
  const double straight_up = Manipulability(setup.robot, Eigen::VectorXd::Zero(m.nq()));
  EXPECT_GT(setup.home_manipulability, 1e-3);
  EXPECT_LT(straight_up, 1e-4 * setup.home_manipulability);
  EXPECT_NEAR(setup.home_manipulability, Manipulability(setup.robot, setup.home), 1e-12);
}

TEST(RobotSetup, HomeOverrideIsUsedAndChecked) {
  const fs::path dir = TempDir("home_override");
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  Eigen::VectorXd home(4);
  home << 0.1, 0.2, 0.3, 0.4;
  const RobotSetup setup = SetupRobot(urdf, Options(dir, 200, 1, home));
  EXPECT_EQ(setup.home, home);
  Eigen::VectorXd bad = home;
  bad[2] = 4.0;
  try {
    SetupRobot(urdf, Options(dir, 200, 1, bad));
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("j3"), std::string::npos) << e.what();
  }
  EXPECT_THROW(SetupRobot(urdf, Options(dir, 200, 1, Eigen::VectorXd::Zero(3))),
               InputError);
}

TEST(RobotSetup, WrittenFilesLoadAndCarryTheRobotsOwnSettings) {
  const fs::path dir = TempDir("roundtrip");
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  const RobotSetup setup = SetupRobot(urdf, Options(dir, 1000));
  const fs::path out = dir / "out";
  fs::create_directories(out);
  Write(CollisionYamlPathFor(urdf, out), CollisionYamlText(setup));
  Write(SettingsPathFor(urdf, out), SettingsYamlText(setup));
  const Robot robot = LoadRobot(urdf, CollisionYamlPathFor(urdf, out));
  EXPECT_EQ(robot.capsules.size(), setup.robot.capsules.size());
  EXPECT_EQ(robot.excluded_pairs, setup.robot.excluded_pairs);
  EXPECT_EQ(robot.end_effector.link, setup.robot.end_effector.link);
  for (size_t c = 0; c < robot.capsules.size(); ++c) {
    EXPECT_NEAR(robot.capsules[c].radius, setup.robot.capsules[c].radius, 1e-4);
    // rounded outwards? the YAML keeps 4 decimals: 0.05 mm, well inside any margin
    EXPECT_LT((robot.capsules[c].p_LA - setup.robot.capsules[c].p_LA).norm(), 1e-4);
  }
  EXPECT_FALSE(robot.shipped);
  EXPECT_EQ(robot.settings_path, SettingsPathFor(urdf, out));
  EXPECT_EQ(rmp::RmpflowConfigPath(robot), SettingsPathFor(urdf, out));
  const rmp::RmpflowOptions options = rmp::LoadRmpflowOptions(robot);
  ASSERT_EQ(options.home.size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_NEAR(options.home[i], setup.home[i], 1e-4);
}

TEST(RobotSetup, ATightCoverGetsACoarseSelfCollisionSetThatCoversTheSameGeometry) {
  if (!MeshReadingAvailable()) GTEST_SKIP() << "built without assimp";
  const fs::path dir = TempDir("self-set");
  Write(dir / "box.stl", BoxStlMillimetres(kMeshSize, kMeshCentre));
  const fs::path urdf = WriteVendorArm(dir, "package://vendor_arm_description/meshes/link2.stl");
  RobotSetupOptions options = Options(dir, 1000);
  options.cover.method = CoverMethod::kInscribed;
  options.cover.tolerance = 0.004;
  options.cover.max_capsules = 64;
  options.self_cover = CapsuleCoverOptions{};
  const RobotSetup setup = SetupRobot(urdf, options);
  const Robot& robot = setup.robot;
  const LinkFit& box = FitOf(setup, "link2");
  ASSERT_FALSE(box.self_capsules.empty());
  EXPECT_LT(box.self_capsules.size(), box.capsules.size());  // coarser: fewer capsules
  EXPECT_GT(box.self_excess, box.excess);
  for (const LinkFit& fit : setup.links) EXPECT_EQ(fit.capsules.empty(), fit.self_capsules.empty());
  // every point of the box's faces lies inside both sets' capsules of its link
  const Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  auto outside = [&](const std::vector<LinkCapsule>& capsules, const std::vector<int>& indices,
                     const Eigen::Vector3d& p) {
    double d = std::numeric_limits<double>::infinity();
    for (int c : indices) {
      d = std::min(d, CapsuleSignedDistance({capsules[c].p_LA, capsules[c].p_LB, capsules[c].radius}, p));
    }
    return d;
  };
  double worst = -1.0, worst_self = -1.0;
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> U(-0.5, 0.5);
  for (int k = 0; k < 3000; ++k) {
    const int axis = k % 3, i = (axis + 1) % 3, j = (axis + 2) % 3;
    Eigen::Vector3d p;
    p[axis] = (k % 2 ? 0.5 : -0.5) * kMeshSize[axis];
    p[i] = U(rng) * kMeshSize[i];
    p[j] = U(rng) * kMeshSize[j];
    const Eigen::Vector3d p_L = R * (p + kMeshCentre);
    worst = std::max(worst, outside(robot.capsules, box.capsules, p_L));
    worst_self = std::max(worst_self, outside(robot.self_capsules, box.self_capsules, p_L));
  }
  EXPECT_LE(worst, 1e-6);
  EXPECT_LE(worst_self, 1e-6);
  // the exclusions were sampled on the self set: its pair statistics are the robot's with the self set as capsules
  Robot coarse = robot;
  coarse.capsules = robot.self_capsules;
  coarse.self_capsules.clear();
  const std::vector<PairStatistics> a = SampleSelfCollision(robot, options), b = SampleSelfCollision(coarse, options);
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) EXPECT_EQ(a[k].min_distance, b[k].min_distance);
  // written and read back
  const fs::path out = dir / "out";
  fs::create_directories(out);
  Write(CollisionYamlPathFor(urdf, out), CollisionYamlText(setup));
  const Robot read = LoadRobot(urdf, CollisionYamlPathFor(urdf, out));
  ASSERT_EQ(read.self_capsules.size(), robot.self_capsules.size());
  for (size_t c = 0; c < read.self_capsules.size(); ++c) {
    EXPECT_EQ(read.self_capsules[c].link, robot.self_capsules[c].link);
    EXPECT_GE(read.self_capsules[c].radius, robot.self_capsules[c].radius);
    EXPECT_LT((read.self_capsules[c].p_LA - robot.self_capsules[c].p_LA).norm(), 1e-5);
  }
}

TEST(RobotSetup, AUserUrdfNamedLikeAShippedRobotDoesNotInheritItsSettings) {
  const fs::path dir = TempDir("panda_named");
  const fs::path urdf = dir / "panda.urdf";
  std::string text = ArmUrdf("package://vendor_arm_description/meshes/link2.stl");
  text.replace(text.find("vendor_arm\">"), 11, "panda\">");
  Write(urdf, text);
  const RobotSetup setup = FitRobot(urdf);
  EXPECT_EQ(setup.robot.name, "panda");
  EXPECT_EQ(rmp::RmpflowConfigPath(setup.robot).filename(), "default.yaml");
  EXPECT_EQ(rmp::RmpflowConfigPath(LoadShippedRobot("panda")).filename(), "panda.yaml");
}

TEST(RobotSetup, XacroIsRefusedWithAnExpansionHint) {
  const fs::path dir = TempDir("xacro");
  const fs::path path = dir / "arm.urdf.xacro";
  Write(path, R"(<?xml version="1.0"?>
<robot name="arm" xmlns:xacro="http://www.ros.org/wiki/xacro">
  <xacro:include filename="$(find arm_description)/urdf/arm.xacro"/>
  <xacro:arm prefix=""/>
</robot>
)");
  for (auto load : {+[](const fs::path& p) { LoadUrdfModel(p); }, +[](const fs::path& p) { FitRobot(p); }}) {
    try {
      load(path);
      FAIL() << "expected InputError";
    } catch (const InputError& e) {
      const std::string what = e.what();
      EXPECT_NE(what.find("xacro file"), std::string::npos) << what;
      EXPECT_NE(what.find("expand it with ROS's xacro first"), std::string::npos) << what;
      EXPECT_NE(what.find("arm.urdf.xacro"), std::string::npos) << what;
    }
  }
}

TEST(RobotSetup, AnExpandedUrdfKeepingTheXacroNamespaceIsPlainUrdf) {
  const Model m = ParseUrdfModel(R"(<?xml version="1.0"?>
<robot name="expanded" xmlns:xacro="http://www.ros.org/wiki/xacro"><link name="base"/></robot>)", "expanded.urdf");
  EXPECT_EQ(m.num_links(), 1);
}

TEST(RobotSetup, UrdfWithoutAnyGeometryIsRefusedClearly) {
  try {
    FitRobot(fs::path(RMPMARL_TEST_DATA_DIR) / "robots/tree/tree.urdf");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no link has <collision> or <visual> geometry"), std::string::npos);
  }
}

// a URDF with a parallel gripper and a coupled wrist (<mimic>): the tool frame is found past the coupled
// joint, the two fingers of the gripper are excluded from each other (and nothing else for being on one chain), and
// the home posture is well conditioned although the gripper's dof does not move the end effector.
TEST(RobotSetup, MimicGripperFingersAreOneGripperAndHomeIgnoresTheGripperDof) {
  const fs::path urdf = fs::path(RMPMARL_TEST_DATA_DIR) / "robots" / "mimic" / "mimic_arm.urdf";
  RobotSetupOptions options;
  options.samples = 2000;
  const RobotSetup setup = SetupRobot(urdf, options);
  const Robot& robot = setup.robot;
  const Model& m = robot.model;
  EXPECT_EQ(m.link(robot.end_effector.link).name, "tcp");
  const int left = m.LinkIndex("finger_left"), right = m.LinkIndex("finger_right");
  int gripper = 0;
  for (const Exclusion& e : setup.exclusions) {
    if (e.reason != ExclusionReason::kOneGripper) continue;
    ++gripper;
    EXPECT_EQ(std::make_pair(e.link_a, e.link_b), std::make_pair(std::min(left, right), std::max(left, right)));
  }
  EXPECT_EQ(gripper, 1);
  EXPECT_TRUE(robot.IsExcludedPair(left, right));
  EXPECT_FALSE(robot.IsExcludedPair(m.LinkIndex("link2"), m.LinkIndex("link4")));  // j3 and its follower: one arm
  EXPECT_GT(setup.home_manipulability, 1e-3);
  EXPECT_NEAR(setup.home_manipulability, Manipulability(robot, setup.home), 1e-12);
  EXPECT_GE(ClosestSelfCollisionPair(robot, setup.home).distance, 0.0);
}

}  // namespace
}  // namespace rmpmarl::setup
