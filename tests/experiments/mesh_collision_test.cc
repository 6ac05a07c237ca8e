// The mesh referee (experiments/mesh_collision.h): a cube mesh written to an OBJ file on a one-joint arm against
// spheres and boxes at hand-derived distances (separated, touching, penetrating, beyond the cap), URDF primitives,
// the reasons a model is unavailable, and, where MotionBenchMaker's Panda set is present, its meshes placed by forward
// kinematics against spheres set beyond the robot's extreme vertex in a direction (the distance known exactly).
#include "rmpmarl/experiments/mesh_collision.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/urdf_geometry.h"
#include "rmpmarl/setup/mesh.h"
#include "rmpmarl/sim/scenario.h"
#include "../support/temp_files.h"

namespace rmpmarl::experiments {
namespace {
namespace fs = std::filesystem;
using Eigen::Vector3d;

fs::path TempDir(const std::string& name) { return test::FreshTempDir("meshes", name); }

// a cube of side 2·half about the origin as an OBJ file (12 triangles, outward faces)
void WriteCube(const fs::path& path, double half) {
  std::ofstream obj(path);
  for (int i = 0; i < 8; ++i) {
    obj << fmt::format("v {} {} {}\n", (i & 1 ? half : -half), (i & 2 ? half : -half), (i & 4 ? half : -half));
  }
  // faces by vertex number (1-based): −x, +x, −y, +y, −z, +z, two triangles each
  obj << "f 1 5 7\nf 1 7 3\nf 2 4 8\nf 2 8 6\nf 1 2 6\nf 1 6 5\nf 3 7 8\nf 3 8 4\nf 1 3 4\nf 1 4 2\nf 5 6 8\n"
         "f 5 8 7\n";
}

// a one-joint arm: `base` and `arm` joined by a revolute joint about z at height 0.5 m; `arm` carries `collision`
// (a <collision> element's inside)
kinematics::Robot OneJointArm(const fs::path& dir, const std::string& collision) {
  const fs::path urdf = dir / "arm.urdf";
  std::ofstream(urdf) << fmt::format(R"(<?xml version="1.0"?>
<robot name="one_joint">
  <link name="base"/>
  <link name="arm">{}</link>
  <joint name="j" type="revolute">
    <parent link="base"/><child link="arm"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/>
    <limit lower="-3" upper="3" velocity="1" effort="1"/>
  </joint>
</robot>
)", collision);
  kinematics::Robot robot;
  robot.name = "one_joint";
  robot.model = kinematics::LoadUrdfModel(urdf);
  robot.urdf_path = urdf;
  return robot;
}

// the link poses at q
kinematics::Data Kinematics(const kinematics::Robot& robot, const Eigen::VectorXd& q) {
  kinematics::Data data(robot.model);
  kinematics::CalcForwardKinematics(robot.model, q, &data);
  return data;
}

// The cube (side 0.2 m) 0.3 m out along the arm: at q = π/2 its centre is at (0, 0.3, 0.5) and its +y face at
// y = 0.4. Spheres of radius 5 cm in front of that face, at a corner, touching and inside it; a box beside it.
TEST(MeshCollisionTest, ACubeMeshAgainstSpheresAndBoxesAtHandDerivedDistances) {
  if (!setup::MeshReadingAvailable()) GTEST_SKIP() << "built without assimp: meshes cannot be read";
  const fs::path dir = TempDir("cube");
  WriteCube(dir / "cube.obj", 0.1);
  const kinematics::Robot arm = OneJointArm(
      dir, R"(<collision><origin xyz="0.3 0 0"/><geometry><mesh filename="cube.obj"/></geometry></collision>)");
  const MeshCollisionModel model(arm, {.distance_cap = 0.5});
  ASSERT_TRUE(model.available()) << model.unavailable_reason();
  EXPECT_EQ(model.num_geometries(), 1);
  EXPECT_EQ(model.link_name(model.geometry_link(0)), "arm");
  EXPECT_NE(model.Summary().find("1 collision mesh (12 triangles) on 1 link of arm.urdf"), std::string::npos)
      << model.Summary();
  MeshCollisionData data(model);
  const kinematics::Data kin = Kinematics(arm, Eigen::VectorXd::Constant(1, M_PI / 2));
  const double r = 0.05;
  auto clearance = [&](const std::vector<rmp::Obstacle>& obstacles) {
    return CalcMeshClearance(model, kin, obstacles, &data);
  };
  const rmp::Obstacle far = rmp::Obstacle::MakeSphere(Vector3d(2.0, 2.0, 2.0), 0.1);

  // in front of the +y face: distance = 0.12 − r
  MeshClearance c = clearance({far, rmp::Obstacle::MakeSphere(Vector3d(0.02, 0.4 + 0.12, 0.53), r)});
  EXPECT_NEAR(c.distance, 0.07, 1e-6);
  EXPECT_EQ(c.obstacle, 1);
  EXPECT_EQ(arm.model.link(c.link).name, "arm");
  EXPECT_FALSE(c.in_collision());
  // off the corner (0.1, 0.4, 0.6) along (1, 1, 1): distance = a·√3 − r
  const double a = 0.04;
  c = clearance({rmp::Obstacle::MakeSphere(Vector3d(0.1 + a, 0.4 + a, 0.6 + a), r)});
  EXPECT_NEAR(c.distance, a * std::sqrt(3.0) - r, 1e-6);
  // a box beside the −x face (x = −0.1), 8 cm away, turned about z by 30°: its nearest corner decides. The box's
  // corner nearest the face lies at x = c_x − (h_x cos 30° + h_y sin 30°)
  Eigen::Isometry3d X_WB = Eigen::Isometry3d::Identity();
  X_WB.linear() = Eigen::AngleAxisd(M_PI / 6, Vector3d::UnitZ()).toRotationMatrix();
  const Vector3d half(0.05, 0.02, 0.05);
  const double reach = half.x() * std::cos(M_PI / 6) + half.y() * std::sin(M_PI / 6);
  X_WB.translation() = Vector3d(-0.1 - 0.08 - reach, 0.3, 0.5);
  c = clearance({rmp::Obstacle::MakeBox(X_WB, half)});
  EXPECT_NEAR(c.distance, 0.08, 1e-5);  // GJK's tolerance
  // penetrating the +y face by 2 cm: in collision, with FCL's depth (the sphere's r − its centre's distance to the
  // face)
  c = clearance({far, rmp::Obstacle::MakeSphere(Vector3d(0.0, 0.4 + 0.03, 0.5), r)});
  EXPECT_TRUE(c.in_collision());
  EXPECT_NEAR(c.distance, -0.02, 1e-3);
  EXPECT_EQ(c.obstacle, 1);
  // a box entering the −x face by 1 cm: FCL's (EPA) depth of the face's triangles in it
  c = clearance({rmp::Obstacle::MakeBox(Eigen::Isometry3d(Eigen::Translation3d(-0.1 - 0.05 + 0.01, 0.3, 0.5)),
                                        Vector3d::Constant(0.05))});
  EXPECT_TRUE(c.in_collision());
  EXPECT_NEAR(c.distance, -0.01, 1e-3);
  // a board 1 cm thick through the cube's middle: no vertex inside it, the side faces across it — the mesh is as deep
  // in it as its mid-plane, 5 mm (libccd's per-triangle depth is bounded by that)
  c = clearance({rmp::Obstacle::MakeBox(Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.3, 0.5)),
                                        Vector3d(0.3, 0.3, 0.005))});
  EXPECT_TRUE(c.in_collision());
  EXPECT_NEAR(c.distance, -0.005, 1e-9);
  // the deeper of two penetrations decides
  c = clearance({rmp::Obstacle::MakeSphere(Vector3d(0.0, 0.4 + 0.03, 0.5), r),
                 rmp::Obstacle::MakeSphere(Vector3d(0.1 + 0.01, 0.3, 0.5), r)});
  EXPECT_NEAR(c.distance, -0.04, 1e-3);
  EXPECT_EQ(c.obstacle, 1);
  // beyond the cap (0.5 m): nothing, and FCL was not asked
  c = clearance({rmp::Obstacle::MakeSphere(Vector3d(0.0, 1.2, 0.5), r)});
  EXPECT_EQ(c.distance, std::numeric_limits<double>::infinity());
  EXPECT_EQ(c.link, -1);
  EXPECT_EQ(c.obstacle, -1);
  EXPECT_EQ(c.exact_pairs, 0);
  // at q = 0 the cube is at (0.3, 0, 0.5): the same sphere in front of its +x face, 12 cm out
  const kinematics::Data zero = Kinematics(arm, Eigen::VectorXd::Zero(1));
  c = CalcMeshClearance(model, zero, std::vector{rmp::Obstacle::MakeSphere(Vector3d(0.52, 0.0, 0.5), r)}, &data);
  EXPECT_NEAR(c.distance, 0.07, 1e-6);

