// Data-parallel training: the learner's arithmetic over ranks against one process with all the samples (threads as
// ranks), and `rmpmarl train --nproc 2` as processes on loopback — identical learners on every rank, exact resume,
// a different world size refused, a killed rank ending the other within the timeout.
#include "rmpmarl/rl/torch/distributed.h"

#include <gtest/gtest.h>
#include <fmt/format.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <barrier>
#include <functional>
#include <map>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <regex>
#include <sstream>
#include <thread>

#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/torch/ppo.h"
#include "rmpmarl/rl/torch/trainer.h"
#include "rmpmarl/rl/torch/toy_reach.h"

namespace rmpmarl::rl {
namespace {

namespace fs = std::filesystem;

// W ranks as W threads of one process: each collective waits for every rank, then every rank sums the deposits in
// rank order (so each gets the same bits, as Gloo's ring gives every rank the same sums)
class ThreadGroup {
 public:
  explicit ThreadGroup(int world) : world_(world), deposits_(world), sync_(world) {}
  class Rank final : public Collective {
   public:
    Rank(ThreadGroup* group, int rank) : group_(group), rank_(rank) {}
    int rank() const override { return rank_; }
    int world_size() const override { return group_->world_; }
    void AllReduceSum(torch::Tensor& t) override {
      group_->deposits_[rank_] = t.clone();
      group_->sync_.arrive_and_wait();
      torch::Tensor sum = group_->deposits_[0].clone();
      for (int r = 1; r < group_->world_; ++r) sum += group_->deposits_[r];
      group_->sync_.arrive_and_wait();
      t.copy_(sum);
    }
    void Broadcast(torch::Tensor& t) override {
      if (rank_ == 0) group_->deposits_[0] = t.clone();
      group_->sync_.arrive_and_wait();
      if (rank_ != 0) t.copy_(group_->deposits_[0]);
      group_->sync_.arrive_and_wait();
    }

   private:
    ThreadGroup* group_;
    int rank_;
  };

