// Training runs: config parsing, checkpoints (round trip, corrupt/mismatched refused), bit-exact resume,
// evaluation, and learning smoke tests with measured thresholds on the toy-reach task.
#include "rmpmarl/rl/torch/trainer.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/rl/torch/toy_reach.h"

namespace rmpmarl::rl {
namespace {

namespace fs = std::filesystem;

TrainConfig ToyConfig(int agents, const std::string& interface, const std::string& dir = "") {
  TrainConfig c;
  c.name = "toy";
  c.task.name = "toy-reach";
  c.task.interface = interface;
  c.task.overrides_yaml = fmt::format("{{agents: {}}}", agents);
  c.algorithm = agents == 1 ? "ppo" : "mappo";
  c.seed = 5;
  c.num_envs = 8;
  c.total_updates = 4;
  c.checkpoint_every = 2;
  c.output_dir = dir;
  c.progress = false;
  c.network = NetworkOptions{}.actor_hidden({32, 32}).critic_hidden({32, 32});
  c.ppo = PpoOptions{}.rollout_steps(16).epochs(2).minibatches(2);
  return c;
}

std::string TempDir(const std::string& name) {
  const std::string dir = ::testing::TempDir() + "/rmpmarl_trainer_test_" + name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

void ExpectRefused(const std::function<void()>& f, const std::vector<std::string>& words) {
  try {
    f();
    ADD_FAILURE() << "not refused (expected a message with \"" << words.front() << "\")";
  } catch (const InputError& e) {
    for (const std::string& w : words) EXPECT_NE(std::string(e.what()).find(w), std::string::npos) << e.what();
  }
}

// ---------------------------------------------------------------------------------------------------- config
TEST(TrainConfigTest, ParsesKeysAndRoundTripsThroughYaml) {
  const TrainConfig c = ParseTrainConfig(R"(
name: demo
task: {name: toy-reach, interface: direct, overrides: {agents: 3, horizon: 20}}
algorithm: mappo
seed: 42
num_envs: 6
network: {actor_hidden: [64, 32], activation: tanh, init_log_std: -1.0}
ppo: {clip: 0.1, epochs: 7, lr: 0.001, lr_schedule: constant, entropy_option: 0.02, normalize_value: false}
logging: {csv: false}
)", "inline");
  EXPECT_EQ(c.name, "demo");
  EXPECT_EQ(c.task.interface, "direct");
  EXPECT_EQ(c.seed, 42u);
  EXPECT_EQ(c.network.actor_hidden(), (std::vector<int>{64, 32}));
  EXPECT_EQ(c.network.activation(), Activation::kTanh);
  EXPECT_EQ(c.ppo.clip(), 0.1);
  EXPECT_EQ(c.ppo.epochs(), 7);
  EXPECT_EQ(c.ppo.lr_schedule(), LrSchedule::kConstant);
  EXPECT_FALSE(c.ppo.normalize_value());
  EXPECT_FALSE(c.write_csv);
  EXPECT_EQ(c.ppo.gae_lambda(), PpoOptions{}.gae_lambda());  // untouched keys keep their defaults
  const TrainConfig back = ParseTrainConfig(ToYaml(c), "round trip");
  EXPECT_EQ(FlattenTrainConfig(back), FlattenTrainConfig(c));
  EXPECT_NO_THROW(MakeTaskFactory(c.task));
}

TEST(TrainConfigTest, UnknownKeysAndBadValuesRefused) {
  ExpectRefused([] { ParseTrainConfig("task: {name: toy-reach}\nppo: {clp: 0.2}\n", "cfg.yaml"); },
                {"cfg.yaml", "unknown key \"ppo.clp\"", "ppo.clip"});
  ExpectRefused([] { ParseTrainConfig("task: {name: toy-reach}\nppo: {epochs: many}\n", "cfg.yaml"); },
                {"ppo.epochs", "many"});
  ExpectRefused([] { ParseTrainConfig("task: {name: toy-reach}\nnum_envs: 0\n", "cfg.yaml"); },
                {"num_envs", "expected >= 1, got 0"});
  ExpectRefused([] { ParseTrainConfig("task: {name: toy-reach}\nalgorithm: dqn\n", "cfg.yaml"); }, {"algorithm"});
  ExpectRefused([] { ParseTrainConfig("seed: 1\n", "cfg.yaml"); }, {"task.name"});
  ExpectRefused([] { MakeTaskFactory({.name = "no-such-task"}); }, {"unknown task \"no-such-task\"", "toy-reach"});
  TrainConfig multi = ToyConfig(3, "options");
  multi.algorithm = "ppo";
  ExpectRefused([&] { Trainer t(multi, MakeTaskFactory(multi.task)); }, {"single-agent", "3 agents"});
}

// a mixture of scenes (task.mix): every other env runs the second task, with the first's interface; the keys
// round-trip, and a config without a mix prints no mix keys (so older runs' train.yaml still compare equal)
TEST(TrainConfigTest, MixedTasksAlternateOverTheEnvs) {
  const TrainConfig c = ParseTrainConfig(R"(
name: mix
task:
  name: reach-avoid
  interface: per-joint-rmp
  overrides: {observation: {max_obstacles: 6}, randomization: {variants: 1}}
  mix: {name: cluttered, overrides: {observation: {max_obstacles: 6}, randomization: {variants: 1}}, fraction: 0.5}
)", "inline");
  EXPECT_EQ(c.task.mix_name, "cluttered");
  const TrainConfig back = ParseTrainConfig(ToYaml(c), "round trip");
  EXPECT_EQ(FlattenTrainConfig(back), FlattenTrainConfig(c));
  EXPECT_EQ(back.task.mix_overrides_yaml, c.task.mix_overrides_yaml);
  const tasks::EnvFactory factory = MakeTaskFactory(c.task);
  for (int k = 0; k < 4; ++k) {
    const std::unique_ptr<tasks::Env> env = factory(k);
    const auto* m = dynamic_cast<const tasks::ManipulatorEnv*>(env.get());
    ASSERT_NE(m, nullptr);
    EXPECT_EQ(m->context().config().task, k % 2 == 1 ? tasks::TaskKind::kCluttered : tasks::TaskKind::kReachAvoid) << k;
    EXPECT_EQ(m->context().config().interface, tasks::InterfaceMode::kPerJointRmp) << k;
    EXPECT_EQ(m->context().config().observation.max_obstacles, 6) << k;
  }
  const TrainConfig plain = ParseTrainConfig("task: {name: toy-reach}\n", "inline");
  EXPECT_EQ(ToYaml(plain).find("mix"), std::string::npos);
  ExpectRefused([] { ParseTrainConfig("task: {name: reach-avoid, mix: {name: cluttered, fraction: 1.5}}\n", "c.yaml"); },
                {"task.mix.fraction", "(0, 1)", "1.5"});
  ExpectRefused([] { MakeTaskFactory({.name = "toy-reach", .mix_name = "cluttered"}); },
                {"two manipulator tasks", "toy-reach"});
}

TEST(TrainConfigTest, ShippedTrainingConfigsParse) {
  const fs::path dir = fs::path(RMPMARL_TEST_DATA_DIR) / ".." / ".." / "configs" / "train";
  int count = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".yaml") continue;
    EXPECT_NO_THROW(LoadTrainConfig(entry.path().string())) << entry.path();
    ++count;
  }
  EXPECT_GE(count, 5);
}

// ---------------------------------------------------------------------------------------------------- checkpoints
TEST(CheckpointTest, RoundTripRestoresTheFullState) {
  const std::string dir = TempDir("roundtrip");
  const TrainConfig config = ToyConfig(2, "options");
  Trainer a(config, MakeTaskFactory(config.task));
  a.RunUpdate();
  a.RunUpdate();
  a.SaveCheckpoint(dir + "/a.ckpt");
  EXPECT_FALSE(fs::exists(dir + "/a.ckpt.tmp"));
  Trainer b(config, MakeTaskFactory(config.task));
  EXPECT_NE(b.StateVector(), a.StateVector());
  b.Resume(dir + "/a.ckpt");
  EXPECT_EQ(b.update(), 2);
  EXPECT_EQ(b.env_steps(), a.env_steps());
  EXPECT_EQ(b.StateVector(), a.StateVector());  // parameters, Adam moments, normalisers, RNG state, counters
  EXPECT_EQ(ReadCheckpointConfig(dir + "/a.ckpt").ppo.rollout_steps(), 16);
}

TEST(CheckpointTest, CorruptOrMismatchedCheckpointsRefused) {
  const std::string dir = TempDir("corrupt");
  const TrainConfig config = ToyConfig(2, "options");
  Trainer a(config, MakeTaskFactory(config.task));
  a.RunUpdate();
  const std::string good = dir + "/good.ckpt";
  a.SaveCheckpoint(good);
  const std::string bytes = ReadAll(good);
  auto resume_from = [&](const std::string& content, const TrainConfig& c) {
    const std::string bad = dir + "/bad.ckpt";
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << content;
    Trainer t(c, MakeTaskFactory(c.task));
    t.Resume(bad);
  };
  std::string flipped = bytes;
  flipped[bytes.size() - 100] ^= 0x01;
  ExpectRefused([&] { resume_from(flipped, config); }, {"is corrupt", "checksum mismatch"});
  ExpectRefused([&] { resume_from(bytes.substr(0, bytes.size() - 10), config); }, {"is corrupt", "truncated"});
  ExpectRefused([&] { resume_from("PK\x03\x04 not a checkpoint", config); }, {"not an rmpmarl checkpoint"});
  ExpectRefused([&] { resume_from("", config); }, {"not an rmpmarl checkpoint"});
  TrainConfig other_lr = config;
  other_lr.ppo.lr(1e-3);
  ExpectRefused([&] { resume_from(bytes, other_lr); }, {"different configuration", "ppo.lr: 0.0003", "0.001"});
  TrainConfig other_seed = config;
  other_seed.seed = 6;
  ExpectRefused([&] { resume_from(bytes, other_seed); }, {"seed: 5 in the checkpoint, 6 now"});
  TrainConfig three_agents = config;
  three_agents.task.overrides_yaml = "{agents: 3}";
  ExpectRefused([&] { resume_from(bytes, three_agents); }, {"env layout", "agents=2", "agents=3"});
  // run-local keys may differ
  TrainConfig renamed = config;
  renamed.name = "other";
  renamed.env_threads = 2;
  EXPECT_NO_THROW(resume_from(bytes, renamed));
  // a pre-trained actor must fit the new task's agent
  TrainConfig direct = ToyConfig(2, "direct");
  direct.init_actor_from = good;
  ExpectRefused([&] { Trainer t(direct, MakeTaskFactory(direct.task)); }, {"init_actor_from", "does not fit"});
  // a pre-training run that was never trained: named, with what to do
  TrainConfig missing = ToyConfig(2, "options");
  missing.init_actor_from = good + ".missing";
  ExpectRefused([&] { Trainer t(missing, MakeTaskFactory(missing.task)); },
                {"init_actor_from: expected the checkpoint of a finished pre-training run", ".missing", "no such file"});
}

// ---------------------------------------------------------------------------------------------------- resume
// the CSV without the wall-clock columns (fps, seconds).
std::string CsvWithoutTimes(const std::string& path) {
  std::istringstream in(ReadAll(path));
  std::string line, out;
  while (std::getline(in, line)) {
    for (int i = 0; i < 4; ++i) line = line.substr(0, line.rfind(','));
    out += line + "\n";
  }
  return out;
}

TEST(ResumeTest, ResumedRunEqualsUninterruptedRunBitForBit) {
  const std::string dir_a = TempDir("uninterrupted"), dir_b = TempDir("interrupted");
  TrainConfig a = ToyConfig(2, "options", dir_a);
  a.total_updates = 5;
  a.checkpoint_every = 2;
  a.env_threads = 2;
  RunTraining(a, MakeTaskFactory(a.task));

  // the same run, killed after update 3 (its last checkpoint is update 2), then resumed to the end
  TrainConfig b = a;
  b.output_dir = dir_b;
  struct Killed {};
  RunOptions kill_at_3;
  kill_at_3.on_update = [](const UpdateSummary& s) {
    if (s.update == 3) throw Killed{};
  };
  EXPECT_THROW(RunTraining(b, MakeTaskFactory(b.task), kill_at_3), Killed);
  b.env_threads = 1;  // the env thread count does not change results
  RunTraining(b, MakeTaskFactory(b.task), RunOptions{.resume = true});

  Trainer final_a(a, MakeTaskFactory(a.task)), final_b(b, MakeTaskFactory(b.task));
  final_a.Resume(dir_a + "/final.ckpt");
  final_b.Resume(dir_b + "/final.ckpt");
  EXPECT_EQ(final_a.update(), 5);
  EXPECT_EQ(final_b.update(), 5);
  const std::vector<double> sa = final_a.StateVector(), sb = final_b.StateVector();
  ASSERT_EQ(sa.size(), sb.size());
  EXPECT_TRUE(sa == sb) << "state vectors differ";
  EXPECT_EQ(CsvWithoutTimes(dir_a + "/metrics.csv"), CsvWithoutTimes(dir_b + "/metrics.csv"));
  EXPECT_EQ(ReadAll(dir_a + "/policy.rmpp"), ReadAll(dir_b + "/policy.rmpp"));
  // a finished run resumes as a no-op
  EXPECT_NO_THROW(RunTraining(b, MakeTaskFactory(b.task), RunOptions{.resume = true}));
  // no checkpoint to resume from
  TrainConfig c = a;
  c.output_dir = TempDir("empty");
  ExpectRefused([&] { RunTraining(c, MakeTaskFactory(c.task), RunOptions{.resume = true}); }, {"no checkpoint"});
  // a TensorBoard event file was written
  bool found = false;
  for (const auto& e : fs::directory_iterator(dir_a + "/tb")) found |= e.path().filename().string().rfind("events.out.tfevents.", 0) == 0;
  EXPECT_TRUE(found);
}

// ---------------------------------------------------------------------------------------------------- eval
TEST(EvaluateTest, CheckpointAndExportedRuntimeAgree) {
  const std::string dir = TempDir("eval");
  TrainConfig c = ToyConfig(2, "options", dir);
  c.total_updates = 2;
  RunTraining(c, MakeTaskFactory(c.task));
  const EvalOptions options{.episodes = 12, .num_envs = 4};
  const EvalResult torch_result = Evaluate(dir + "/final.ckpt", MakeTaskFactory(c.task), options);
  const EvalResult runtime_result = Evaluate(dir + "/policy.rmpp", MakeTaskFactory(c.task), options);
  EXPECT_EQ(torch_result.episodes, 12);
  EXPECT_EQ(runtime_result.episodes, 12);
  EXPECT_EQ(torch_result.success_rate, runtime_result.success_rate);
  EXPECT_NEAR(torch_result.tracking_error_mean_mm, runtime_result.tracking_error_mean_mm, 1e-2);
  EXPECT_NEAR(torch_result.mean_return, runtime_result.mean_return, 1e-3);
  ExpectRefused([&] { Evaluate(dir + "/policy.rmpp", MakeTaskFactory(ToyConfig(2, "direct").task), options); },
                {"does not fit"});
}

// ---------------------------------------------------------------------------------------------------- learning
// Learning smoke tests: fixed seeds, thresholds set from measured values with margin (see the comments).

TEST(LearningTest, PpoSolvesOneDimensionalReach) {
  const auto start = std::chrono::steady_clock::now();
  const std::string dir = TempDir("learn_ppo");
  TrainConfig c = ToyConfig(1, "direct", dir);
  c.num_envs = 16;
  c.total_updates = 40;
  c.checkpoint_every = 40;
  c.write_tensorboard = false;
  c.ppo = PpoOptions{}.rollout_steps(64).epochs(5).minibatches(4).lr(1e-3).entropy_continuous(0.0);
  RunTraining(c, MakeTaskFactory(c.task));
  const EvalResult r = Evaluate(dir + "/final.ckpt", MakeTaskFactory(c.task), {.episodes = 64, .num_envs = 16});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fmt::print("PPO toy-reach direct: success {:.3f}, tracking {:.1f} mm, {:.1f} s\n", r.success_rate,
             r.tracking_error_mean_mm, seconds);
  // measured (seed 5, 40 updates × 16 envs × 64 steps): success 1.000, tracking 68.7 mm, ~1 s
  EXPECT_GE(r.success_rate, 0.9);
  EXPECT_LT(r.tracking_error_mean_mm, 120.0);
}

TEST(LearningTest, MappoOptionsAgentsBeatARandomOptionPolicy) {
  const auto start = std::chrono::steady_clock::now();
  const std::string dir = TempDir("learn_mappo");
  TrainConfig c = ToyConfig(3, "options", dir);
  c.num_envs = 16;
  c.total_updates = 40;
  c.checkpoint_every = 40;
  c.write_tensorboard = false;
  c.ppo = PpoOptions{}.rollout_steps(64).epochs(5).minibatches(4).lr(1e-3);
  // the untrained policy (near-uniform options, terminating half the time) as the random-option baseline
  TrainConfig untrained = c;
  untrained.total_updates = 1;
  untrained.ppo.lr(1e-12);
  untrained.output_dir = TempDir("learn_mappo_random");
  RunTraining(untrained, MakeTaskFactory(c.task));
  const EvalOptions eval{.episodes = 64, .num_envs = 16, .stochastic = true};
  const EvalResult random = Evaluate(untrained.output_dir + "/final.ckpt", MakeTaskFactory(c.task), eval);
  RunTraining(c, MakeTaskFactory(c.task));
  const EvalResult trained = Evaluate(dir + "/final.ckpt", MakeTaskFactory(c.task), eval);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fmt::print("MAPPO toy-reach options, 3 agents: return {:.2f} vs random {:.2f}; tracking {:.1f} vs {:.1f} mm; "
             "success {:.3f} vs {:.3f}; {:.1f} s\n", trained.mean_return, random.mean_return,
             trained.tracking_error_mean_mm, random.tracking_error_mean_mm, trained.success_rate,
             random.success_rate, seconds);
  // measured (seed 5): return −2.60 vs −23.41, tracking 64.9 vs 585.4 mm, success 0.953 vs 0.000, ~2 s
  EXPECT_GT(trained.mean_return, random.mean_return + 10.0);
  EXPECT_LT(trained.tracking_error_mean_mm, 0.3 * random.tracking_error_mean_mm);
  EXPECT_GT(trained.success_rate, 0.7);
}

// HRL-RMP on a reduced pretrain-2link (100-step episodes, 2 robot variants, 64-unit MLPs): the per-joint RMP agents
// trained with MAPPO for 150 updates (120k env steps) against the random-option policy — the untrained actor,
// sampled: near-uniform options (logits ≈ 0 from the 0.01-gain output layer), termination p ≈ ½, gains ~ N(0, 0.61).
TEST(LearningTest, HrlRmpOnReducedPretrain2LinkBeatsRandomOptions) {
  const auto start = std::chrono::steady_clock::now();
  TrainConfig c = ToyConfig(2, "per-joint-rmp", TempDir("learn_hrl"));
  c.task = TaskSelection{.name = "pretrain-2link", .interface = "per-joint-rmp",
                         .overrides_yaml = "{episode: {max_steps: 100}, randomization: {variants: 2}}"};
  c.seed = 3;
  c.total_updates = 150;
  c.checkpoint_every = 150;
  c.write_tensorboard = false;
  c.network = NetworkOptions{}.actor_hidden({64, 64}).critic_hidden({64, 64});
  c.ppo = PpoOptions{}.rollout_steps(100).epochs(4).minibatches(4).lr(1e-3);
  const tasks::EnvFactory factory = MakeTaskFactory(c.task);
  TrainConfig untrained = c;
  untrained.total_updates = 1;
  untrained.ppo.lr(1e-12);
  untrained.output_dir = TempDir("learn_hrl_random");
  RunTraining(untrained, factory);
  RunTraining(c, factory);
  const EvalOptions sampled{.episodes = 128, .num_envs = 16, .stochastic = true};
  const EvalResult random = Evaluate(untrained.output_dir + "/final.ckpt", factory, sampled);
  const EvalResult trained = Evaluate(c.output_dir + "/final.ckpt", factory, sampled);
  const EvalResult trained_modes = Evaluate(c.output_dir + "/final.ckpt", factory, {.episodes = 128, .num_envs = 16});
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  fmt::print("HRL-RMP reduced pretrain-2link: return {:.1f} (modes {:.1f}) vs random {:.1f}; success {:.3f} (modes "
             "{:.3f}) vs {:.3f}; {:.1f} s\n", trained.mean_return, trained_modes.mean_return, random.mean_return,
             trained.success_rate, trained_modes.success_rate, random.success_rate, seconds);
  // measured (seed 3): return 623.5 (modes 606.4) vs random 557.0. The margin over seeds 1, 2, 3, 4 (same setup, CLI):
  // +70/+74/+66/+58 sampled, +64/+56/+49/+58 modes, so the threshold +25 has a 2× margin. Success (no collision in
  // 100 steps) does not separate them here (random: 0.88–0.96), so it is printed, not asserted.
  EXPECT_GT(trained.mean_return, random.mean_return + 25.0);
  EXPECT_GT(trained_modes.mean_return, random.mean_return + 25.0);
}

}  // namespace
}  // namespace rmpmarl::rl
