// The CLI from the outside: exit codes and messages for good and bad robot descriptions.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <regex>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "run_cli.h"

namespace {
namespace fs = std::filesystem;
using rmpmarl::kinematics::ModelsDirectory;

using rmpmarl::test::CommandResult;
using rmpmarl::test::RunCli;

const std::string kData = RMPMARL_TEST_DATA_DIR;

TEST(CliTest, CheckRobotPrintsAValidRobot) {
  const CommandResult r = RunCli("check-robot " + kData + "/robots/tree/tree.urdf " + kData + "/robots/tree/collision.yaml");
  EXPECT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("robot 'tree': 8 links, 6 joints"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("j1_slider"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("prismatic"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("end effector: on 'tool_a'"), std::string::npos) << r.output;
}

TEST(CliTest, CheckRobotFailsClearlyOnMissingFile) {
  const CommandResult r = RunCli("check-robot /no/such.urdf /no/such.yaml");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("rmpmarl: error: check-robot /no/such.urdf: no such file"), std::string::npos) << r.output;
  // a shipped robot's name is pointed at its file
  const CommandResult shipped = RunCli("check-robot panda");
  EXPECT_EQ(shipped.exit_code, 2) << shipped.output;
  EXPECT_NE(shipped.output.find("'panda' is a shipped robot, whose description is"), std::string::npos)
      << shipped.output;
}

// what a new user mistypes is refused at once, naming the input, what was expected and what was given
TEST(CliTest, MistypedArgumentsAreRefusedWithTheReason) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"demo --seed -1", "--seed: expected a seed: a whole number from 0 to 2^64 − 1, got '-1'"},
      {"eval models/policies/marl-rmp.rmpp --seed -3", "--seed: expected a seed"},
      {"demo --duration 0", "--duration: Value 0 not in range"},
      {"experiment table4 --methods \"\"", "--methods: expected method keys separated by commas"},
      {"demo --robot pandaa", "--robot: expected a shipped robot, one of gen3, iiwa14, irb120, panda, ur5e, xarm6 (a "
                              "robot of your own: --urdf FILE), got 'pandaa'"},
      {"demo --urdf /nope/arm.urdf", "--urdf: expected an existing .urdf file, got '/nope/arm.urdf' (no such file)"},
      {"demo --policy rmpflo", "--policy rmpflo: no such controller file (expected a .rmpp file, or `rmpflow` for "
                               "RMPflow alone)"},
  };
  for (const auto& [args, message] : cases) {
    SCOPED_TRACE(args);
    const CommandResult r = RunCli(args);
    EXPECT_NE(r.exit_code, 0) << r.output;
    EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
    EXPECT_EQ(r.output.find("planar2"), std::string::npos) << r.output;  // not a robot --robot takes
  }
}

TEST(CliTest, CheckRobotFailsClearlyOnMismatchedYaml) {
  // the tree URDF with planar-style YAML of another robot: the robot name check fires
  const CommandResult r = RunCli("check-robot " + kData + "/robots/tree/tree.urdf " + kData + "/robots/bad/wrong_robot.yaml");
  EXPECT_EQ(r.exit_code, 2) << r.output;
  EXPECT_NE(r.output.find("key 'robot': expected the URDF's robot name 'tree', got 'other'"), std::string::npos)
      << r.output;
}

TEST(CliTest, MissingArgumentsIsAUsageError) {
  const CommandResult r = RunCli("check-robot");
  EXPECT_NE(r.exit_code, 0);
  EXPECT_NE(r.output.find("required"), std::string::npos) << r.output;
}

// the row `name` of the comparison table: its two columns
std::pair<std::string, std::string> Row(const std::string& output, const std::string& name) {
  const size_t at = output.find("  " + name);
  if (at == std::string::npos) return {};
  std::istringstream line(output.substr(at + 2 + name.size(), output.find('\n', at) - at - 2 - name.size()));
  std::string a, unit_a, b, unit_b;
  line >> a >> unit_a >> b >> unit_b;
  return {a, b};
}

