// The CLI from the outside: exit codes and messages for good and bad robot descriptions.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>
#include <vector>

namespace {

struct CommandResult {
  int exit_code = -1;
  std::string output;  // stdout and stderr together
};

// runs the rmpmarl CLI with `args` and captures its output and exit code.
CommandResult RunCli(const std::string& args) {
  const std::string command = std::string(RMPMARL_CLI_PATH) + " " + args + " 2>&1";
  CommandResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return result;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

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
  EXPECT_NE(r.output.find("rmpmarl: error: /no/such.urdf: cannot open URDF file"), std::string::npos) << r.output;
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

// `make demo`'s job: the shipped coupled-layer agents (marl-rmp-v2c-gate, on the basic layer written beside them) and
// RMPflow on one reach-avoid episode; at seed 3 both succeed
TEST(CliTest, DefaultDemoRunsTheShippedCoupledAgentsBesideRmpflow) {
  const CommandResult r = RunCli("demo --seed 3");
  ASSERT_EQ(r.exit_code, 0) << r.output;
  EXPECT_NE(r.output.find("models/policies/marl-rmp-v2c-gate.rmpp"), std::string::npos) << r.output;
  // its layer carries the hand gate as the prior of the target stiffness
  EXPECT_NE(r.output.find("target_gate_clearance: 0.15"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("resolve: coupled"), std::string::npos) << r.output;
  const size_t result = r.output.find("  result ");
  ASSERT_NE(result, std::string::npos) << r.output;
  const std::string line = r.output.substr(result, r.output.find('\n', result) - result);
  EXPECT_EQ(line.find("FAILURE"), std::string::npos) << line;
  EXPECT_NE(line.find("success"), line.rfind("success")) << line;  // both columns
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
