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
#include <vector>

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
  // the default methods: the paper's seven and the project's three
  for (const char* method : {"| PPO |", "| MAPPO (no pre-training) |", "| MARL-PPO |", "| HRL-RMP |", "| MARL-RMP |",
                             "| RMPflow |", "| RRT |", "| RMPflow-tuned |", "| Hand gate (ours) |",
                             "| MARL-RMP residual (ours) |"}) {
    EXPECT_NE(report.find(method), std::string::npos) << method;
  }
  for (const char* speed : {"0.2 m/s", "0.6 m/s", "1.2 m/s", "1.8 m/s", "2.8 m/s"}) {
    EXPECT_NE(report.find(speed), std::string::npos) << speed;
  }
  const std::string csv = Read(dir / "table4" / "results.csv");
  EXPECT_EQ(csv.rfind("method,condition,train_seed,episodes,success_rate,tracking_mm,settled_tracking_mm,"
                      "collisions_per_episode", 0), 0u);
  // 10 methods (6 learned, 4 untrained) x 5 speeds, one training seed: 50 rows + header
  EXPECT_EQ(std::count(csv.begin(), csv.end(), '\n'), 51);
  EXPECT_TRUE(fs::exists(dir / "table4" / "table4_success.png"));
  EXPECT_GT(fs::file_size(dir / "table4" / "table4_success.png"), 1000u);
  // a second run reuses the finished training runs
  ASSERT_EQ(std::system(command.c_str()), 0);
  EXPECT_NE(Read(dir.string() + ".log").find("finished before, reused"), std::string::npos);
  fs::remove_all(dir);
  fs::remove(dir.string() + ".log");
}

// --list: the default method keys, one per line, the paper's seven among them
TEST(ExperimentCliTest, ListPrintsTheDefaultMethodKeys) {
  const fs::path out = fs::temp_directory_path() / ("rmpmarl_list_" + std::to_string(::getpid()));
  ASSERT_EQ(std::system((std::string(RMPMARL_CLI_PATH) + " experiment table4 --list > " + out.string()).c_str()), 0);
  std::istringstream lines(Read(out));
  std::vector<std::string> keys;
  for (std::string k; std::getline(lines, k);) keys.push_back(k);
  fs::remove(out);
  EXPECT_GE(keys.size(), 7u);
  EXPECT_LE(keys.size(), 12u);
  for (const char* paper : {"hrl-rmp", "marl-rmp", "ppo", "mappo", "marl-ppo", "rmpflow", "rrt"}) {
    EXPECT_NE(std::find(keys.begin(), keys.end(), paper), keys.end()) << paper;
  }
  EXPECT_NE(std::find(keys.begin(), keys.end(), "marl-rmp-residual"), keys.end());
}

// --shipped: the shipped MARL-RMP against RMPflow with no training at all
TEST(ExperimentCliTest, ShippedPoliciesAreEvaluatedWithoutTraining) {
  const fs::path dir = fs::temp_directory_path() / ("rmpmarl_table4_shipped_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  const std::string command = std::string(RMPMARL_CLI_PATH) + " experiment table4 --shipped --episodes 1 "
                              "--methods marl-rmp,rmpflow,marl-ppo,marl-rmp-residual,basic-ttc-v2-gentle --no-plots --out " + (dir / "table4").string() +
                              " --runs " + (dir / "runs").string() + " > " + (dir.string() + ".log") + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << Read(dir.string() + ".log");
  const std::string report = Read(dir / "table4" / "report.md");
  EXPECT_NE(report.find("| MARL-RMP | 2.8 m/s |"), std::string::npos);
  EXPECT_NE(report.find("| RMPflow | 2.8 m/s |"), std::string::npos);
  EXPECT_NE(report.find("| MARL-RMP residual (ours) | 2.8 m/s |"), std::string::npos);
  // an ablation runs by its key (configs/ablations/); a label with a comma is one quoted CSV field (RFC 4180), so
  // the plots read the right columns
  const std::string csv = Read(dir / "table4" / "results.csv");
  EXPECT_NE(csv.find("\n\"basic layer v2 (target-then-collision, collision scale 1/4)\",0.2 m/s,0,"), std::string::npos);
  EXPECT_EQ(report.find("| MARL-PPO |"), std::string::npos);  // no shipped policy: left out, and said so
  EXPECT_NE(Read(dir.string() + ".log").find("MARL-PPO (marl-ppo) has no shipped policy"), std::string::npos);
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