// the words after `name` on its line of the output
std::vector<std::string> Cells(const std::string& output, const std::string& name) {
  const size_t at = output.find("  " + name);
  if (at == std::string::npos) return {};
  std::istringstream line(output.substr(at + 2 + name.size(), output.find('\n', at) - at - 2 - name.size()));
  std::vector<std::string> cells;
  for (std::string cell; line >> cell;) cells.push_back(cell);
  return cells;
}

// `make demo`'s job: the shipped default controller (marl-rmp-residual, its basic layer read from its own file) and
// RMPflow on one reach-avoid episode; at seed 3 both succeed
TEST(CliTest, DefaultDemoRunsTheShippedResidualBesideRmpflow) {
  const CommandResult r = RunCli("demo --seed 3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("models/policies/marl-rmp-residual.rmpp"), std::string::npos) << r.output;
  // its layer, from the file: the coupled resolve with the hand gate as the prior of the target stiffness
  EXPECT_NE(r.output.find("coupled basic layer, look-ahead 1 s, hand gate under the target stiffness at 0.15 m"),
            std::string::npos) << r.output;
  // what happened, in words: both reached the target and neither touched an obstacle
  EXPECT_EQ(Cells(r.output, "reached (within 20 mm)"), (std::vector<std::string>{"yes", "yes"})) << r.output;
  EXPECT_EQ(Cells(r.output, "collision-free"), (std::vector<std::string>{"yes", "yes"})) << r.output;
}

// `make demo`'s job: plan + the controller for cells, plan + RMPflow and the plan open loop on the same generated
// cells; each success rate with its Wilson interval (checked against the formula) and no more successes than goals
// reached; --record is for one episode only
TEST(CliTest, DemoEpisodesPrintsSuccessRatesOfThreeWaysOnTheSameCells) {
  const CommandResult r =
      RunCli("demo --scenario cells --plan --episodes 3 --policy " +
             (ModelsDirectory() / "policies" / "marl-rmp-gated.rmpp").string());
  ASSERT_EQ(r.exit_code, 0) << r.output;
  std::smatch header;
  ASSERT_TRUE(std::regex_search(r.output, header,
                                std::regex(R"(plan \+ marl-rmp-gated +plan \+ RMPflow +plan, open loop)")))
      << r.output;
  std::smatch row;
  ASSERT_TRUE(std::regex_search(r.output, row, std::regex(R"(success \[95 % CI\] +(.*))"))) << r.output;
  const std::string cells = row[1];
  const std::regex cell(R"((\d+)/3 (\d+) % \[(\d+), (\d+)\])");
  std::vector<int> successes;
  for (auto it = std::sregex_iterator(cells.begin(), cells.end(), cell); it != std::sregex_iterator(); ++it) {
    const int k = std::stoi((*it)[1]);
    successes.push_back(k);
    // Wilson's score interval at z = 1.96, by hand
    const double n = 3.0, p = k / n, z = 1.959963984540054;
    const double centre = (p + z * z / (2 * n)) / (1 + z * z / n);
    const double half = z * std::sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n);
    EXPECT_EQ(std::stoi((*it)[3]), static_cast<int>(std::lround(100 * (centre - half))));
    EXPECT_EQ(std::stoi((*it)[4]), static_cast<int>(std::lround(100 * (centre + half))));
  }
  ASSERT_EQ(successes.size(), 3u) << cells;
  const std::vector<std::string> reached = Cells(r.output, "reached (within 20 mm)");
  ASSERT_EQ(reached.size(), 3u) << r.output;
  for (int i = 0; i < 3; ++i) EXPECT_LE(successes[i], std::stoi(reached[i])) << r.output;
  const CommandResult refused = RunCli("demo --episodes 2 --record /tmp/never.json");
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.output.find("--record: one episode only"), std::string::npos) << refused.output;
}

