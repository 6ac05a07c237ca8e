// setup-robot, check-robot without a YAML, and demo --urdf without a YAML, from the outside.
#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "../support/temp_files.h"
#include "run_cli.h"

namespace {

namespace fs = std::filesystem;

using rmpmarl::test::CommandResult;
using rmpmarl::test::RunCli;

// a world-rooted arm with primitive collision geometry and frame-only tool links.
fs::path WriteArm(const std::string& name) {
  const fs::path dir = rmpmarl::test::FreshTempDir("setup-cli", name);
  std::ofstream(dir / "arm.urdf") << R"(<?xml version="1.0"?>
<robot name="arm">
  <link name="world"/>
  <link name="base_link"><collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.08" length="0.1"/></geometry></collision></link>
  <link name="link1"><collision><origin xyz="0 0 0.1"/><geometry><box size="0.12 0.12 0.2"/></geometry></collision></link>
  <link name="link2"><collision><origin xyz="0 0 0.15"/><geometry><cylinder radius="0.05" length="0.3"/></geometry></collision></link>
  <link name="link3"><collision><origin xyz="0 0 0.125"/><geometry><cylinder radius="0.04" length="0.25"/></geometry></collision></link>
  <link name="link4"><collision><geometry><sphere radius="0.05"/></geometry></collision></link>
  <link name="tool0"/>
  <joint name="world_joint" type="fixed"><parent link="world"/><child link="base_link"/></joint>
  <joint name="j1" type="revolute"><parent link="base_link"/><child link="link1"/><origin xyz="0 0 0.1"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="2" effort="10"/></joint>
  <joint name="j2" type="revolute"><parent link="link1"/><child link="link2"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="2" effort="10"/></joint>
  <joint name="j3" type="revolute"><parent link="link2"/><child link="link3"/><origin xyz="0 0 0.3"/><axis xyz="0 1 0"/><limit lower="-2.5" upper="2.5" velocity="2" effort="10"/></joint>
  <joint name="j4" type="revolute"><parent link="link3"/><child link="link4"/><origin xyz="0 0 0.25"/><axis xyz="0 1 0"/><limit lower="-2" upper="2" velocity="2" effort="10"/></joint>
  <joint name="t" type="fixed"><parent link="link4"/><child link="tool0"/><origin xyz="0 0 0.06"/></joint>
</robot>
)";
  return dir / "arm.urdf";
}

