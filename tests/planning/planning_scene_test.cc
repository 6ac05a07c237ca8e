// MoveIt planning scenes and motion-plan requests: hand-written files with hand-derived poses and sizes, the refusals
// by name, and MotionBenchMaker's Panda problems (where the set is present).
#include "rmpmarl/planning/planning_scene.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::planning {
namespace {

const char* kScene = R"(
name: shelf
world:
  collision_objects:
    - id: board
      primitive_poses:
        - position: [0.5, 0.0, 0.3]
          orientation: [0, 0, 0.7071067811865476, 0.7071067811865476]
      primitives:
        - type: box
          dimensions: [0.4, 0.2, 0.02]
    - id: can
      pose: {position: {x: 0.1, y: 0.0, z: 0.0}, orientation: {x: 0, y: 0, z: 0, w: 1}}
      primitive_poses:
        - {position: {x: 0.5, y: 0.1, z: 0.4}, orientation: {x: 0.7071067811865476, y: 0, z: 0, w: 0.7071067811865476}}
        - position: [0.0, 0.0, 1.0]
          orientation: [0, 0, 0, 1]
      primitives:
        - type: cylinder
          dimensions: [0.14, 0.03]
        - type: sphere
          dimensions: [0.05]
)";

TEST(PlanningSceneTest, ReadsBoxesCylindersAndSpheresWithTheirPoses) {
  const PlanningScene scene = ParsePlanningScene(kScene, "shelf.yaml");
  EXPECT_EQ(scene.name, "shelf");
  ASSERT_EQ(scene.objects.size(), 2u);
  EXPECT_EQ(scene.objects[0].id, "board");
  const rmp::Obstacle& board = scene.objects[0].primitives.at(0);
  ASSERT_EQ(board.shape, rmp::ObstacleShape::kBox);
  EXPECT_TRUE(board.box.half_size.isApprox(Eigen::Vector3d(0.2, 0.1, 0.01)));
  EXPECT_TRUE(board.box.X_WB.translation().isApprox(Eigen::Vector3d(0.5, 0.0, 0.3)));
  // a quarter turn about z: the box's x axis along the world's y
  EXPECT_TRUE((board.box.X_WB.linear() * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));

  const std::vector<rmp::Obstacle>& can = scene.objects[1].primitives;
  ASSERT_EQ(can.size(), 2u);
  ASSERT_EQ(can[0].shape, rmp::ObstacleShape::kCylinder);
  EXPECT_DOUBLE_EQ(can[0].cylinder.radius, 0.03);
  EXPECT_DOUBLE_EQ(can[0].cylinder.half_length, 0.07);
  // the object pose shifts its primitives by 0.1 m in x; a quarter turn about x lays the axis along −y
  EXPECT_TRUE(can[0].cylinder.X_WC.translation().isApprox(Eigen::Vector3d(0.6, 0.1, 0.4)));
  EXPECT_TRUE((can[0].cylinder.X_WC.linear() * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
  ASSERT_EQ(can[1].shape, rmp::ObstacleShape::kSphere);
  EXPECT_TRUE(can[1].sphere.p_WC.isApprox(Eigen::Vector3d(0.1, 0.0, 1.0)));
  EXPECT_EQ(scene.Obstacles().size(), 3u);
  rmp::Scene s;
  s.obstacles = scene.Obstacles();
  EXPECT_NO_THROW(rmp::ValidateScene(s, "shelf"));
}

void ExpectRefused(const std::string& yaml, const std::string& needle) {
  try {
    ParsePlanningScene(yaml, "bad.yaml");
    ADD_FAILURE() << "accepted a scene that should fail with '" << needle << "'";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("bad.yaml"), std::string::npos) << e.what();
  }
}

TEST(PlanningSceneTest, RefusesWhatItCannotReadByName) {
  const std::string head = "world:\n  collision_objects:\n    - id: thing\n";
  ExpectRefused(head + "      meshes: [{vertices: [[0, 0, 0]]}]\n", "meshes are not read");
  ExpectRefused(head + "      primitive_poses: [{position: [0, 0, 0], orientation: [0, 0, 0, 1]}]\n"
                       "      primitives: [{type: cone, dimensions: [0.1, 0.1]}]\n", "cone");
  ExpectRefused(head + "      primitive_poses: [{position: [0, 0, 0], orientation: [0, 0, 0, 2]}]\n"
                       "      primitives: [{type: box, dimensions: [0.1, 0.1, 0.1]}]\n", "unit quaternion");
  ExpectRefused(head + "      primitive_poses: [{position: [0, 0, 0], orientation: [0, 0, 0, 1]}]\n"
                       "      primitives: [{type: box, dimensions: [0.1, 0, 0.1]}]\n", "expected a size > 0");
  ExpectRefused(head + "      primitive_poses: [{position: [0, 0, 0], orientation: [0, 0, 0, 1]}]\n"
                       "      primitives: [{type: cylinder, dimensions: [0.1]}]\n", "[height, radius]");
  ExpectRefused(head + "      primitives: [{type: sphere, dimensions: [0.1]}]\n", "one pose per primitive");
  ExpectRefused(head + "      operation: 1\n", "only ADD");
  ExpectRefused("robot_state: {}\n", "world");
}

TEST(PlanningSceneTest, AppliesTheVirtualJointFixedFramesAndObjectFramesAndRefusesAnUnknownOne) {
  // the robot's base stands at (1, 2, 0) in the planning frame 'world', turned 90° about z; a fixed frame 'table' sits
  // at (0, 0, 0.7) in 'world'. Hand-derived: a point p_W is at R_z(−90°) (p_W − (1, 2, 0)) in the base frame, so
  // (x, y, z) ↦ (y − 2, 1 − x, z).
  const double s = std::sqrt(0.5);
  const std::string head = fmt::format(R"(
robot_state:
  multi_dof_joint_state:
    joint_names: [virtual_joint]
    transforms: [{{translation: [1, 2, 0], rotation: [0, 0, {0}, {0}]}}]
fixed_frame_transforms:
  - header: {{frame_id: world}}
    child_frame_id: table
    transform: {{translation: [0, 0, 0.7], rotation: [0, 0, 0, 1]}}
world:
  collision_objects:
    - id: in_world
      primitives: [{{type: sphere, dimensions: [0.05]}}]
      primitive_poses: [{{position: [1.5, 2.0, 0.3], orientation: [0, 0, 0, 1]}}]
    - id: on_table
      header: {{frame_id: table}}
      primitives: [{{type: box, dimensions: [0.2, 0.1, 0.04]}}]
      primitive_poses: [{{position: [1.0, 2.5, 0.02], orientation: [0, 0, 0, 1]}}]
    - id: named_world
      header: {{frame_id: world}}
      primitives: [{{type: sphere, dimensions: [0.05]}}]
      primitive_poses: [{{position: [1.0, 3.0, 0.0], orientation: [0, 0, 0, 1]}}]
    - id: in_base
      header: {{frame_id: base}}
      primitives: [{{type: sphere, dimensions: [0.05]}}]
      primitive_poses: [{{position: [0.4, 0.1, 0.2], orientation: [0, 0, 0, 1]}}]
)", s);
  const PlanningScene scene = ParsePlanningScene(head, "framed.yaml", "base");
  ASSERT_EQ(scene.objects.size(), 4u);
  EXPECT_TRUE(scene.objects[0].primitives[0].sphere.p_WC.isApprox(Eigen::Vector3d(0.0, -0.5, 0.3), 1e-12));
  const math::Box& box = scene.objects[1].primitives[0].box;
  EXPECT_TRUE(box.X_WB.translation().isApprox(Eigen::Vector3d(0.5, 0.0, 0.72), 1e-12)) << box.X_WB.translation();
  // the box's x axis (world x) is the base frame's −y
  EXPECT_TRUE((box.X_WB.linear() * Eigen::Vector3d::UnitX()).isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
  EXPECT_TRUE(scene.objects[2].primitives[0].sphere.p_WC.isApprox(Eigen::Vector3d(1.0, 0.0, 0.0), 1e-12));
  EXPECT_TRUE(scene.objects[3].primitives[0].sphere.p_WC.isApprox(Eigen::Vector3d(0.4, 0.1, 0.2), 1e-12));
  // without the base link named, the object in it is refused, naming the frame and the ones the scene has
  try {
    ParsePlanningScene(head, "framed.yaml");
    ADD_FAILURE() << "accepted an unknown frame";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("('in_base').header.frame_id"), std::string::npos) << what;
    EXPECT_NE(what.find("unknown frame 'base'"), std::string::npos) << what;
    EXPECT_NE(what.find("'world', 'table'"), std::string::npos) << what;
  }
}

const char* kRequest = R"(
group_name: arm
start_state:
  joint_state:
    name: [j2, j1, finger]
    position: [0.2, 0.1, 0.04]
goal_constraints:
  - joint_constraints:
      - {joint_name: j1, position: -0.5, tolerance_below: 0.01, tolerance_above: 0.02}
      - {joint_name: j2, position: 0.7}
)";