// a run stopped by --duration reports what it did, not an empty episode (it printed 0.0 mm, "–" and 0.0 µs)
TEST(CliTest, DemoDurationReportsTheShortenedRun) {
  const CommandResult r = RunCli("demo --seed 3 --duration 2");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("2.0 s simulated: the learned"), std::string::npos) << r.output;
  for (const char* row : {"tracking error (mean)", "settled (t >= 1 s)", "control step"}) {
    const auto [learned, rmpflow] = Row(r.output, row);
    SCOPED_TRACE(row);
    ASSERT_FALSE(learned.empty()) << r.output;
    EXPECT_GT(std::stod(learned), 0.0) << r.output;
    EXPECT_GT(std::stod(rmpflow), 0.0) << r.output;
  }
  // RMPflow alone honours it too
  const CommandResult alone = RunCli("demo --policy rmpflow --seed 3 --duration 2");
  ASSERT_EQ(alone.exit_code, 0) << alone.output;
  EXPECT_NE(alone.output.find("2.0 s simulated"), std::string::npos) << alone.output;
  EXPECT_NE(alone.output.find("RMPflow alone"), std::string::npos) << alone.output;
  EXPECT_GT(std::stod(Row(alone.output, "tracking error (mean)").first), 0.0) << alone.output;
}

// the learned default runs beside RMPflow in the line-crossing scene (a URDF without a collision YAML:
// SetupRobotCli.DemoWithoutYamlFitsInMemory)
TEST(CliTest, DemoRunsTheLearnedAgentsInEveryArmScene) {
  const CommandResult line = RunCli("demo --scenario line-crossing --obstacle-speed 2.8 --seed 1");
  ASSERT_EQ(line.exit_code, 0) << line.output;
  EXPECT_NE(line.output.find("task 'line-crossing'"), std::string::npos) << line.output;
  EXPECT_NE(line.output.find("marl-rmp-residual"), std::string::npos) << line.output;
  const CommandResult clutter = RunCli("demo --scenario cluttered --robot iiwa14 --seed 1 --duration 2");
  ASSERT_EQ(clutter.exit_code, 0) << clutter.output;
  EXPECT_NE(clutter.output.find("iiwa14 (7 dof), scenario 'cluttered'"), std::string::npos) << clutter.output;
  // what cannot fit is refused with the reason
  const CommandResult stat = RunCli("demo --policy " + (ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string() +
                                    " --scenario static-reach");
  EXPECT_EQ(stat.exit_code, 2) << stat.output;
  EXPECT_NE(stat.output.find("run RMPflow alone"), std::string::npos) << stat.output;
}

// values no user means are refused at once with the allowed range, instead of running for minutes
TEST(CliTest, DemoRefusesUnreasonableSizesWithTheAllowedRange) {
  for (const char* args : {"demo --obstacles 100000", "demo --duration 1e9", "demo --width 100000",
                           "demo --fps 0", "demo --obstacle-speed 1000"}) {
    const CommandResult r = RunCli(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.output.find("not in range"), std::string::npos) << args << ": " << r.output;
  }
}

TEST(CliTest, TrainEvalAndRobotsRefuseUnreasonableSizesWithTheAllowedRange) {
  std::vector<std::string> cases = {"robots --duration 1e9", "robots --duration 0"};
  if (RunCli("train --help").exit_code == 0) {  // built with libtorch
    for (const char* c : {"train c.yaml --updates 0", "train c.yaml --updates 100000000",
                          "train c.yaml --env-threads 100000", "train c.yaml --torch-threads 0",
                          "train c.yaml --envs 0", "train c.yaml --envs 5000",
                          "eval p.rmpp --episodes 0", "eval p.rmpp --episodes 1000000000",
                          "eval p.rmpp --envs 1000000", "eval p.rmpp --env-threads 0"}) {
      cases.push_back(c);
    }
  }
  for (const std::string& args : cases) {
    const CommandResult r = RunCli(args);
    EXPECT_NE(r.exit_code, 0) << args;
    EXPECT_NE(r.output.find("not in range"), std::string::npos) << args << ": " << r.output;
  }
}

}  // namespace