TEST(SetupRobotCli, CheckRobotWithoutYamlFitsInMemoryAndValidates) {
  const fs::path urdf = WriteArm("check");
  const CommandResult r = RunCli("check-robot " + urdf.string());
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("fitted in memory"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("MuJoCo world: compiles"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("OK"), std::string::npos) << r.output;
}

TEST(SetupRobotCli, SetupRobotWritesFilesThatCheckRobotAndDemoUse) {
  const fs::path urdf = WriteArm("setup");
  const fs::path out = urdf.parent_path() / "description";
  const CommandResult r = RunCli(fmt::format("setup-robot {} --out {} --samples 2000 --seed 3", urdf.string(), out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  for (const char* link : {"base_link", "link1", "link2", "link3", "link4", "tool0", "world"}) {
    EXPECT_NE(r.output.find(link), std::string::npos) << link;
  }
  EXPECT_NE(r.output.find("sticks out"), std::string::npos) << r.output;
  EXPECT_TRUE(fs::exists(out / "arm.collision.yaml"));
  EXPECT_TRUE(fs::exists(out / "arm.rmpflow.yaml"));
  const CommandResult check = RunCli(fmt::format("check-robot {} {}", urdf.string(), (out / "arm.collision.yaml").string()));
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("arm.rmpflow.yaml"), std::string::npos) << check.output;  // the robot's own home
  const CommandResult demo = RunCli(fmt::format("demo --urdf {} --collision {} --duration 1", urdf.string(),
                                             (out / "arm.collision.yaml").string()));
  EXPECT_EQ(demo.exit_code, 0) << demo.output;
  EXPECT_NE(demo.output.find("arm.rmpflow.yaml"), std::string::npos) << demo.output;
}

TEST(SetupRobotCli, CheckRobotNamesEveryPairOverlappingAtHome) {
  const fs::path urdf = WriteArm("overlap");
  std::ofstream(urdf.parent_path() / "arm.collision.yaml") << R"(robot: arm
end_effector: {link: tool0}
capsules:
  - {link: base_link, a: [0, 0, 0], b: [0, 0, 0.1], radius: 0.08}
  - {link: link1, a: [0, 0, 0], b: [0, 0, 0.2], radius: 0.06}
  - {link: link2, a: [0, 0, 0], b: [0, 0, 0.3], radius: 0.2}
  - {link: link3, a: [0, 0, 0], b: [0, 0, 0.25], radius: 0.04}
  - {link: link4, a: [0, 0, 0], b: [0, 0, 0], radius: 0.05}
links_without_capsule: [world, tool0]
)";
  const CommandResult r = RunCli("check-robot " + urdf.string());  // the YAML beside the URDF is found
  EXPECT_NE(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("overlap at the home posture"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("base_link – link2"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("link2 – link4"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find(" mm"), std::string::npos) << r.output;
}

TEST(SetupRobotCli, CheckRobotFindsAShippedRobotsCollisionYamlBesideItsUrdf) {
  const std::string panda = std::string(RMPMARL_TEST_DATA_DIR) + "/../../models/robots/panda/panda.urdf";
  const CommandResult r = RunCli("check-robot " + panda);
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("collision.yaml"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("configs/rmpflow/panda.yaml"), std::string::npos) << r.output;  // a shipped robot's settings
}

TEST(SetupRobotCli, DemoWithoutYamlFitsInMemory) {
  const fs::path urdf = WriteArm("demo");
  // the shipped learned controller beside RMPflow on an arm it never saw, described by a URDF alone
  const CommandResult r = RunCli("demo --urdf " + urdf.string() + " --duration 5 --seed 2");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("fitted in memory"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("home found in memory"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("marl-rmp-residual.rmpp) and RMPflow on the same episode"), std::string::npos) << r.output;
  const size_t row = r.output.find("  collision events");
  ASSERT_NE(row, std::string::npos) << r.output;
  std::istringstream line(r.output.substr(row + 18, r.output.find('\n', row) - row - 18));
  int learned = -1, rmpflow = -1;
  line >> learned >> rmpflow;
  EXPECT_EQ(learned, 0) << r.output;
}

TEST(SetupRobotCli, XacroIsRefusedWithTheExpansionHint) {
  const fs::path dir = WriteArm("xacro").parent_path();
  std::ofstream(dir / "arm.urdf.xacro") << "<robot name=\"arm\" xmlns:xacro=\"http://www.ros.org/wiki/xacro\">\n"
                                          "  <xacro:include filename=\"arm_macro.xacro\"/>\n</robot>\n";
  const CommandResult r = RunCli("setup-robot " + (dir / "arm.urdf.xacro").string());
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("expand it with ROS's xacro first"), std::string::npos) << r.output;
}

// a URDF with <mimic> joints runs as downloaded: fitted in memory, RMPflow drives the independent joints in MuJoCo,
// the followers ride along on their equality constraints
TEST(SetupRobotCli, DemoRunsAUrdfWithMimicJoints) {
  const std::string urdf = std::string(RMPMARL_TEST_DATA_DIR) + "/robots/mimic/mimic_arm.urdf";
  const CommandResult check = RunCli("check-robot " + urdf);
  EXPECT_EQ(check.exit_code, 0) << check.output;
  EXPECT_NE(check.output.find("mimic: -0.5 x j3 +0.2"), std::string::npos) << check.output;
  const CommandResult r = RunCli("demo --policy rmpflow --urdf " + urdf + " --duration 2");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("mimic_arm (4 dof)"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("0 (0 self)"), std::string::npos) << r.output;
}

// the robot's MoveIt SRDF beside the URDF: its disabled pairs are excluded and listed with their reason, its end
// effector used; --no-srdf turns it off, --srdf names one
TEST(SetupRobotCli, SetupRobotUsesTheSrdfBesideTheUrdf) {
  const fs::path urdf = WriteArm("srdf");
  std::ofstream(urdf.parent_path() / "arm.srdf") << R"(<?xml version="1.0"?>
<robot name="arm">
  <end_effector name="tool" parent_link="link3" group="gripper"/>
  <disable_collisions link1="base_link" link2="link2" reason="Never"/>
  <disable_collisions link1="link1" link2="link3" reason="Never"/>
</robot>
)";
  const fs::path out = urdf.parent_path() / "description";
  const CommandResult r = RunCli(fmt::format("setup-robot {} --out {} --samples 300", urdf.string(), out.string()));
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("end effector: link3 (the parent link of arm.srdf's end effector 'tool')"),
            std::string::npos) << r.output;
  EXPECT_NE(r.output.find("2 disabled in the SRDF"), std::string::npos) << r.output;
  std::stringstream yaml;
  yaml << std::ifstream(out / "arm.collision.yaml").rdbuf();
  EXPECT_NE(yaml.str().find("- [link1, link3]   # disabled in the SRDF (Never)"), std::string::npos) << yaml.str();

  const CommandResult off = RunCli(fmt::format("setup-robot {} --out {} --samples 300 --no-srdf", urdf.string(),
                                               out.string()));
  ASSERT_EQ(off.exit_code, 0) << off.output;
  EXPECT_NE(off.output.find("0 disabled in the SRDF"), std::string::npos) << off.output;
  EXPECT_NE(off.output.find("end effector: tool0"), std::string::npos) << off.output;

  const CommandResult missing = RunCli(fmt::format("setup-robot {} --srdf {}", urdf.string(),
                                                   (urdf.parent_path() / "absent.srdf").string()));
  EXPECT_NE(missing.exit_code, 0);
  EXPECT_NE(missing.output.find("expected an existing .srdf file"), std::string::npos) << missing.output;
  const CommandResult both = RunCli(fmt::format("setup-robot {} --srdf {} --no-srdf", urdf.string(),
                                                (urdf.parent_path() / "arm.srdf").string()));
  EXPECT_NE(both.exit_code, 0) << both.output;
}

}  // namespace