 private:
  int world_;
  std::vector<torch::Tensor> deposits_;
  std::barrier<> sync_;
};

std::vector<double> Flatten(Ppo& ppo) {
  std::vector<double> out;
  std::vector<torch::Tensor> params = ppo.actor()->parameters();
  for (const torch::Tensor& p : ppo.critic()->parameters()) params.push_back(p);
  for (RunningMeanStd* n : {&ppo.obs_norm(), &ppo.state_norm(), &ppo.value_norm()}) {
    params.push_back(n->mean());
    params.push_back(n->var());
  }
  for (const torch::Tensor& p : params) {
    const torch::Tensor d = p.detach().to(torch::kDouble).contiguous().reshape({-1});
    out.insert(out.end(), d.data_ptr<double>(), d.data_ptr<double>() + d.numel());
  }
  return out;
}

// the rows [begin, end) of env-steps of a batch (actor rows: env-step major, A per env-step)
RolloutBatch Slice(const RolloutBatch& b, int64_t begin, int64_t end) {
  const int A = b.num_agents;
  auto rows = [&](const torch::Tensor& t) { return t.slice(0, begin * A, end * A).contiguous(); };
  auto steps = [&](const torch::Tensor& t) { return t.slice(0, begin, end).contiguous(); };
  RolloutBatch s;
  s.num_agents = A;
  s.actor_obs = rows(b.actor_obs);
  s.critic_state = steps(b.critic_state);
  s.actions = rows(b.actions);
  s.old_log_probs = {rows(b.old_log_probs.option), rows(b.old_log_probs.continuous), rows(b.old_log_probs.termination)};
  s.option_mask = rows(b.option_mask);
  s.termination_mask = rows(b.termination_mask);
  s.continuous_mask = rows(b.continuous_mask);
  s.old_values = steps(b.old_values);
  s.returns = steps(b.returns);
  s.advantages = steps(b.advantages);
  return s;
}

TEST(DistributedTest, TwoRanksOfHalfTheSamplesLearnWhatOneProcessLearnsFromAll) {
  const tasks::EnvSpec spec = ToyReachEnv(ToyReachOptions{.agents = 3, .options = true}).spec();
  const int A = spec.num_agents;
  const NetworkOptions net = NetworkOptions{}.actor_hidden({32, 32}).critic_hidden({32, 32});
  // one minibatch per epoch: the two ranks' minibatches together are the one process's
  const PpoOptions opts = PpoOptions{}.epochs(3).minibatches(1);
  const int64_t M = 64;  // env-steps: 2 ranks × 32
  torch::manual_seed(7);
  const torch::Tensor local = torch::randn({M * A, spec.local_obs_dim}) * 2.0 + 0.5;
  const torch::Tensor global = torch::randn({M, spec.global_state_dim}) - 1.0;
  // the rollout: actions and log-probabilities of a sampler, random masks, returns and advantages
  Ppo sampler(spec, net, opts, 3);
  const ActResult acted = sampler.Act(local, global, false, false);
  RolloutBatch batch;
  batch.num_agents = A;
  batch.actor_obs = acted.actor_obs;
  batch.critic_state = acted.critic_state;
  batch.actions = acted.sampled.actions;
  batch.old_log_probs = acted.sampled.log_probs;
  batch.option_mask = (torch::rand({M * A}) < 0.3).to(torch::kFloat);
  batch.termination_mask = torch::ones({M * A});
  batch.continuous_mask = (torch::rand({M * A}) < 0.6).to(torch::kFloat);
  batch.old_values = acted.raw_values;
  batch.returns = torch::randn({M}) * 3.0 + 1.0;
  batch.advantages = torch::randn({M}) * 0.7 + 0.2;

  // one process: the normalisers see every sample, then one update on the whole batch
  Ppo one(spec, net, opts, 11);
  one.Act(local, global, true, false);
  one.Update(batch, 1.0);

  // two ranks (threads), each with half: normalisers merged, advantages normalised and gradients averaged over both
  ThreadGroup group(2);
  std::vector<std::unique_ptr<Ppo>> ranks;
  for (int r = 0; r < 2; ++r) ranks.push_back(std::make_unique<Ppo>(spec, net, opts, 11));
  // rank 1 starts elsewhere: the broadcast gives it rank 0's parameters
  {
    torch::NoGradGuard no_grad;
    for (torch::Tensor p : ranks[1]->actor()->parameters()) p.add_(0.5);
  }
  std::vector<std::thread> threads;
  for (int r = 0; r < 2; ++r) {
    threads.emplace_back([&, r] {
      ThreadGroup::Rank rank(&group, r);
      Ppo& ppo = *ranks[r];
      ppo.SetCollective(&rank);
      ppo.Act(local.slice(0, r * (M / 2) * A, (r + 1) * (M / 2) * A), global.slice(0, r * M / 2, (r + 1) * M / 2),
              true, false);
      ppo.Update(Slice(batch, r * M / 2, (r + 1) * M / 2), 1.0);
      ppo.SetCollective(nullptr);
    });
  }
  for (std::thread& t : threads) t.join();

  const std::vector<double> a = Flatten(one), b0 = Flatten(*ranks[0]), b1 = Flatten(*ranks[1]);
  ASSERT_EQ(a.size(), b0.size());
  EXPECT_EQ(b0, b1) << "the ranks' learners differ";
  double worst = 0.0, moved = 0.0;
  const std::vector<double> start = Flatten(sampler);  // another seed: only to see that the update moved something
  for (size_t i = 0; i < a.size(); ++i) {
    worst = std::max(worst, std::abs(a[i] - b0[i]));
    moved = std::max(moved, std::abs(a[i]));
  }
  EXPECT_LT(worst, 2e-5) << "two ranks of half the batch against one process of all of it";
  EXPECT_GT(moved, 0.0);
}

TEST(DistributedTest, NormalisersMergeToTheUnionsStatistics) {
  torch::manual_seed(3);
  const torch::Tensor x = torch::randn({90, 4}, torch::kDouble) * 5.0 + 100.0;
  RunningMeanStd one(4);
  one.Update(x);
  one.Update(x * 0.5);
  ThreadGroup group(3);
  std::vector<RunningMeanStd> ranks(3, RunningMeanStd(4));
  std::vector<std::thread> threads;
  for (int r = 0; r < 3; ++r) {
    threads.emplace_back([&, r] {
      ThreadGroup::Rank rank(&group, r);
      // unequal shares: 10, 30 and 50 rows
      const int64_t begin = r == 0 ? 0 : (r == 1 ? 10 : 40), end = r == 0 ? 10 : (r == 1 ? 40 : 90);
      ranks[r].Update(x.slice(0, begin, end), &rank);
      ranks[r].Update(x.slice(0, begin, end) * 0.5, &rank);
    });
  }
  for (std::thread& t : threads) t.join();
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(ranks[r].count(), one.count(), 1e-9);
    EXPECT_LT((ranks[r].mean() - one.mean()).abs().max().item<double>(), 1e-9);
    EXPECT_LT((ranks[r].var() - one.var()).abs().max().item<double>(), 1e-9);
  }
  // a rollout: each rank folds its own batches without communicating, then one synchronisation gives every rank
  // the statistics of all of them
  const torch::Tensor y = torch::randn({60, 4}, torch::kDouble) * 2.0 - 30.0;
  for (int step = 0; step < 3; ++step) one.Update(y.slice(0, 20 * step, 20 * step + 20));
  threads.clear();
  for (int r = 0; r < 3; ++r) {
    threads.emplace_back([&, r] {
      ThreadGroup::Rank rank(&group, r);
      // step k: rank r holds rows [20 k + [0, 5, 12][r], ...): unequal shares of every step
      const int64_t cut[4] = {0, 5, 12, 20};
      for (int step = 0; step < 3; ++step) ranks[r].Accumulate(y.slice(0, 20 * step + cut[r], 20 * step + cut[r + 1]));
      RunningMeanStd::Synchronize({&ranks[r]}, &rank);
    });
  }
  for (std::thread& t : threads) t.join();
  for (int r = 0; r < 3; ++r) {
    EXPECT_NEAR(ranks[r].count(), one.count(), 1e-9);
    EXPECT_LT((ranks[r].mean() - one.mean()).abs().max().item<double>(), 1e-9);
    EXPECT_LT((ranks[r].var() - one.var()).abs().max().item<double>(), 1e-9);
  }
}

TrainConfig ToyConfig() {
  TrainConfig c;
  c.name = "toy";
  c.task.name = "toy-reach";
  c.task.interface = "options";
  c.task.overrides_yaml = "{agents: 3, horizon: 20}";
  c.seed = 5;
  c.num_envs = 4;
  c.total_updates = 4;
  c.checkpoint_every = 2;
  c.progress = false;
  c.network = NetworkOptions{}.actor_hidden({32, 32}).critic_hidden({32, 32});
  c.ppo = PpoOptions{}.rollout_steps(16).epochs(2).minibatches(2);
  return c;
}

// runs `body(trainer)` on every rank of a two-thread group; returns each rank's learner checksum afterwards
std::vector<std::uint32_t> OnTwoRanks(const std::function<void(Trainer&)>& body) {
  ThreadGroup group(2);
  std::vector<std::uint32_t> sums(2);
  std::vector<std::string> errors(2);
  std::vector<std::thread> threads;
  for (int r = 0; r < 2; ++r) {
    threads.emplace_back([&, r] {
      ThreadGroup::Rank rank(&group, r);
      try {
        Trainer trainer(ToyConfig(), MakeTaskFactory(ToyConfig().task), &rank);
        body(trainer);
        sums[r] = trainer.LearnerChecksum();
      } catch (const std::exception& e) {
        errors[r] = e.what();
      }
    });
  }
  for (std::thread& t : threads) t.join();
  for (const std::string& e : errors) EXPECT_EQ(e, "");
  return sums;
}

TEST(DistributedTest, ResumesExactlyAtTheSameWorldSizeAndRefusesAnother) {
  const std::string path = ::testing::TempDir() + "/rmpmarl_distributed_test_resume.ckpt";
  const std::vector<std::uint32_t> full = OnTwoRanks([](Trainer& t) {
    while (!t.finished()) t.RunUpdate();
  });
  EXPECT_EQ(full[0], full[1]) << "the ranks' learners differ";
  OnTwoRanks([&](Trainer& t) {
    t.RunUpdate();
    t.RunUpdate();
    t.SaveCheckpoint(path);  // every rank takes part; rank 0 writes
  });
  const std::vector<std::uint32_t> resumed = OnTwoRanks([&](Trainer& t) {
    t.Resume(path);
    EXPECT_EQ(t.update(), 2);
    while (!t.finished()) t.RunUpdate();
  });
  EXPECT_EQ(resumed, full) << "a resumed two-rank run equals the uninterrupted one";
  // one process may not continue a two-rank run
  Trainer alone(ToyConfig(), MakeTaskFactory(ToyConfig().task));
  try {
    alone.Resume(path);
    ADD_FAILURE() << "a checkpoint of 2 ranks was resumed by 1";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("written by a run of 2 ranks"), std::string::npos) << e.what();
  }
  std::remove(path.c_str());
}

