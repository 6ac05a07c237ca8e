// `rmpmarl experiment table4 --quick`: the whole pipeline (training, evaluation of every method, CSV, report, plot)
// in a temporary directory; checks the report's shape, not its numbers.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

namespace {
namespace fs = std::filesystem;

std::string Read(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST(ExperimentCliTest, Table4QuickWritesEveryMethodRowCsvAndPlot) {
  const fs::path dir = fs::temp_directory_path() / ("rmpmarl_table4_quick_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string command = std::string(RMPMARL_CLI_PATH) + " experiment table4 --quick --seeds 1 --out " +
                              (dir / "table4").string() + " --runs " + (dir / "runs").string() + " > " +
                              (dir.string() + ".log") + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << Read(dir.string() + ".log");
  const std::string report = Read(dir / "table4" / "report.md");
  for (const char* method : {"| PPO |", "| MAPPO (no pre-training) |", "| MARL-PPO |", "| RMPflow |", "| RRT |",
                             "| MARL-RMP |", "| basic layer (target option) |", "| basic layer (target-then-collision) |",
                             "| MARL-RMP (v0 basic layer) |", "| basic layer v0 (target-then-collision) |",
                             "| MARL-RMP (2 ms basic layer) |", "| basic layer 2 ms (target-then-collision) |",
                             "| MARL-RMP (v2) |", "| basic layer v2 (target-then-collision) |",
                             "| basic layer v2 (target-then-collision, collision scale 1/4) |",
                             "| RMPflow (tuned collision gains) |",
                             "| MAPPO over the v2 layer (composite option fixed, parameters learned, 300 updates) |",
                             "| basic layer v2, coupled resolve (target-then-collision) |"}) {
    EXPECT_NE(report.find(method), std::string::npos) << method;
  }
  for (const char* speed : {"0.2 m/s", "0.6 m/s", "1.2 m/s", "1.8 m/s", "2.8 m/s"}) {
    EXPECT_NE(report.find(speed), std::string::npos) << speed;
  }
  const std::string csv = Read(dir / "table4" / "results.csv");
  EXPECT_EQ(csv.rfind("method,condition,train_seed,episodes,success_rate,tracking_mm,settled_tracking_mm,"
                      "collisions_per_episode", 0), 0u);
  // 67 methods (49 learned + 18 basic-layer and baseline rows) x 5 speeds, one training seed: 335 rows + header
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 336);
  // a label with a comma is one quoted CSV field (RFC 4180), so the plots read the right columns
  EXPECT_NE(csv.find("\n\"basic layer v2 (target-then-collision, collision scale 1/4)\",0.2 m/s,0,"), std::string::npos);
  EXPECT_TRUE(fs::exists(dir / "table4" / "table4_success.png"));
  EXPECT_GT(fs::file_size(dir / "table4" / "table4_success.png"), 1000u);
  // a second run reuses the finished training runs
  ASSERT_EQ(std::system(command.c_str()), 0);
  EXPECT_NE(Read(dir.string() + ".log").find("finished before, reused"), std::string::npos);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".log");
}

// --shipped: the shipped MARL-RMP against RMPflow with no training at all
TEST(ExperimentCliTest, ShippedPoliciesAreEvaluatedWithoutTraining) {
  const fs::path dir = fs::temp_directory_path() / ("rmpmarl_table4_shipped_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string command = std::string(RMPMARL_CLI_PATH) + " experiment table4 --shipped --episodes 1 "
                              "--methods marl-rmp,rmpflow,marl-ppo,marl-rmp-v2c-gate-residual-kernel-gated --no-plots --out " + (dir / "table4").string() +
                              " --runs " + (dir / "runs").string() + " > " + (dir.string() + ".log") + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << Read(dir.string() + ".log");
  const std::string report = Read(dir / "table4" / "report.md");
  EXPECT_NE(report.find("| MARL-RMP | 2.8 m/s |"), std::string::npos);
  EXPECT_NE(report.find("| RMPflow | 2.8 m/s |"), std::string::npos);
  // a recipe whose shipped file has another name (models/policies/marl-rmp-residual.rmpp)
  EXPECT_NE(report.find("| MAPPO residual over the hand gate (coupled v2 layer, look-ahead), precision kernel paid only "
                        "while no pass is predicted | 2.8 m/s |"), std::string::npos);
  EXPECT_EQ(report.find("| MARL-PPO |"), std::string::npos);  // no shipped policy: left out, and said so
  EXPECT_NE(Read(dir.string() + ".log").find("MARL-PPO has no shipped policy"), std::string::npos);
  EXPECT_FALSE(fs::exists(dir / "runs"));  // nothing trained
  fs::remove_all(dir);
  fs::remove(dir.string() + ".log");
}

// fig5's split of each arm's episodes by the pure tracker: fixed methods only, two arms
TEST(ExperimentCliTest, Fig5SplitsTheEpisodesByThePureTracker) {
  const fs::path dir = fs::temp_directory_path() / ("rmpmarl_fig5_split_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string command = std::string(RMPMARL_CLI_PATH) + " experiment fig5 --quick --episodes 4 "
                              "--methods basic-target-v2c-stiff,basic-ttc-v2c-stiff --no-plots --out " +
                              (dir / "fig5").string() + " --runs " + (dir / "runs").string() + " > " +
                              (dir.string() + ".log") + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << Read(dir.string() + ".log");
  const std::string report = Read(dir / "fig5" / "report.md");
  const size_t split = report.find("## Where the cube blocks the arm");
  ASSERT_NE(split, std::string::npos) << report;
  // one row per method, two columns (free, blocked) per arm; the parts of the reference add up to its 4 episodes
  EXPECT_NE(report.find("| basic layer v2, coupled resolve (target-then-collision, target stiffness x4) |", split),
            std::string::npos);
  const size_t header = report.find("| method |", split);
  ASSERT_NE(header, std::string::npos);
  const std::string line = report.substr(header, report.find('\n', header) - header);
  EXPECT_EQ(std::count(line.begin(), line.end(), '|'), 1 + 1 + 2 * 2) << line;
  const std::regex part(R"((\w+): free \((\d+)\) \| (\w+): blocked \((\d+)\))");
  int arms = 0;
  for (auto it = std::sregex_iterator(line.begin(), line.end(), part); it != std::sregex_iterator(); ++it, ++arms) {
    EXPECT_EQ((*it)[1], (*it)[3]) << line;
    EXPECT_EQ(std::stoi((*it)[2]) + std::stoi((*it)[4]), 4) << line;
  }
  EXPECT_EQ(arms, 2) << line;
  fs::remove_all(dir);
  fs::remove(dir.string() + ".log");
}

}  // namespace