kinematics::Robot TwoJointRobot() { return kinematics::MakePlanar2(); }

TEST(MotionPlanRequestTest, ReadsStartAndJointGoalInTheRobotsOrder) {
  const MotionPlanRequest request = ParseMotionPlanRequest(kRequest, "request.yaml");
  EXPECT_EQ(request.group, "arm");
  ASSERT_EQ(request.goal.joints.names.size(), 2u);
  EXPECT_DOUBLE_EQ(request.goal.tolerance_above[0], 0.02);
  EXPECT_DOUBLE_EQ(request.goal.tolerance_below[1], 1e-3);  // MoveIt's default when left out

  // the same names on a robot whose dofs are called j1, j2: the finger is skipped, the order is the robot's
  kinematics::Robot robot = TwoJointRobot();
  NamedJoints start = request.start;
  for (std::string& n : start.names) {
    if (n == "j1") n = robot.model.dof_name(0);
    if (n == "j2") n = robot.model.dof_name(1);
  }
  const Eigen::VectorXd q = JointVector(robot, start, "start_state");
  EXPECT_TRUE(q.isApprox(Eigen::Vector2d(0.1, 0.2)));
  start.names.erase(start.names.begin());  // j2 missing
  start.positions = start.positions.tail(2).eval();
  try {
    JointVector(robot, start, "start_state");
    ADD_FAILURE() << "accepted a state without every joint";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(robot.model.dof_name(1)), std::string::npos) << e.what();
  }
}

