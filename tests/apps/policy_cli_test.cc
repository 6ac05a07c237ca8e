// Controller files from the outside: `rmpmarl policy show|upgrade|set-provenance` and `rmpmarl eval FILE.rmpp` on
// its own task, moved to another arm and scene, and as a controller in a user's loop.
#include <fmt/format.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/tasks/task_config.h"
#include "../support/temp_files.h"
#include "run_cli.h"

namespace {

namespace fs = std::filesystem;
using rmpmarl::kinematics::ModelsDirectory;
using rmpmarl::test::CommandResult;
using rmpmarl::test::RunCli;

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

fs::path Shipped(const std::string& name) { return ModelsDirectory() / "policies" / name; }

fs::path TempDir(const std::string& name) { return rmpmarl::test::FreshTempDir("policy-cli", name); }

// eval is part of the libtorch build
bool HasEval() { return RunCli("eval --help").exit_code == 0; }

// the card beside every shipped controller file is what `policy show` prints from the file
TEST(PolicyCli, ShowPrintsTheCardShippedBesideTheFile) {
  for (const char* name : {"hrl-rmp-2link", "marl-rmp", "marl-rmp-residual"}) {
    SCOPED_TRACE(name);
    const CommandResult r = RunCli("policy show " + Shipped(std::string(name) + ".rmpp").string());
    ASSERT_EQ(r.exit_code, 0) << r.output;
    EXPECT_EQ(r.output, ReadAll(Shipped(std::string(name) + ".yaml")));
  }
  const CommandResult missing = RunCli("policy show /no/such.rmpp");
  EXPECT_EQ(missing.exit_code, 2) << missing.output;
  EXPECT_NE(missing.output.find("/no/such.rmpp: cannot open it"), std::string::npos) << missing.output;
  // a current file is not upgraded: it says so
  const CommandResult current = RunCli("policy upgrade " + Shipped("marl-rmp.rmpp").string() + " --out /tmp/x.rmpp");
  EXPECT_EQ(current.exit_code, 2) << current.output;
  EXPECT_NE(current.output.find("already format 2"), std::string::npos) << current.output;
}

// a format-1 file (the network alone) is refused with the upgrade command; the upgrade gives a file that runs its
// task as the shipped format-2 file of the same network does, and provenance can be added to it
TEST(PolicyCli, UpgradeTurnsAFormat1FileIntoTheSameController) {
  const fs::path dir = TempDir("upgrade");
  // format 1 as written before: the same layout up to the weights, version 1, checksum over all preceding bytes
  const fs::path shipped = Shipped("marl-rmp.rmpp");
  const rmpmarl::control::PolicyFile file = rmpmarl::control::LoadPolicyFile(shipped.string());
  const std::string bytes = ReadAll(shipped);
  const size_t weights_end = bytes.size() - 4 - (4 + file.task_yaml.size()) - (4 + file.provenance_yaml.size());
  std::string v1 = bytes.substr(0, weights_end);
  const std::uint32_t version = 1;
  std::memcpy(v1.data() + 8, &version, 4);
  const std::uint32_t crc = rmpmarl::control::Crc32c(v1.data(), v1.size());
  v1.append(reinterpret_cast<const char*>(&crc), 4);
  const fs::path old_file = dir / "old.rmpp", new_file = dir / "new.rmpp";
  std::ofstream(old_file, std::ios::binary) << v1;

  const CommandResult refused = RunCli("policy show " + old_file.string());
  EXPECT_EQ(refused.exit_code, 2) << refused.output;
  EXPECT_NE(refused.output.find("rmpmarl policy upgrade " + old_file.string() + " --task TASK"), std::string::npos)
      << refused.output;
  const CommandResult no_task = RunCli(fmt::format("policy upgrade {} --out {}", old_file.string(), new_file.string()));
  EXPECT_EQ(no_task.exit_code, 2) << no_task.output;
  EXPECT_NE(no_task.output.find("give --task"), std::string::npos) << no_task.output;
  const CommandResult bad_task =
      RunCli(fmt::format("policy upgrade {} --task reach --out {}", old_file.string(), new_file.string()));
  EXPECT_EQ(bad_task.exit_code, 2) << bad_task.output;
  EXPECT_FALSE(fs::exists(new_file));

  // a task whose interface does not fit the network is refused naming both sizes
  const CommandResult misfit = RunCli(fmt::format("policy upgrade {} --task reach-avoid --overrides "
                                                  "'interface: direct' --out {}", old_file.string(),
                                                  new_file.string()));
  EXPECT_EQ(misfit.exit_code, 2) << misfit.output;
  EXPECT_NE(misfit.output.find("observations per joint"), std::string::npos) << misfit.output;
  EXPECT_FALSE(fs::exists(new_file));

  // marl-rmp runs the shipped reach-avoid task with the obstacle slots of its training
  const CommandResult up = RunCli(fmt::format("policy upgrade {} --task reach-avoid --overrides "
                                              "'observation: {{max_obstacles: 6}}' --out {}",
                                              old_file.string(), new_file.string()));
  ASSERT_EQ(up.exit_code, 0) << up.output;
  const rmpmarl::control::PolicyFile upgraded = rmpmarl::control::LoadPolicyFile(new_file.string());
  EXPECT_EQ(upgraded.task_yaml, file.task_yaml);
  EXPECT_NE(upgraded.provenance_yaml.find("upgraded_from: old.rmpp"), std::string::npos) << upgraded.provenance_yaml;
  EXPECT_EQ(ReadAll(new_file).substr(12, weights_end - 12), bytes.substr(12, weights_end - 12));  // the network

  if (HasEval()) {
    const std::string options = " --episodes 3 --envs 3 --env-threads 1";
    const CommandResult a = RunCli("eval " + new_file.string() + options);
    const CommandResult b = RunCli("eval " + shipped.string() + options);
    ASSERT_EQ(a.exit_code, 0) << a.output;
    ASSERT_EQ(b.exit_code, 0) << b.output;
    // the same episodes, the same numbers: everything after the first line (which names the file)
    EXPECT_EQ(a.output.substr(a.output.find('\n')), b.output.substr(b.output.find('\n')));
  }

  // provenance is added, not replaced; a file that is no mapping is refused and the controller file stays
  std::ofstream(dir / "provenance.yaml") << "commit: 0123abc\nevaluation: {success_rate: 1.0}\n";
  const CommandResult set =
      RunCli(fmt::format("policy set-provenance {} {}", new_file.string(), (dir / "provenance.yaml").string()));
  ASSERT_EQ(set.exit_code, 0) << set.output;
  const CommandResult shown = RunCli("policy show " + new_file.string());
  ASSERT_EQ(shown.exit_code, 0) << shown.output;
  EXPECT_NE(shown.output.find("commit: 0123abc"), std::string::npos) << shown.output;
  EXPECT_NE(shown.output.find("upgraded_from: old.rmpp"), std::string::npos) << shown.output;
  const std::string before = ReadAll(new_file);
  std::ofstream(dir / "list.yaml") << "[1, 2]\n";
  const CommandResult list =
      RunCli(fmt::format("policy set-provenance {} {}", new_file.string(), (dir / "list.yaml").string()));
  EXPECT_EQ(list.exit_code, 2) << list.output;
  EXPECT_NE(list.output.find("expected a YAML mapping"), std::string::npos) << list.output;
  EXPECT_EQ(ReadAll(new_file), before);
}

// a controller file runs its own task without --task, moves to another arm and scene, and runs as a controller
TEST(PolicyCli, EvalRunsAControllerFileOnItsTaskMovedAndAsAController) {
  if (!HasEval()) GTEST_SKIP() << "eval needs the libtorch build";
  const std::string residual = Shipped("marl-rmp-residual.rmpp").string();
  const std::string options = " --episodes 2 --envs 2 --env-threads 1";
  const CommandResult own = RunCli("eval " + residual + options);
  ASSERT_EQ(own.exit_code, 0) << own.output;
  EXPECT_NE(own.output.find("on reach-avoid / panda / per-joint-rmp (2 episodes, deterministic actions)"),
            std::string::npos) << own.output;
  EXPECT_NE(own.output.find("success rate"), std::string::npos) << own.output;
  const CommandResult moved =
      RunCli("eval " + residual + options + " --robot ur5e --scenario line-crossing --obstacle-speed 1.5 --as-controller");
  ASSERT_EQ(moved.exit_code, 0) << moved.output;
  EXPECT_NE(moved.output.find("on line-crossing / ur5e / per-joint-rmp, as a controller in a user's loop"),
            std::string::npos) << moved.output;
  // what cannot fit is refused with the reason
  const struct {
    const char* args;
    const char* message;
  } refusals[] = {
      {" --as-controller --stochastic", "a controller acts on its deterministic modes"},
      {" --scenario static-reach", "run RMPflow alone"},
      {" --scenario cluttered --obstacle-speed 1", "do not move"},
      {" --collision c.yaml", "--collision needs --urdf"},
      {" --robot ur5e --urdf a.urdf", "give one of them"},
      {" --robot no-such-arm", "no-such-arm"},
  };
  for (const auto& refusal : refusals) {
    const CommandResult r = RunCli("eval " + residual + options + refusal.args);
    EXPECT_EQ(r.exit_code, 2) << refusal.args << ": " << r.output;
    EXPECT_NE(r.output.find(refusal.message), std::string::npos) << refusal.args << ": " << r.output;
  }
}

}  // namespace