// ---- Gloo's collectives on loopback, ranks as threads

// each rank's tensor of n elements: small integers, so every sum is exact whatever the order of the additions
torch::Tensor RankValues(int rank, int64_t n, torch::ScalarType type) {
  return (torch::arange(n, torch::kLong).remainder(1000) * (rank + 1) + rank).to(type);
}

// every rank of a `world`-rank group joins on loopback, all-reduces and broadcasts n elements of each type; returns
// each rank's results, in the order all-reduce float, double, int64, then broadcast float
std::vector<std::vector<torch::Tensor>> OnLoopback(int world, CollectiveWait wait, int64_t n) {
  const int port = FreeLocalPort();
  std::vector<std::vector<torch::Tensor>> out(world);
  std::vector<std::string> errors(world);
  std::vector<std::thread> threads;
  for (int r = 0; r < world; ++r) {
    threads.emplace_back([&, r] {
      try {
        ProcessGroupOptions o;
        o.rank = r;
        o.world_size = world;
        o.master_port = port;
        o.timeout = std::chrono::seconds(10);
        o.wait = wait;
        const std::unique_ptr<Collective> group = JoinProcessGroup(o);
        for (torch::ScalarType type : {torch::kFloat, torch::kDouble, torch::kLong}) {
          torch::Tensor t = RankValues(r, n, type);
          group->AllReduceSum(t);
          out[r].push_back(t);
        }
        torch::Tensor b = RankValues(r, n, torch::kFloat).reshape({-1, 1});
        group->Broadcast(b);
        out[r].push_back(b);
      } catch (const std::exception& e) {
        errors[r] = e.what();
      }
    });
  }
  for (std::thread& t : threads) t.join();
  for (int r = 0; r < world; ++r) EXPECT_EQ(errors[r], "") << "rank " << r;
  return out;
}

