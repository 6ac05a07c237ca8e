// A training process SIGKILLed in the middle of a checkpoint write (tests/rl_torch/kill_in_checkpoint_write.cc, an
// LD_PRELOAD shim, kills `rmpmarl train` inside the fsync of its temporary file) leaves the previous checkpoint intact;
// `--resume` continues from it without error and ends where an uninterrupted run ends, bit for bit.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>

#include <algorithm>
#include <csignal>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/torch/trainer.h"

extern char** environ;

namespace rmpmarl::rl {
namespace {

namespace fs = std::filesystem;

struct ExitStatus {
  bool killed = false;  ///< terminated by SIGKILL
  int code = -1;        ///< exit code when it exited
};

// runs the CLI with `args` and `extra_env` on top of this process's environment, output to `log`.
ExitStatus RunCli(const std::vector<std::string>& args, const std::vector<std::string>& extra_env,
                  const std::string& log) {
  std::vector<std::string> argv_s = {RMPMARL_CLI_PATH};
  argv_s.insert(argv_s.end(), args.begin(), args.end());
  // the inherited environment, with extra_env's variables replacing any of the same name (getenv returns the first
  // of duplicates: an inherited ASAN_OPTIONS would hide the one given here)
  auto name_of = [](const std::string& entry) { return entry.substr(0, entry.find('=')); };
  std::vector<std::string> env_s;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry(*e);
    const bool replaced = std::any_of(extra_env.begin(), extra_env.end(),
                                      [&](const std::string& x) { return name_of(x) == name_of(entry); });
    if (!replaced) env_s.push_back(entry);
  }
  env_s.insert(env_s.end(), extra_env.begin(), extra_env.end());
  std::vector<char*> argv, envp;
  for (std::string& s : argv_s) argv.push_back(s.data());
  for (std::string& s : env_s) envp.push_back(s.data());
  argv.push_back(nullptr);
  envp.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  ExitStatus status;
  if (spawned != 0) return status;
  int raw = 0;
  waitpid(pid, &raw, 0);
  status.killed = WIFSIGNALED(raw) && WTERMSIG(raw) == SIGKILL;
  if (WIFEXITED(raw)) status.code = WEXITSTATUS(raw);
  return status;
}

std::string ReadAll(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// a seconds-long toy-reach run with a checkpoint after every update.
std::string WriteConfig(const fs::path& dir, const std::string& name) {
  const fs::path path = dir / (name + ".yaml");
  std::ofstream(path) << "name: " << name << "\n"
                      << "task: {name: toy-reach, interface: options, overrides: {agents: 3, horizon: 20}}\n"
                      << "algorithm: mappo\nseed: 7\nnum_envs: 4\ntotal_updates: 4\ncheckpoint_every: 1\n"
                      << "env_threads: 1\ntorch_threads: 1\noutput_dir: " << (dir / name).string() << "\n"
                      << "network: {actor_hidden: [16], critic_hidden: [16]}\n"
                      << "ppo: {rollout_steps: 16, epochs: 1, minibatches: 1}\n";
  return path.string();
}

TEST(CheckpointKillTest, SigkillDuringACheckpointWriteResumesFromThePreviousOne) {
  const fs::path dir = fs::temp_directory_path() / "rmpmarl_checkpoint_kill_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string log = (dir / "log.txt").string();
  // ASan (make test-sanitize) wants to come first in the library list; the shim is preloaded before it
  std::string asan = "ASAN_OPTIONS=verify_asan_link_order=0";
  if (const char* a = std::getenv("ASAN_OPTIONS")) asan += std::string(":") + a;
  const std::vector<std::string> kill_env = {std::string("LD_PRELOAD=") + RMPMARL_KILL_SHIM_PATH,
                                             "RMPMARL_KILL_AT_CHECKPOINT_WRITE=3", asan};

  const std::string killed_config = WriteConfig(dir, "killed");
  const ExitStatus killed = RunCli({"train", killed_config, "--quiet"}, kill_env, log);
  ASSERT_TRUE(killed.killed) << "exit code " << killed.code << "; log:\n" << ReadAll(log);
  // the half-written temporary file is left behind; the checkpoint is the one of update 2, whole
  const fs::path run = dir / "killed";
  int partial = 0;
  for (const auto& entry : fs::directory_iterator(run)) {
    if (entry.path().filename().string().rfind("checkpoint.ckpt.tmp.", 0) == 0) ++partial;
  }
  EXPECT_EQ(partial, 1);
  ASSERT_TRUE(fs::exists(run / "checkpoint.ckpt"));
  EXPECT_FALSE(fs::exists(run / "final.ckpt"));
  EXPECT_NO_THROW(ReadCheckpointConfig((run / "checkpoint.ckpt").string()));

  const ExitStatus resumed = RunCli({"train", killed_config, "--resume", "--quiet"}, {}, log);
  ASSERT_EQ(resumed.code, 0) << ReadAll(log);
  ASSERT_TRUE(fs::exists(run / "final.ckpt"));

  const std::string whole_config = WriteConfig(dir, "whole");
  ASSERT_EQ(RunCli({"train", whole_config, "--quiet"}, {}, log).code, 0) << ReadAll(log);
  // the same controller: network and task bit for bit (the provenance names each run)
  auto controller = [&](const fs::path& policy) {
    control::PolicyFile file = control::LoadPolicyFile(policy.string());
    file.provenance_yaml.clear();
    const fs::path bare = dir / "bare.rmpp";
    control::SavePolicyFile(file, bare.string());
    return ReadAll(bare);
  };
  const std::string resumed_policy = controller(run / "policy.rmpp");
  EXPECT_FALSE(resumed_policy.empty());
  EXPECT_TRUE(resumed_policy == controller(dir / "whole" / "policy.rmpp"))
      << "the resumed run's policy differs from the uninterrupted run's";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rmpmarl::rl