TEST(MotionPlanRequestTest, RefusesMalformedConstraintsByName) {
  const std::string start = "start_state: {joint_state: {name: [a], position: [0]}}\n";
  for (const auto& [goal, needle] : {std::pair<std::string, std::string>{"goal_constraints: [foo]\n", "goal_constraints[0]"},
                                     {"goal_constraints: [{joint_constraints: [foo]}]\n", "joint_constraints[0]"}}) {
    try {
      ParseMotionPlanRequest(start + goal, "bad.yaml");
      ADD_FAILURE() << "accepted " << goal;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
    }
  }
  EXPECT_NO_THROW(ParsePlanningScene("robot_state: foo\nworld: {octomap: {octomap: foo}}\n", "odd.yaml"));
}

TEST(MotionPlanRequestTest, RefusesAPoseGoalByName) {
  const std::string pose_goal = "start_state: {joint_state: {name: [a], position: [0]}}\n"
                                "goal_constraints: [{position_constraints: [{link_name: hand}]}]\n";
  try {
    ParseMotionPlanRequest(pose_goal, "pose.yaml");
    ADD_FAILURE() << "accepted a goal without joint constraints";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("only joint-space goals"), std::string::npos) << e.what();
  }
}

// every problem of MotionBenchMaker's Panda set reads: 100 scenes and requests per family, boxes and cylinders in
// valid poses, a start and goal for each of the Panda's seven joints
TEST(MotionBenchMakerTest, EveryPandaProblemReads) {
  const std::filesystem::path dir = RMPMARL_MBM_PROBLEMS;
  if (dir.empty() || !std::filesystem::is_directory(dir)) GTEST_SKIP() << "MotionBenchMaker's Panda set is absent";
  const kinematics::Robot panda = kinematics::LoadShippedRobot("panda");
  int problems = 0, cylinders = 0;
  for (const auto& family : std::filesystem::directory_iterator(dir)) {
    for (int i = 1; i <= 100; ++i) {
      const std::filesystem::path scene_path = family.path() / fmt::format("scene{:04d}.yaml", i);
      const PlanningScene scene = ReadPlanningScene(scene_path);
      rmp::Scene s;
      s.obstacles = scene.Obstacles();
      ASSERT_FALSE(s.obstacles.empty()) << scene_path;
      rmp::ValidateScene(s, scene_path.string());
      for (const rmp::Obstacle& o : s.obstacles) cylinders += o.shape == rmp::ObstacleShape::kCylinder;
      const MotionPlanRequest request = ReadMotionPlanRequest(family.path() / fmt::format("request{:04d}.yaml", i));
      EXPECT_EQ(JointVector(panda, request.start, "start").size(), 7);
      EXPECT_EQ(JointVector(panda, request.goal.joints, "goal").size(), 7);
      ++problems;
    }
  }
  EXPECT_EQ(problems, 700);
  EXPECT_GT(cylinders, 0);
}

}  // namespace
}  // namespace rmpmarl::planning