// a rank that joins a group ignores SIGPIPE: a write to a peer that died fails with EPIPE and the collective throws
// its message, instead of the signal ending the rank at once (the killed-rank test below, where a write can race the
// peer's death)
TEST(DistributedTest, AJoinedRankIgnoresSigpipe) {
  std::signal(SIGPIPE, SIG_DFL);
  OnLoopback(2, CollectiveWait::kPoll, 10);
  struct sigaction action {};
  ASSERT_EQ(sigaction(SIGPIPE, nullptr, &action), 0);
  EXPECT_EQ(action.sa_handler, SIG_IGN);
}

TEST(DistributedTest, GlooCollectivesInPiecesGiveTheSumsWhetherRanksPollOrBlock) {
  // 1 500 001 elements: more than a socket buffer holds (a whole message in one synchronous write would block both
  // ranks), sent in pieces of a socket buffer's size, the last one short
  const int64_t n = 1'500'001;
  for (auto [world, wait] : {std::pair{2, CollectiveWait::kPoll}, std::pair{2, CollectiveWait::kBlock},
                             std::pair{3, CollectiveWait::kBlock}}) {
    SCOPED_TRACE(fmt::format("{} ranks, {}", world, wait == CollectiveWait::kPoll ? "poll" : "block"));
    const std::vector<std::vector<torch::Tensor>> got = OnLoopback(world, wait, n);
    for (int r = 0; r < world; ++r) {
      ASSERT_EQ(got[r].size(), 4u);
      int k = 0;
      for (torch::ScalarType type : {torch::kFloat, torch::kDouble, torch::kLong}) {
        torch::Tensor expected = torch::zeros({n}, type);
        for (int q = 0; q < world; ++q) expected += RankValues(q, n, type);
        EXPECT_TRUE(torch::equal(got[r][k], expected)) << "rank " << r << ", " << c10::toString(type);
        ++k;
      }
      EXPECT_TRUE(torch::equal(got[r][3], RankValues(0, n, torch::kFloat).reshape({-1, 1}))) << "rank " << r;
    }
  }
}

