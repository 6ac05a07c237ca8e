// MoveIt's SRDF: what the reader keeps (pairs with their reasons, end effectors, virtual joints, groups), errors that
// name the file and the link, and SetupRobot excluding an SRDF's disabled pairs and taking its end effector — on a
// small arm written here and on MotionBenchMaker's Panda with its own SRDF.
#include "rmpmarl/setup/srdf.h"

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>
#include <string>
#include <utility>

#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/setup/robot_setup.h"
#include "../support/temp_files.h"

namespace rmpmarl::setup {

using namespace kinematics;  // the robot description being set up: kinematics' types throughout
namespace {

namespace fs = std::filesystem;

fs::path TempDir(const std::string& name) { return test::FreshTempDir("srdf", name); }

void Write(const fs::path& path, const std::string& text) { test::WriteTextFile(path, text); }

// a world-rooted four-joint arm of primitives with frame-only flange and tool0.
constexpr const char* kArmUrdf = R"(<?xml version="1.0"?>
<robot name="arm">
  <link name="world"/>
  <link name="base_link"><collision><origin xyz="0 0 0.05"/><geometry><cylinder radius="0.08" length="0.1"/></geometry></collision></link>
  <link name="link1"><collision><origin xyz="0 0 0.1"/><geometry><box size="0.12 0.12 0.2"/></geometry></collision></link>
  <link name="link2"><collision><origin xyz="0 0 0.15"/><geometry><cylinder radius="0.05" length="0.3"/></geometry></collision></link>
  <link name="link3"><collision><origin xyz="0 0 0.125"/><geometry><cylinder radius="0.04" length="0.25"/></geometry></collision></link>
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
)";

// its SRDF: one parent–child pair (already excluded) and three others, an end effector on link3 (not the tool0 the
// URDF alone gives), a virtual joint and two groups.
constexpr const char* kArmSrdf = R"(<?xml version="1.0"?>
<robot name="arm">
  <group name="manipulator"><chain base_link="base_link" tip_link="link4"/><joint name="virtual_joint"/></group>
  <group name="gripper"><link name="link4"/><joint name="j4"/><group name="manipulator"/></group>
  <end_effector name="tool" parent_link="link3" group="gripper" parent_group="manipulator"/>
  <virtual_joint name="virtual_joint" type="fixed" parent_frame="odom" child_link="world"/>
  <!-- pairs -->
  <disable_collisions link1="base_link" link2="link1" reason="Adjacent"/>
  <disable_collisions link1="base_link" link2="link2" reason="Never"/>
  <disable_collisions link1="link3" link2="link1" reason="Never"/>
  <disable_collisions link1="link4" link2="base_link" reason="User"/>
</robot>
)";

// true when one of the setup's notes contains `text` (all of them printed otherwise).
::testing::AssertionResult HasNote(const RobotSetup& setup, const std::string& text) {
  std::string all;
  for (const std::string& n : setup.notes) {
    if (n.find(text) != std::string::npos) return ::testing::AssertionSuccess();
    all += "\n  " + n;
  }
  return ::testing::AssertionFailure() << "no note contains '" << text << "'; the notes:" << all;
}

RobotSetupOptions FewSamples() {
  RobotSetupOptions options;
  options.samples = 300;
  return options;
}

// the (link, link) names of a setup's exclusions for one reason, each pair sorted by name.
std::set<std::pair<std::string, std::string>> PairsFor(const RobotSetup& setup, ExclusionReason reason) {
  std::set<std::pair<std::string, std::string>> pairs;
  for (const Exclusion& e : setup.exclusions) {
    if (e.reason != reason) continue;
    const std::string a = setup.robot.model.link(e.link_a).name, b = setup.robot.model.link(e.link_b).name;
    pairs.insert(std::minmax(a, b));
  }
  return pairs;
}