  // a point set is refused by name; link poses of another robot too
  rmp::Obstacle points;
  points.shape = rmp::ObstacleShape::kPoints;
  EXPECT_THROW(clearance({points}), InputError);
  const kinematics::Data other = Kinematics(kinematics::LoadShippedRobot("panda"), Eigen::VectorXd::Zero(7));
  EXPECT_THROW(CalcMeshClearance(model, other, std::vector{far}, &data), InputError);
  fs::remove_all(dir);
}

// URDF primitives (a sphere and a scaled box element) become FCL primitives, posed by their origins
TEST(MeshCollisionTest, UrdfPrimitivesArePosedByTheirOrigins) {
  const fs::path dir = TempDir("primitives");
  const kinematics::Robot arm = OneJointArm(dir, R"(
    <collision><origin xyz="0.3 0 0"/><geometry><sphere radius="0.1"/></geometry></collision>
    <collision>
      <origin xyz="0 0 0.2" rpy="0 0 0.7853981633974483"/><geometry><box size="0.2 0.2 0.1"/></geometry>
    </collision>)");
  const MeshCollisionModel model(arm);
  ASSERT_TRUE(model.available()) << model.unavailable_reason();
  EXPECT_EQ(model.num_geometries(), 2);
  MeshCollisionData data(model);
  const kinematics::Data kin = Kinematics(arm, Eigen::VectorXd::Zero(1));
  // the sphere element at (0.3, 0, 0.5): a sphere obstacle 6 cm beyond its surface
  MeshClearance c = CalcMeshClearance(
      model, kin, std::vector{rmp::Obstacle::MakeSphere(Vector3d(0.3, 0.0, 0.5 - 0.1 - 0.06 - 0.02), 0.02)}, &data);
  EXPECT_NEAR(c.distance, 0.06, 1e-5);
  // the box element at (0, 0, 0.7), turned 45° about z: its corner reaches x = 0.1·√2; a sphere 3 cm beyond it on x
  c = CalcMeshClearance(model, kin,
                        std::vector{rmp::Obstacle::MakeSphere(Vector3d(0.1 * std::sqrt(2.0) + 0.03 + 0.01, 0.0, 0.7),
                                                              0.01)},
                        &data);
  EXPECT_NEAR(c.distance, 0.03, 1e-5);
  fs::remove_all(dir);
}