// sets environment variables for one scope and restores them after
class ScopedEnv {
 public:
  explicit ScopedEnv(std::map<std::string, std::string> vars) {
    for (const auto& [k, v] : vars) {
      const char* old = std::getenv(k.c_str());
      saved_.emplace_back(k, old ? std::optional<std::string>(old) : std::nullopt);
      if (v.empty()) unsetenv(k.c_str());
      else setenv(k.c_str(), v.c_str(), 1);
    }
  }
  ~ScopedEnv() {
    for (const auto& [k, v] : saved_) {
      if (v) setenv(k.c_str(), v->c_str(), 1);
      else unsetenv(k.c_str());
    }
  }

 private:
  std::vector<std::pair<std::string, std::optional<std::string>>> saved_;
};

TEST(DistributedTest, TheEnvironmentChoosesHowRanksWait) {
  const long cpus = static_cast<long>(std::thread::hardware_concurrency());
  {
    ScopedEnv env({{"WORLD_SIZE", "2"}, {"RANK", "1"}, {"MASTER_ADDR", "127.0.0.1"}, {"LOCAL_WORLD_SIZE", "1"},
                   {"RMPMARL_DIST_WAIT", ""}});
    const std::optional<ProcessGroupOptions> o = ProcessGroupFromEnvironment();
    ASSERT_TRUE(o.has_value());
    EXPECT_EQ(o->rank, 1);
    EXPECT_EQ(o->wait, CollectiveWait::kPoll) << "one rank on this machine: it may spin";
  }
  {
    // more ranks on this machine than it has CPUs: a spinning rank would take its peer's core
    ScopedEnv env({{"WORLD_SIZE", "2"}, {"RANK", "0"}, {"MASTER_ADDR", "127.0.0.1"},
                   {"LOCAL_WORLD_SIZE", std::to_string(cpus + 1)}, {"RMPMARL_DIST_WAIT", ""}});
    EXPECT_EQ(ProcessGroupFromEnvironment()->wait, CollectiveWait::kBlock);
  }
  {
    ScopedEnv env({{"WORLD_SIZE", "2"}, {"RANK", "0"}, {"MASTER_ADDR", "127.0.0.1"}, {"LOCAL_WORLD_SIZE", "1"},
                   {"RMPMARL_DIST_WAIT", "block"}});
    EXPECT_EQ(ProcessGroupFromEnvironment()->wait, CollectiveWait::kBlock);
  }
  {
    ScopedEnv env({{"WORLD_SIZE", "2"}, {"RANK", "0"}, {"MASTER_ADDR", "127.0.0.1"}, {"RMPMARL_DIST_WAIT", "spin"}});
    try {
      ProcessGroupFromEnvironment();
      ADD_FAILURE() << "RMPMARL_DIST_WAIT=spin was accepted";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("RMPMARL_DIST_WAIT: expected 'poll' or 'block', got 'spin'"),
                std::string::npos) << e.what();
    }
  }
}