TEST(Srdf, ReadsPairsWithReasonsEndEffectorsVirtualJointsAndGroups) {
  const fs::path dir = TempDir("parse");
  Write(dir / "arm.srdf", kArmSrdf);
  const Srdf srdf = LoadSrdf(dir / "arm.srdf");
  EXPECT_EQ(srdf.robot_name, "arm");
  EXPECT_EQ(srdf.source, (dir / "arm.srdf").string());
  ASSERT_EQ(srdf.disabled_collisions.size(), 4u);
  EXPECT_EQ(srdf.disabled_collisions[1].link1, "base_link");
  EXPECT_EQ(srdf.disabled_collisions[1].link2, "link2");
  EXPECT_EQ(srdf.disabled_collisions[1].reason, "Never");
  EXPECT_EQ(srdf.disabled_collisions[3].reason, "User");
  EXPECT_EQ(srdf.disabled_collisions[3].line, 11);
  ASSERT_EQ(srdf.end_effectors.size(), 1u);
  EXPECT_EQ(srdf.end_effectors[0].name, "tool");
  EXPECT_EQ(srdf.end_effectors[0].parent_link, "link3");
  EXPECT_EQ(srdf.end_effectors[0].group, "gripper");
  EXPECT_EQ(srdf.end_effectors[0].parent_group, "manipulator");
  ASSERT_EQ(srdf.virtual_joints.size(), 1u);
  EXPECT_EQ(srdf.virtual_joints[0].name, "virtual_joint");
  EXPECT_EQ(srdf.virtual_joints[0].type, "fixed");
  EXPECT_EQ(srdf.virtual_joints[0].parent_frame, "odom");
  EXPECT_EQ(srdf.virtual_joints[0].child_link, "world");
  ASSERT_EQ(srdf.groups.size(), 2u);
  ASSERT_EQ(srdf.groups[0].chains.size(), 1u);
  EXPECT_EQ(srdf.groups[0].chains[0].base_link, "base_link");
  EXPECT_EQ(srdf.groups[0].chains[0].tip_link, "link4");
  EXPECT_EQ(srdf.groups[1].links, std::vector<std::string>{"link4"});
  EXPECT_EQ(srdf.groups[1].joints, std::vector<std::string>{"j4"});
  EXPECT_EQ(srdf.groups[1].subgroups, std::vector<std::string>{"manipulator"});
  // every name is the URDF's (the virtual joint counts as a joint of a group): no warning
  EXPECT_TRUE(CheckSrdfAgainstModel(srdf, ParseUrdfModel(kArmUrdf, "arm.urdf")).empty());
}

TEST(Srdf, MalformedXmlAndAWrongRootNameTheFile) {
  const fs::path dir = TempDir("malformed");
  Write(dir / "broken.srdf", "<robot name=\"arm\">\n  <disable_collisions link1=\"a\" link2=\"b\">\n</robot>\n");
  try {
    LoadSrdf(dir / "broken.srdf");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find((dir / "broken.srdf").string()), std::string::npos) << what;
    EXPECT_NE(what.find("not valid XML"), std::string::npos) << what;
  }
  try {
    ParseSrdf("<?xml version=\"1.0\"?><semantic/>", "s.srdf");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("s.srdf: not an SRDF: expected the root element <robot>, got <semantic>"),
              std::string::npos) << e.what();
  }
  try {
    LoadSrdf(dir / "absent.srdf");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("absent.srdf: cannot open"), std::string::npos) << e.what();
  }
  try {
    ParseSrdf("<robot name=\"arm\">\n<disable_collisions link1=\"a\" reason=\"Never\"/></robot>", "p.srdf");
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("p.srdf:2: <disable_collisions>: expected a non-empty attribute link2"),
              std::string::npos) << e.what();
  }
}

TEST(Srdf, AnEndEffectorOrVirtualJointOnAnUnknownLinkIsAnErrorNamingFileElementAndLink) {
  const Model model = ParseUrdfModel(kArmUrdf, "arm.urdf");
  const Srdf ee = ParseSrdf(R"(<robot name="arm">
  <end_effector name="hand" parent_link="panda_link8" group="hand"/>
</robot>)", "other.srdf");
  try {
    CheckSrdfAgainstModel(ee, model);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("other.srdf:2: <end_effector name=\"hand\"> parent_link: expected one of the URDF's links "
                        "(world, base_link, link1"), std::string::npos) << what;
    EXPECT_NE(what.find("got 'panda_link8'"), std::string::npos) << what;
  }
  const Srdf vj = ParseSrdf(
      R"(<robot name="arm"><virtual_joint name="v" type="planar" parent_frame="odom" child_link="base_footprint"/>)"
      "</robot>",
      "mobile.srdf");
  try {
    CheckSrdfAgainstModel(vj, model);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("mobile.srdf:1: <virtual_joint name=\"v\"> child_link"), std::string::npos) << what;
    EXPECT_NE(what.find("got 'base_footprint'"), std::string::npos) << what;
  }
}

TEST(Srdf, UnknownLinksOfPairsAndGroupsAreWarningsAsInMoveIt) {
  const Model model = ParseUrdfModel(kArmUrdf, "arm.urdf");
  const Srdf srdf = ParseSrdf(R"(<robot name="arm_with_hand">
  <group name="hand"><link name="finger"/><joint name="finger_joint"/></group>
  <disable_collisions link1="link4" link2="finger" reason="Adjacent"/>
</robot>)", "hand.srdf");
  const std::vector<std::string> warnings = CheckSrdfAgainstModel(srdf, model);
  ASSERT_EQ(warnings.size(), 3u);
  EXPECT_NE(warnings[0].find("<robot name=\"arm_with_hand\">: expected the URDF's robot name 'arm'"), std::string::npos)
      << warnings[0];
  EXPECT_NE(warnings[1].find("hand.srdf:3: <disable_collisions link1=\"link4\" link2=\"finger\">: no link 'finger' in "
                             "the URDF: pair skipped"), std::string::npos) << warnings[1];
  EXPECT_NE(warnings[2].find("<group name=\"hand\">: not in the URDF: link 'finger', joint 'finger_joint'"),
            std::string::npos) << warnings[2];
}

