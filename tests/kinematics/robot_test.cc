// Loading robots: the tree test robot, planar2, and every kind of bad input with its message.
#include "rmpmarl/kinematics/robot.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <fstream>

#include "rmpmarl/common/error.h"
#include "test_robots.h"

namespace rmpmarl::kinematics {
namespace {

// writes `text` to a fresh file in a per-process temporary directory and returns its path.
std::filesystem::path WriteTemp(const std::string& name, const std::string& text) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("rmpmarl_robot_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / name;
  std::ofstream(path) << text;
  return path;
}

const char* kTwoLinkUrdf = R"(<?xml version="1.0"?>
<robot name="two">
  <link name="base"/><link name="l1"/><link name="l2"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="l2"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>)";

const char* kTwoLinkYaml = R"(robot: two
end_effector: {link: l2, xyz: [0.2, 0, 0]}
capsules:
  - {link: l1, a: [0, 0, 0], b: [0.3, 0, 0], radius: 0.04}
  - {link: l2, a: [0, 0, 0], b: [0.2, 0, 0], radius: 0.03}
links_without_capsule: [base]
)";

// loads kTwoLinkUrdf with the given YAML text and returns the InputError message ("" if it loaded).
std::string YamlError(const std::string& yaml_text) {
  const auto urdf = WriteTemp("two.urdf", kTwoLinkUrdf);
  const auto yaml = WriteTemp("collision.yaml", yaml_text);
  try {
    LoadRobot(urdf, yaml);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::string UrdfError(const std::string& urdf_text) {
  try {
    ParseUrdfModel(urdf_text, "test.urdf");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

#define EXPECT_HAS(haystack, needle) EXPECT_NE((haystack).find(needle), std::string::npos) << (haystack)

TEST(RobotTest, LoadsTreeRobotInTopologicalOrder) {
  const Robot robot = testing::LoadTreeRobot();
  EXPECT_EQ(robot.name, "tree");
  EXPECT_EQ(robot.model.num_links(), 8);
  EXPECT_EQ(robot.model.nq(), 6);
  for (int k = 1; k < robot.model.num_links(); ++k) EXPECT_LT(robot.model.link(k).parent, k);
  // depth-first, children by joint name: j0_torso, j1_slider, j2_a1, j3_a2, j5_b1, j6_b2
  const std::vector<std::string> expected = {"j0_torso", "j1_slider", "j2_a1", "j3_a2", "j5_b1", "j6_b2"};
  for (int i = 0; i < robot.model.nq(); ++i) EXPECT_EQ(robot.model.dof_name(i), expected[i]);
  const int a2 = robot.model.dof_link(3);
  EXPECT_EQ(robot.model.link(a2).joint_type, JointType::kContinuous);
  EXPECT_TRUE(std::isinf(robot.model.limits()[3].lower));
  EXPECT_EQ(robot.model.link(robot.model.dof_link(1)).joint_type, JointType::kPrismatic);
  EXPECT_NEAR(robot.model.link(robot.model.dof_link(1)).axis_J.norm(), 1.0, 1e-15);
  EXPECT_EQ(robot.end_effector.link, robot.model.LinkIndex("tool_a"));
  EXPECT_TRUE(robot.IsExcludedPair(robot.model.LinkIndex("torso"), robot.model.LinkIndex("arm_a1")));
  EXPECT_TRUE(robot.IsExcludedPair(robot.model.LinkIndex("arm_a1"), robot.model.LinkIndex("slider")));  // adjacent
  EXPECT_FALSE(robot.IsExcludedPair(robot.model.LinkIndex("arm_a2"), robot.model.LinkIndex("arm_b2")));
}

TEST(RobotTest, LoadsValidTwoLinkRobot) { EXPECT_EQ(YamlError(kTwoLinkYaml), ""); }

TEST(RobotTest, Planar2UsesItsLinkLengths) {
  const Robot robot = MakePlanar2({.link1_length = 0.3, .link2_length = 0.7});
  EXPECT_EQ(robot.model.nq(), 2);
  EXPECT_DOUBLE_EQ(robot.model.link(2).X_PJ.translation().x(), 0.3);
  EXPECT_DOUBLE_EQ(robot.end_effector.X_LE.translation().x(), 0.7);
  EXPECT_THROW(MakePlanar2({.link1_length = -0.1}), InputError);
}

TEST(RobotTest, MissingFilesAreReported) {
  try {
    LoadRobot("/nonexistent/robot.urdf", "/nonexistent/collision.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_HAS(std::string(e.what()), "/nonexistent/robot.urdf: cannot open URDF file");
  }
  const auto urdf = WriteTemp("two.urdf", kTwoLinkUrdf);
  try {
    LoadRobot(urdf, "/nonexistent/collision.yaml");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_HAS(std::string(e.what()), "/nonexistent/collision.yaml: cannot open collision YAML");
  }
}

TEST(RobotTest, MalformedUrdfIsReported) {
  EXPECT_HAS(UrdfError("<robot name='x'><link name='a'>"), "test.urdf: not a valid URDF");
  EXPECT_HAS(UrdfError("not xml at all"), "test.urdf: not a valid URDF");
}

TEST(RobotTest, UnsupportedOrIncompleteJointsAreReported) {
  std::string floating = kTwoLinkUrdf;
  floating.replace(floating.find("type=\"revolute\""), 15, "type=\"floating\"");
  EXPECT_HAS(UrdfError(floating), "joint 'j1': type not supported");
  std::string zero_axis = kTwoLinkUrdf;
  zero_axis.replace(zero_axis.find("<axis xyz=\"0 0 1\"/>"), 19, "<axis xyz=\"0 0 0\"/>");
  EXPECT_HAS(UrdfError(zero_axis), "joint 'j1': <axis xyz> must be non-zero");
  std::string bad_limits = kTwoLinkUrdf;
  bad_limits.replace(bad_limits.find("lower=\"-1\" upper=\"1\""), 20, "lower=\"1\" upper=\"-1\"");
  EXPECT_HAS(UrdfError(bad_limits), "joint 'j1': <limit> expected finite lower < upper, got lower=1 upper=-1");
  std::string zero_velocity = kTwoLinkUrdf;
  zero_velocity.replace(zero_velocity.find("velocity=\"1\""), 12, "velocity=\"0\"");
  EXPECT_HAS(UrdfError(zero_velocity), "joint 'j1': <limit velocity> must be a positive number");
}

TEST(RobotTest, MalformedYamlIsReported) {
  EXPECT_HAS(YamlError("robot: two\ncapsules: [ {link: l1"), "collision.yaml:");
  EXPECT_HAS(YamlError("robot: two\ncapsules: [ {link: l1"), "malformed YAML");
  EXPECT_HAS(YamlError("- just\n- a list\n"), "expected a mapping");
}

TEST(RobotTest, UnknownKeysAreReported) {
  std::string yaml = kTwoLinkYaml;
  EXPECT_HAS(YamlError(yaml + "colour: red\n"), "key 'colour': unknown key");
  std::string bad = kTwoLinkYaml;
  bad.replace(bad.find("radius: 0.04"), 12, "radius: 0.04, colour: red");
  EXPECT_HAS(YamlError(bad), "key 'capsules[0].colour': unknown key");
}

TEST(RobotTest, LinkWithoutCapsuleIsReported) {
  std::string yaml = kTwoLinkYaml;
  yaml.replace(yaml.find("links_without_capsule: [base]"), 29, "");
  EXPECT_HAS(YamlError(yaml), "link 'base' has no capsule");
}

TEST(RobotTest, BadCapsuleValuesAreReported) {
  std::string unknown_link = kTwoLinkYaml;
  unknown_link.replace(unknown_link.find("{link: l1"), 9, "{link: l9");
  EXPECT_HAS(YamlError(unknown_link), "key 'capsules[0].link': no link 'l9' in the URDF (links: base, l1, l2)");
  std::string negative = kTwoLinkYaml;
  negative.replace(negative.find("radius: 0.04"), 12, "radius: -0.04");
  EXPECT_HAS(YamlError(negative), "key 'capsules[0].radius': expected > 0, got -0.04");
  std::string short_vec = kTwoLinkYaml;
  short_vec.replace(short_vec.find("b: [0.3, 0, 0]"), 14, "b: [0.3, 0]");
  EXPECT_HAS(YamlError(short_vec), "key 'capsules[0].b': expected a list of 3 numbers, got 2 entries");
  std::string not_number = kTwoLinkYaml;
  not_number.replace(not_number.find("b: [0.3, 0, 0]"), 14, "b: [0.3, zero, 0]");
  EXPECT_HAS(YamlError(not_number), "key 'capsules[0].b[1]': expected a number, got 'zero'");
  std::string nan = kTwoLinkYaml;
  nan.replace(nan.find("b: [0.3, 0, 0]"), 14, "b: [.nan, 0, 0]");
  EXPECT_HAS(YamlError(nan), "key 'capsules[0].b[0]': expected a finite number");
}

TEST(RobotTest, ASeparateSelfCollisionSetIsReadAndChecked) {
  const std::string with_set = std::string(kTwoLinkYaml) +
                               "self_collision_capsules:\n"
                               "  - {link: l1, a: [0, 0, 0], b: [0.3, 0, 0], radius: 0.05}\n"
                               "  - {link: l2, a: [0, 0, 0], b: [0.1, 0, 0], radius: 0.035}\n"
                               "  - {link: l2, a: [0.1, 0, 0], b: [0.2, 0, 0], radius: 0.035}\n";
  const Robot robot = LoadRobot(WriteTemp("two.urdf", kTwoLinkUrdf), WriteTemp("collision.yaml", with_set));
  ASSERT_EQ(robot.capsules.size(), 2u);
  ASSERT_EQ(robot.self_capsules.size(), 3u);
  EXPECT_EQ(&robot.self_collision_capsules(), &robot.self_capsules);
  EXPECT_EQ(robot.self_capsules[2].p_LA, Eigen::Vector3d(0.1, 0, 0));
  EXPECT_EQ(robot.self_capsules[2].radius, 0.035);
  const Robot plain = LoadRobot(WriteTemp("two.urdf", kTwoLinkUrdf), WriteTemp("collision.yaml", kTwoLinkYaml));
  EXPECT_EQ(&plain.self_collision_capsules(), &plain.capsules);
  // the two sets cover the same links
  std::string missing_link = std::string(kTwoLinkYaml) + "self_collision_capsules:\n"
                             "  - {link: l1, a: [0, 0, 0], b: [0.3, 0, 0], radius: 0.05}\n";
  EXPECT_HAS(YamlError(missing_link), "link 'l2' has 1 capsules and 0 self_collision_capsules: expected both sets to "
                                      "cover the same links");
  std::string negative = std::string(kTwoLinkYaml) + "self_collision_capsules:\n"
                         "  - {link: l1, a: [0, 0, 0], b: [0.3, 0, 0], radius: -0.05}\n";
  EXPECT_HAS(YamlError(negative), "key 'self_collision_capsules[0].radius': expected > 0, got -0.05");
  EXPECT_HAS(YamlError(std::string(kTwoLinkYaml) + "self_collision_capsules: []\n"),
             "key 'self_collision_capsules': expected a non-empty list of {link, a, b, radius}");
}

TEST(RobotTest, RobotNameAndEndEffectorAreChecked) {
  std::string name = kTwoLinkYaml;
  name.replace(name.find("robot: two"), 10, "robot: three");
  EXPECT_HAS(YamlError(name), "key 'robot': expected the URDF's robot name 'two', got 'three'");
  std::string no_ee = kTwoLinkYaml;
  no_ee.replace(no_ee.find("end_effector: {link: l2, xyz: [0.2, 0, 0]}"), 42, "");
  EXPECT_HAS(YamlError(no_ee), "key 'end_effector': missing");
  std::string bad_pair = std::string(kTwoLinkYaml) + "self_collision_exclude: [[l1]]\n";
  EXPECT_HAS(YamlError(bad_pair), "key 'self_collision_exclude[0]': expected a pair [link, link]");
}

TEST(RobotTest, UnknownShippedRobotListsTheShippedOnes) {
  try {
    LoadShippedRobot("no_such_robot");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_HAS(std::string(e.what()), "unknown robot 'no_such_robot'");
  }
}

}  // namespace
}  // namespace rmpmarl::kinematics