// Self-collision: a cube mesh (side 0.2 m) on the base and one on the second of two joints about z, 0.3 m out along it,
// the first joint 0.45 m from the base. Folded back (q1 = π) the arm's cube is centred at x = 0.15, 5 cm into the
// base's cube (a contact, hand-derived); stretched out sideways (q1 = π/2) it is at (0.45, 0.3): apart, and their boxes
// too, so FCL is not asked; turned to 45° near the base's corner, the boxes overlap and the meshes do not. A pair the
// robot excludes is never reported.
TEST(MeshCollisionTest, SelfCollisionBetweenLinksTheRobotChecks) {
  const fs::path dir = TempDir("self");
  WriteCube(dir / "cube.obj", 0.1);
  const fs::path urdf = dir / "fold.urdf";
  std::ofstream(urdf) << R"(<?xml version="1.0"?>
<robot name="fold">
  <link name="base"><collision><geometry><mesh filename="cube.obj"/></geometry></collision></link>
  <link name="upper"/>
  <link name="fore"><collision><origin xyz="0.3 0 0"/><geometry><mesh filename="cube.obj"/></geometry></collision></link>
  <joint name="j1" type="revolute">
    <parent link="base"/><child link="upper"/><origin xyz="0.45 0 0"/><axis xyz="0 0 1"/>
    <limit lower="-3.2" upper="3.2" velocity="1" effort="1"/>
  </joint>
  <joint name="j2" type="revolute">
    <parent link="upper"/><child link="fore"/><axis xyz="0 0 1"/>
    <limit lower="-3.2" upper="3.2" velocity="1" effort="1"/>
  </joint>
</robot>
)";
  kinematics::Robot robot;
  robot.name = "fold";
  robot.model = kinematics::LoadUrdfModel(urdf);
  robot.urdf_path = urdf;
  const MeshCollisionModel model(robot);
  ASSERT_TRUE(model.available()) << model.unavailable_reason();
  MeshCollisionData data(model);
  const int base = robot.model.LinkIndex("base"), fore = robot.model.LinkIndex("fore");
  MeshSelfContact c = CheckMeshSelfCollision(model, Kinematics(robot, Eigen::Vector2d(M_PI, 0.0)), &data);
  ASSERT_TRUE(c.in_collision());
  EXPECT_EQ(std::minmax(c.link, c.other_link), std::minmax(base, fore));
  EXPECT_EQ(c.exact_pairs, 1);
  c = CheckMeshSelfCollision(model, Kinematics(robot, Eigen::Vector2d(M_PI / 2.0, 0.0)), &data);
  EXPECT_FALSE(c.in_collision());
  EXPECT_EQ(c.exact_pairs, 0);
  // boxes overlapping, meshes apart: at q1 = 3π/4 the cube (turned with the arm, 135° about z) is centred at
  // (0.45 − 0.3/√2, 0.3/√2) = (0.238, 0.212); its face towards the base's corner edge (0.1, 0.1) is
  // (0.138 + 0.112)/√2 − 0.1 = 7.7 cm from it, while its box (half size 0.1·√2) reaches x = 0.097 and y = 0.071,
  // inside the base's: FCL is asked and finds nothing
  c = CheckMeshSelfCollision(model, Kinematics(robot, Eigen::Vector2d(3.0 * M_PI / 4.0, 0.0)), &data);
  EXPECT_FALSE(c.in_collision());
  EXPECT_EQ(c.exact_pairs, 1);
  kinematics::Robot excluded = robot;
  excluded.excluded_pairs.emplace_back(std::min(base, fore), std::max(base, fore));
  std::sort(excluded.excluded_pairs.begin(), excluded.excluded_pairs.end());
  const MeshCollisionModel model_excluded(excluded);
  MeshCollisionData data_excluded(model_excluded);
  EXPECT_FALSE(
      CheckMeshSelfCollision(model_excluded, Kinematics(robot, Eigen::Vector2d(M_PI, 0.0)), &data_excluded)
          .in_collision());
  EXPECT_THROW(CheckMeshSelfCollision(model, Kinematics(robot, Eigen::Vector2d(M_PI, 0.0)), &data_excluded),
               InputError);
  fs::remove_all(dir);
}