TEST(Srdf, SetupExcludesExactlyTheSrdfsPairsAndTakesItsEndEffector) {
  const fs::path dir = TempDir("setup");
  Write(dir / "arm.urdf", kArmUrdf);
  Write(dir / "arm.srdf", kArmSrdf);
  const RobotSetup setup = SetupRobot(dir / "arm.urdf", FewSamples());
  const Model& m = setup.robot.model;
  EXPECT_EQ(setup.srdf, dir / "arm.srdf");
  using Pairs = std::set<std::pair<std::string, std::string>>;
  // base_link–link1 is parent–child: excluded already, not listed again
  EXPECT_EQ(PairsFor(setup, ExclusionReason::kSrdf),
            (Pairs{{"base_link", "link2"}, {"link1", "link3"}, {"base_link", "link4"}}));
  for (const Exclusion& e : setup.exclusions) {
    if (e.reason != ExclusionReason::kSrdf) continue;
    EXPECT_EQ(e.srdf_reason, m.link(e.link_b).name == "link4" || m.link(e.link_a).name == "link4" ? "User" : "Never");
  }
  for (const auto& [a, b] :
       Pairs{{"base_link", "link1"}, {"base_link", "link2"}, {"link1", "link3"}, {"base_link", "link4"}}) {
    EXPECT_TRUE(setup.robot.IsExcludedPair(m.LinkIndex(a), m.LinkIndex(b))) << a << " " << b;
  }
  // sampling ran over the other pairs and did not list an SRDF pair a second time
  std::set<std::pair<int, int>> listed;
  for (const Exclusion& e : setup.exclusions) EXPECT_TRUE(listed.insert({e.link_a, e.link_b}).second);
  EXPECT_EQ(m.link(setup.robot.end_effector.link).name, "link3");
  EXPECT_NE(setup.end_effector_from.find("arm.srdf's end effector 'tool'"), std::string::npos)
      << setup.end_effector_from;
  EXPECT_TRUE(HasNote(setup, "of the same name): 4 disabled pairs: 3 excluded as disabled in the SRDF, 1 already "
                              "excluded"));

  const std::string yaml = CollisionYamlText(setup);
  EXPECT_NE(yaml.find("link: link3    # the parent link of arm.srdf's end effector 'tool'"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("- [base_link, link4]   # disabled in the SRDF (User)"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("the disabled pairs of arm.srdf, then the others sampled"), std::string::npos) << yaml;
  // the written YAML loads with those pairs
  Write(dir / "arm.collision.yaml", yaml);
  const Robot loaded = LoadRobot(dir / "arm.urdf", dir / "arm.collision.yaml");
  for (const auto& [a, b] : setup.robot.excluded_pairs) EXPECT_TRUE(loaded.IsExcludedPair(a, b)) << a << " " << b;
  EXPECT_EQ(loaded.end_effector.link, setup.robot.end_effector.link);
}

TEST(Srdf, EndEffectorOptionWinsAndNoSrdfTurnsItOff) {
  const fs::path dir = TempDir("precedence");
  Write(dir / "arm.urdf", kArmUrdf);
  Write(dir / "moveit.srdf", kArmSrdf);  // another name: the only SRDF beside the URDF
  RobotSetupOptions options = FewSamples();
  options.end_effector = "link4";
  const RobotSetup given = SetupRobot(dir / "arm.urdf", options);
  EXPECT_EQ(given.srdf, dir / "moveit.srdf");
  EXPECT_EQ(given.robot.model.link(given.robot.end_effector.link).name, "link4");
  EXPECT_EQ(given.end_effector_from, "--ee");
  EXPECT_EQ(PairsFor(given, ExclusionReason::kSrdf).size(), 3u);
  EXPECT_TRUE(HasNote(given, "(the only SRDF beside the URDF)"));

  options = FewSamples();
  options.use_srdf = false;
  const RobotSetup off = SetupRobot(dir / "arm.urdf", options);
  EXPECT_TRUE(off.srdf.empty());
  EXPECT_TRUE(PairsFor(off, ExclusionReason::kSrdf).empty());
  EXPECT_EQ(off.robot.model.link(off.robot.end_effector.link).name, "tool0");
  options.srdf = dir / "moveit.srdf";
  EXPECT_THROW(SetupRobot(dir / "arm.urdf", options), InputError);  // a path with use_srdf off

  // two SRDFs, neither of the URDF's name: none is used, and a warning says so
  Write(dir / "other.srdf", kArmSrdf);
  const RobotSetup two = SetupRobot(dir / "arm.urdf", FewSamples());
  EXPECT_TRUE(two.srdf.empty());
  EXPECT_TRUE(std::any_of(two.warnings.begin(), two.warnings.end(), [](const std::string& w) {
    return w.find("2 SRDFs beside the URDF (moveit.srdf, other.srdf)") != std::string::npos;
  }));
  // an explicit SRDF of another robot: the error names it and the link
  Write(dir / "panda.srdf",
        R"(<robot name="panda"><end_effector name="hand" parent_link="panda_link8" group="hand"/></robot>)");
  options = FewSamples();
  options.srdf = dir / "panda.srdf";
  try {
    SetupRobot(dir / "arm.urdf", options);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find((dir / "panda.srdf").string()), std::string::npos) << what;
    EXPECT_NE(what.find("got 'panda_link8'"), std::string::npos) << what;
  }
}

// MotionBenchMaker's Panda with the SRDF it was made with: every disabled pair is excluded.
TEST(Srdf, TheToolFrameFixedBelowTheEndEffectorsParentLinkIsTheEndEffector) {
  const fs::path dir = TempDir("tool");
  Write(dir / "arm.urdf", kArmUrdf);
  std::string srdf = kArmSrdf;
  const std::string from = "parent_link=\"link3\"";
  srdf.replace(srdf.find(from), from.size(), "parent_link=\"link4\"");
  Write(dir / "arm.srdf", srdf);
  const RobotSetup setup = SetupRobot(dir / "arm.urdf", FewSamples());
  EXPECT_EQ(setup.robot.model.link(setup.robot.end_effector.link).name, "tool0");  // link4 → flange → tool0, fixed
  EXPECT_NE(setup.end_effector_from.find("the tool frame fixed below link4"), std::string::npos)
      << setup.end_effector_from;
}

TEST(Srdf, AnotherRobotsSrdfFoundBesideTheUrdfIsNotUsedAndSaysWhy) {
  const fs::path dir = TempDir("other");
  Write(dir / "arm.urdf", kArmUrdf);
  Write(dir / "moveit.srdf", R"(<?xml version="1.0"?>
<robot name="other"><end_effector name="hand" parent_link="panda_link8" group="hand"/></robot>
)");
  const RobotSetup setup = SetupRobot(dir / "arm.urdf", FewSamples());
  EXPECT_TRUE(setup.srdf.empty());
  EXPECT_TRUE(PairsFor(setup, ExclusionReason::kSrdf).empty());
  bool said = false;
  for (const std::string& w : setup.warnings) {
    said |= w.find("moveit.srdf (the only SRDF beside the URDF) is not used") != std::string::npos &&
            w.find("panda_link8") != std::string::npos;
  }
  EXPECT_TRUE(said);
  // the same file given with --srdf is this robot's by the user's word: an error naming the link
  RobotSetupOptions options = FewSamples();
  options.srdf = dir / "moveit.srdf";
  EXPECT_THROW(SetupRobot(dir / "arm.urdf", options), InputError);
}

TEST(Srdf, EveryDisabledPairOfTheMbmPandaSrdfIsExcluded) {
#ifdef RMPMARL_MBM_PANDA_DIR
  const fs::path set = RMPMARL_MBM_PANDA_DIR;
#else
  const fs::path set;
#endif
  if (set.empty() || !fs::is_regular_file(set / "panda.srdf")) {
    GTEST_SKIP() << "MotionBenchMaker's Panda set (panda.urdf + panda.srdf) is absent";
  }
  RobotSetupOptions options;
  options.samples = 200;
  options.package_paths = {set};
  const RobotSetup setup = SetupRobot(set / "panda.urdf", options);
  EXPECT_EQ(setup.srdf, set / "panda.srdf");
  const Srdf srdf = LoadSrdf(set / "panda.srdf");
  ASSERT_EQ(srdf.disabled_collisions.size(), 34u);
  const Model& m = setup.robot.model;
  for (const SrdfDisabledPair& p : srdf.disabled_collisions) {
    EXPECT_TRUE(setup.robot.IsExcludedPair(m.LinkIndex(p.link1), m.LinkIndex(p.link2))) << p.link1 << " " << p.link2;
  }
  // the SRDF's end effector hangs on panda_link8; the hand is the tool frame fixed below it
  EXPECT_EQ(m.link(setup.robot.end_effector.link).name, "panda_hand");
  EXPECT_NE(setup.end_effector_from.find("fixed below panda_link8"), std::string::npos) << setup.end_effector_from;
}

}  // namespace
}  // namespace rmpmarl::setup