// ---- processes: the CLI on loopback

std::string TempDir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/rmpmarl_distributed_test_" + name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

struct ShellRun {
  int status = -1;
  std::string output;
};

ShellRun Shell(const std::string& command) {
  ShellRun r;
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  char buf[4096];
  while (fgets(buf, sizeof(buf), p) != nullptr) r.output += buf;
  const int s = pclose(p);
  r.status = WIFEXITED(s) ? WEXITSTATUS(s) : -1;
  return r;
}

// a log file's text so far ("" before it exists)
std::string ReadLog(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// "update,env_steps" of the first row of a run's metrics.csv
std::string FirstUpdateAndEnvSteps(const std::string& dir) {
  std::ifstream csv(dir + "/out/metrics.csv");
  std::string header, first;
  std::getline(csv, header);
  std::getline(csv, first);
  return first.substr(0, first.find(',', 2));
}

// a short toy-reach run: 2 updates per checkpoint
std::string WriteConfig(const std::string& dir, int updates, int minibatches = 2) {
  const std::string path = dir + "/toy.yaml";
  std::ofstream(path) << fmt::format(
      "name: toy\ntask: {{name: toy-reach, interface: options, overrides: {{agents: 3, horizon: 20}}}}\n"
      "algorithm: mappo\nseed: 4\nnum_envs: 4\ntotal_updates: {}\ncheckpoint_every: 2\noutput_dir: {}/out\n"
      "network: {{actor_hidden: [32, 32], critic_hidden: [32, 32]}}\n"
      "ppo: {{rollout_steps: 16, epochs: 2, minibatches: {}, target_kl: 0.05}}\n",
      updates, dir, minibatches);
  return path;
}

// the learner checksum each rank printed, by rank
std::map<int, std::string> Checksums(const std::string& output) {
  std::map<int, std::string> out;
  const std::regex re(R"(rank (\d+) of \d+: learner checksum ([0-9a-f]{8}) after (\d+) updates)");
  for (std::sregex_iterator it(output.begin(), output.end(), re), end; it != end; ++it) {
    out[std::stoi((*it)[1])] = (*it)[2].str() + "@" + (*it)[3].str();
  }
  return out;
}

TEST(DistributedTest, LocalRanksHoldOneLearnerAndRankZeroWritesTheRun) {
  const std::string dir = TempDir("nproc");
  const std::string cli = RMPMARL_CLI_PATH;
  const std::string config = WriteConfig(dir, 4);
  const ShellRun full = Shell(fmt::format("{} train {} --nproc 2 --quiet", cli, config));
  ASSERT_EQ(full.status, 0) << full.output;
  const std::map<int, std::string> sums = Checksums(full.output);
  ASSERT_EQ(sums.size(), 2u) << full.output;
  EXPECT_EQ(sums.at(0), sums.at(1)) << "every rank holds the same learner after 4 updates";
  // three ranks: Gloo's ring adds in a different order on each rank, rank 0's sums are everyone's
  const std::string three_dir = TempDir("nproc3");
  const ShellRun three = Shell(fmt::format("{} train {} --nproc 3 --quiet", cli, WriteConfig(three_dir, 4)));
  ASSERT_EQ(three.status, 0) << three.output;
  const std::map<int, std::string> three_sums = Checksums(three.output);
  ASSERT_EQ(three_sums.size(), 3u) << three.output;
  EXPECT_EQ(three_sums.at(0), three_sums.at(1));
  EXPECT_EQ(three_sums.at(0), three_sums.at(2));
  fs::remove_all(three_dir);
  // rank 0 alone wrote the run's files; each update counted both ranks' env steps (4 envs × 16 steps × 2 ranks)
  EXPECT_TRUE(fs::exists(dir + "/out/policy.rmpp"));
  EXPECT_EQ(FirstUpdateAndEnvSteps(dir), "1,128");

  fs::remove_all(dir);
}

TEST(DistributedTest, EnvsSetsEachRanksEnvironments) {
  // --nproc 2 --envs 2 for a config of 4: every update counts 2 ranks × 2 envs × 16 steps
  const std::string dir = TempDir("envs");
  const ShellRun run = Shell(fmt::format("{} train {} --nproc 2 --envs 2 --quiet", RMPMARL_CLI_PATH, WriteConfig(dir, 2)));
  ASSERT_EQ(run.status, 0) << run.output;
  EXPECT_EQ(FirstUpdateAndEnvSteps(dir), "1,64");
  // fewer env steps per rollout than minibatches: refused, naming the option
  const ShellRun tiny = Shell(fmt::format("{} train {} --envs 1 --quiet", RMPMARL_CLI_PATH,
                                          WriteConfig(dir, 2, /*minibatches=*/32)));
  EXPECT_NE(tiny.status, 0);
  EXPECT_NE(tiny.output.find("--envs 1: expected at least ppo.minibatches = 32 env steps per rollout, got 16"),
            std::string::npos) << tiny.output;
  fs::remove_all(dir);
}

// starts two ranks as torchrun would (timeout `timeout_s`), lets them train, then does `fault` to rank 1; returns how
// long rank 0 ran on, and checks that it failed saying why
double RankZeroSurvives(const std::string& name, int timeout_s, const std::function<void(pid_t)>& fault,
                        const char* wait = "poll") {
  const std::string dir = TempDir(name);
  const std::string config = WriteConfig(dir, 100000);
  const int port = FreeLocalPort();
  const std::string log0 = dir + "/rank0.log";
  auto start = [&](int rank, const std::string& log) {
    const pid_t pid = fork();
    if (pid == 0) {
      setenv("RANK", std::to_string(rank).c_str(), 1);
      setenv("WORLD_SIZE", "2", 1);
      setenv("MASTER_ADDR", "127.0.0.1", 1);
      setenv("MASTER_PORT", std::to_string(port).c_str(), 1);
      setenv("RMPMARL_DIST_TIMEOUT", std::to_string(timeout_s).c_str(), 1);
      setenv("RMPMARL_DIST_WAIT", wait, 1);
      if (freopen(log.c_str(), "w", stdout) == nullptr) _exit(126);
      dup2(fileno(stdout), 2);
      execl(RMPMARL_CLI_PATH, RMPMARL_CLI_PATH, "train", config.c_str(), nullptr);
      _exit(127);
    }
    return pid;
  };
  const pid_t r0 = start(0, log0), r1 = start(1, dir + "/rank1.log");
  auto stop_both = [&] {
    kill(r0, SIGKILL);
    kill(r1, SIGKILL);
    waitpid(r0, nullptr, 0);
    waitpid(r1, nullptr, 0);
  };
  // rank 0 reports updates once the group trains
  const auto begin = std::chrono::steady_clock::now();
  while (ReadLog(log0).find("3/100000]") == std::string::npos) {
    if (std::chrono::steady_clock::now() - begin > std::chrono::seconds(120)) {
      stop_both();
      ADD_FAILURE() << "the ranks did not train for 120 s:\n" << ReadLog(log0);
      return -1.0;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  fault(r1);
  const auto faulted = std::chrono::steady_clock::now();
  int status = 0;
  while (waitpid(r0, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - faulted > std::chrono::seconds(timeout_s + 15)) {
      stop_both();
      ADD_FAILURE() << "rank 0 still ran " << timeout_s + 15 << " s after the fault (timeout " << timeout_s << " s)";
      return -1.0;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - faulted).count();
  kill(r1, SIGKILL);
  waitpid(r1, nullptr, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) != 0);
  const std::string out = ReadLog(log0);
  EXPECT_NE(out.find("rank 0 of 2"), std::string::npos) << out;
  EXPECT_NE(out.find("another rank died, hung"), std::string::npos) << out;
  fs::remove_all(dir);
  return seconds;
}

TEST(DistributedTest, AKilledRankEndsTheOtherAtOnce) {
  const double s = RankZeroSurvives("kill", 10, [](pid_t p) {
    kill(p, SIGKILL);
    waitpid(p, nullptr, 0);
  });
  std::printf("rank 0 ended %.2f s after rank 1 was killed (timeout 10 s)\n", s);
  EXPECT_LT(s, 10.0) << "a dead peer's closed connection fails the collective before the timeout";
}

TEST(DistributedTest, AHungRankEndsTheOtherAfterTheTimeout) {
  // a spinning rank checks the clock between reads; a blocked one is woken by its socket's receive timeout
  for (const char* wait : {"poll", "block"}) {
    const double s = RankZeroSurvives(std::string("hang-") + wait, 4, [](pid_t p) { kill(p, SIGSTOP); }, wait);
    std::printf("rank 0 (%s) ended %.2f s after rank 1 stopped (timeout 4 s)\n", wait, s);
    EXPECT_GT(s, 3.0) << wait;
  }
}

TEST(DistributedTest, TheLauncherNamesTheRankThatHung) {
  const std::string dir = TempDir("launcher");
  const std::string config = WriteConfig(dir, 100000);
  const std::string log = dir + "/launcher.log";
  const pid_t launcher = fork();
  if (launcher == 0) {
    if (freopen(log.c_str(), "w", stdout) == nullptr) _exit(126);
    dup2(fileno(stdout), 2);
    execl(RMPMARL_CLI_PATH, RMPMARL_CLI_PATH, "train", config.c_str(), "--nproc", "2", "--dist-timeout", "2",
          nullptr);
    _exit(127);
  }
  const auto begin = std::chrono::steady_clock::now();
  while (ReadLog(log).find("3/100000]") == std::string::npos) {
    if (std::chrono::steady_clock::now() - begin > std::chrono::seconds(120)) {
      kill(-launcher, SIGKILL);
      kill(launcher, SIGKILL);
      FAIL() << ReadLog(log);
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  // the launcher's children, in the order it started them: rank 0, rank 1
  std::ifstream children(fmt::format("/proc/{}/task/{}/children", launcher, launcher));
  pid_t rank0 = 0, rank1 = 0;
  children >> rank0 >> rank1;
  ASSERT_GT(rank1, 0);
  kill(rank1, SIGSTOP);
  int status = 0;
  const auto stopped = std::chrono::steady_clock::now();
  while (waitpid(launcher, &status, WNOHANG) == 0) {
    if (std::chrono::steady_clock::now() - stopped > std::chrono::seconds(40)) {
      kill(rank0, SIGKILL);
      kill(rank1, SIGKILL);
      kill(launcher, SIGKILL);
      FAIL() << "the launcher still ran 40 s after rank 1 hung (timeout 2 s)";
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 1);
  const std::string out = ReadLog(log);
  EXPECT_NE(out.find("rank 1: hung: killed after the timeout"), std::string::npos) << out;
  EXPECT_NE(out.find("rank 0: exited with status 1"), std::string::npos) << out;
  EXPECT_NE(kill(rank1, 0), 0) << "the hung rank is gone";
  fs::remove_all(dir);
}

}  // namespace
}  // namespace rmpmarl::rl