TEST(MeshCollisionTest, UnavailableModelsSayWhy) {
  const fs::path dir = TempDir("unavailable");
  const MeshCollisionModel missing(OneJointArm(
      dir, R"(<collision><geometry><mesh filename="package://nowhere/arm.stl"/></geometry></collision>)"));
  EXPECT_FALSE(missing.available());
  EXPECT_NE(missing.unavailable_reason().find("link 'arm': collision mesh 'package://nowhere/arm.stl' not found"),
            std::string::npos) << missing.unavailable_reason();
  const MeshCollisionModel visual_only(OneJointArm(
      dir, R"(<visual><geometry><sphere radius="0.1"/></geometry></visual>)"));
  EXPECT_FALSE(visual_only.available());
  EXPECT_NE(visual_only.unavailable_reason().find("has no <collision> element"), std::string::npos)
      << visual_only.unavailable_reason();
  EXPECT_NE(visual_only.Summary().find("no collision meshes"), std::string::npos);
  kinematics::Robot no_file = kinematics::LoadShippedRobot("panda");
  no_file.urdf_path.clear();
  EXPECT_FALSE(MeshCollisionModel(no_file).available());
  // an unavailable model is refused by the query, with its reason
  MeshCollisionData data(missing);
  kinematics::Data kin(OneJointArm(dir, "").model);
  try {
    CalcMeshClearance(missing, kin, {}, &data);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos) << e.what();
  }
  EXPECT_THROW(MeshCollisionModel(OneJointArm(dir, ""), {.distance_cap = 0.0}), InputError);
  fs::remove_all(dir);
}

// MotionBenchMaker's Panda: its 11 collision meshes placed by forward kinematics. For a direction u, the vertex v* of
// all meshes (read here, posed here) farthest along u bounds every mesh point p by u·p <= u·v*; a sphere of radius r
// centred at v* + (d + r)·u is then exactly d from the robot (no point nearer than the plane, v* on it), and the link
// of v* attains it.
TEST(MeshCollisionTest, MotionBenchMakerPandaMeshesPlacedByForwardKinematics) {
  const fs::path set = RMPMARL_MBM_PANDA;
  if (!fs::is_regular_file(set / "panda.urdf")) GTEST_SKIP() << "MotionBenchMaker's Panda set is absent: " << set;
  if (!setup::MeshReadingAvailable()) GTEST_SKIP() << "built without assimp: meshes cannot be read";
  const kinematics::Robot panda = kinematics::LoadRobot(
      set / "panda.urdf", fs::path(RMPMARL_TEST_DATA_DIR).parent_path().parent_path() / "configs" / "benchmarks" /
                              "mbm-panda.collision.yaml");
  const MeshCollisionModel model(panda, {.package_paths = {set}});
  ASSERT_TRUE(model.available()) << model.unavailable_reason();
  EXPECT_EQ(model.num_geometries(), 11);
  std::printf("[ meshes   ] %s\n", model.Summary().c_str());
  // the reference: every vertex in W
  std::ifstream in(set / "panda.urdf");
  std::stringstream xml;
  xml << in.rdbuf();
  const Eigen::VectorXd q = sim::ReadyConfiguration(panda);
  const kinematics::Data kin = Kinematics(panda, q);
  std::vector<std::pair<int, Vector3d>> vertices;
  for (const kinematics::LinkShape& s : kinematics::ParseUrdfShapes(xml.str(), panda.model, "panda.urdf")) {
    if (s.visual) continue;
    ASSERT_EQ(s.kind, kinematics::ShapeKind::kMesh);
    const setup::TriangleMesh mesh =
        setup::ReadMesh(setup::ResolveMeshUri(s.mesh_uri, set / "panda.urdf", {set}), s.mesh_scale);
    for (Eigen::Index i = 0; i < mesh.p_M.cols(); ++i) {
      vertices.emplace_back(s.link, kin.X_WL[s.link] * s.X_LG * Vector3d(mesh.p_M.col(i)));
    }
  }
  MeshCollisionData data(model);
  const double d = 0.03, r = 0.02;
  for (const Vector3d& direction : {Vector3d(1, 0, 0), Vector3d(0, -1, 0), Vector3d(0, 0, 1), Vector3d(1, 1, 1)}) {
    const Vector3d u = direction.normalized();
    // the extreme along u over all vertices, and per link (two links may share it: the fingers are mirrored)
    std::vector<double> extreme(panda.model.num_links(), -std::numeric_limits<double>::infinity());
    size_t best = 0;
    for (size_t i = 0; i < vertices.size(); ++i) {
      extreme[vertices[i].first] = std::max(extreme[vertices[i].first], u.dot(vertices[i].second));
      if (u.dot(vertices[i].second) > u.dot(vertices[best].second)) best = i;
    }
    const Vector3d centre = vertices[best].second + (d + r) * u;
    const MeshClearance c = CalcMeshClearance(model, kin, std::vector{rmp::Obstacle::MakeSphere(centre, r)}, &data);
    SCOPED_TRACE(fmt::format("direction {} {} {}", direction.x(), direction.y(), direction.z()));
    EXPECT_NEAR(c.distance, d, 1e-5);
    ASSERT_GE(c.link, 0);
    EXPECT_NEAR(extreme[c.link], u.dot(vertices[best].second), 1e-9)
        << panda.model.link(c.link).name << " vs " << panda.model.link(vertices[best].first).name;
    // moved in by d + 1 cm along −u: 1 cm deep at v*
    const MeshClearance in = CalcMeshClearance(
        model, kin, std::vector{rmp::Obstacle::MakeSphere(centre - (d + 0.01) * u, r)}, &data);
    EXPECT_TRUE(in.in_collision());
    EXPECT_LT(in.distance, -0.005);
  }
}

}  // namespace
}  // namespace rmpmarl::experiments
