// The PPO maths against hand-computed values, the hybrid head, normalisers, and the Eigen runtime vs libtorch.
#include "rmpmarl/rl/torch/ppo.h"

#include <gtest/gtest.h>
#include <ATen/CPUGeneratorImpl.h>
#include <torch/types.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <random>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/rl/torch/tensorboard.h"
#include "rmpmarl/rl/torch/toy_reach.h"

namespace rmpmarl::rl {
namespace {

torch::Tensor T(std::vector<float> v) { return torch::tensor(v, torch::kFloat); }
torch::Tensor T2(std::vector<float> v, int64_t rows) { return T(std::move(v)).reshape({rows, -1}); }

void ExpectNear(const torch::Tensor& got, std::vector<double> want, double tol = 1e-5) {
  const torch::Tensor g = got.to(torch::kDouble).contiguous().reshape({-1});
  ASSERT_EQ(g.numel(), static_cast<int64_t>(want.size()));
  for (size_t i = 0; i < want.size(); ++i) EXPECT_NEAR(g[i].item<double>(), want[i], tol) << "element " << i;
}

// ---------------------------------------------------------------------------------------------------- GAE
TEST(GaeTest, HandComputedWithTerminationAndTruncation) {
  // γ = 0.9, λ = 0.8, so γλ = 0.72. Columns are envs.
  // env 0: no episode end; last value 2.
  //   t=2: δ = 3 + 0.9·2 − 1.5 = 3.3                      Â = 3.3
  //   t=1: δ = 2 + 0.9·1.5 − 1 = 2.35                      Â = 2.35 + 0.72·3.3 = 4.726
  //   t=0: δ = 1 + 0.9·1 − 0.5 = 1.4                       Â = 1.4 + 0.72·4.726 = 4.80272
  // env 1: terminated at t=0 (no bootstrap), truncated at t=1 (bootstrap V(final) = 10), last value 5.
  //   t=2: δ = 1 + 0.9·5 − 4 = 1.5                         Â = 1.5
  //   t=1: δ = 1 + 0.9·10 − 3 = 7     (no carry)           Â = 7
  //   t=0: δ = 1 + 0 − 2 = −1         (no carry)           Â = −1
  GaeInputs in;
  in.rewards = T2({1, 1, 2, 1, 3, 1}, 3);
  in.values = T2({0.5, 2, 1.0, 3, 1.5, 4}, 3);
  in.terminated = T2({0, 1, 0, 0, 0, 0}, 3);
  in.truncated = T2({0, 0, 0, 1, 0, 0}, 3);
  in.final_values = T2({99, 99, 99, 10, 99, 99}, 3);  // read only where truncated
  in.last_values = T({2, 5});
  const GaeResult r = ComputeGae(in, 0.9, 0.8);
  ExpectNear(r.advantages, {4.80272, -1, 4.726, 7, 3.3, 1.5});
  ExpectNear(r.returns, {5.30272, 1, 5.726, 10, 4.8, 5.5});
}

TEST(GaeTest, LambdaOneIsTheDiscountedReturnMinusValue) {
  GaeInputs in;
  in.rewards = T2({1, 1, 1}, 3);
  in.values = T2({0, 0, 0}, 3);
  in.terminated = T2({0, 0, 1}, 3);
  in.truncated = T2({0, 0, 0}, 3);
  in.final_values = T2({0, 0, 0}, 3);
  in.last_values = T({100});
  ExpectNear(ComputeGae(in, 0.5, 1.0).returns, {1.75, 1.5, 1});  // 1 + .5 + .25, 1 + .5, 1
}

TEST(GaeTest, RejectsMismatchedShapes) {
  GaeInputs in;
  in.rewards = T2({1, 1, 1}, 3);
  in.values = T2({0, 0}, 2);
  in.terminated = in.truncated = in.final_values = in.rewards;
  in.last_values = T({0});
  EXPECT_THROW(ComputeGae(in, 0.9, 0.9), c10::Error);
}

// ---------------------------------------------------------------------------------------------------- losses
TEST(PpoLossTest, AdvantageNormalisationIsCorrectlyParenthesised) {
  // (a − mean) / (std + eps): mean 2.5, unbiased std √(5/3) = 1.2909944
  ExpectNear(NormalizeAdvantages(T({1, 2, 3, 4}), 1e-8), {-1.161895, -0.387298, 0.387298, 1.161895});
  // the public-code bug a − mean / (std + eps) would give 1 − 1.936492 = −0.936492 for the first element
  const torch::Tensor n = NormalizeAdvantages(T({10, 20, 30, 40}), 1e-8);
  EXPECT_NEAR(n.mean().item<double>(), 0.0, 1e-6);
  EXPECT_NEAR(n.std().item<double>(), 1.0, 1e-6);
}

TEST(PpoLossTest, ClippedSurrogateHandComputed) {
  // ratios 1.5, 0.5, 1.1; advantages 1, −1, 2; ε = 0.2:
  //   min(1.5·1, 1.2·1) = 1.2;  min(0.5·−1, 0.8·−1) = −0.8;  min(1.1·2, 1.1·2) = 2.2  → loss −(2.6 / 3)
  const torch::Tensor log_prob = torch::log(T({1.5, 0.5, 1.1}));
  EXPECT_NEAR(ClippedSurrogateLoss(log_prob, T({0, 0, 0}), T({1, -1, 2}), 0.2).item<double>(), -2.6 / 3, 1e-6);
  // with old log-probs shifted by the same amount the ratio is unchanged
  EXPECT_NEAR(ClippedSurrogateLoss(log_prob + 3.0, T({3, 3, 3}), T({1, -1, 2}), 0.2).item<double>(), -2.6 / 3,
              1e-5);
}

TEST(PpoLossTest, ClippedValueLossHandComputed) {
  // V = (1, 2), V_old = (0.5, 2.5), R = (2, 1), ε = 0.2:
  //   (V − R)² = 1, 1;  V_clip = 0.7, 2.3 → (V_clip − R)² = 1.69, 1.69;  ½ mean(max) = 0.845
  EXPECT_NEAR(ClippedValueLoss(T({1, 2}), T({0.5, 2.5}), T({2, 1}), 0.2).item<double>(), 0.845, 1e-6);
  EXPECT_NEAR(ClippedValueLoss(T({1, 2}), T({0.5, 2.5}), T({2, 1}), 0.0).item<double>(), 0.5, 1e-6);
  // inside the clip range the clipped term equals the plain one
  EXPECT_NEAR(ClippedValueLoss(T({1, 2}), T({0.95, 2.05}), T({2, 1}), 0.2).item<double>(), 0.5, 1e-6);
}

TEST(PpoLossTest, MaskedMean) {
  EXPECT_NEAR(MaskedMean(T({1, 2, 3, 4}), T({1, 0, 1, 0})).item<double>(), 2.0, 1e-7);
  EXPECT_NEAR(MaskedMean(T({1, 2}), T({0, 0})).item<double>(), 0.0, 1e-7);  // no division by zero
}

// ---------------------------------------------------------------------------------------------------- hybrid head
// Two rows; layout: 3 options, 2 continuous, termination.
//   row 0: logits (0, 1, 2), means (0.5, −1), log σ = (log ½, 0), termination logit 0.3; action [2, 1.5, 0.5, 1]
//   row 1: logits (1, 1, 1), means (0, 0),                     termination logit −1;  action [0, 0, 0, 0]
struct HeadFixture {
  HeadLayout layout{3, 2, true};
  HeadOutputs head;
  torch::Tensor actions;
  HeadFixture() {
    head.option_logits = T2({0, 1, 2, 1, 1, 1}, 2);
    head.mean = T2({0.5, -1, 0, 0}, 2);
    head.log_std = T({std::log(0.5f), 0.0f});
    head.termination_logit = T({0.3f, -1.0f});
    actions = T2({2, 1.5, 0.5, 1, 0, 0, 0, 0}, 2);
  }
};

TEST(HybridHeadTest, LogProbsHandComputed) {
  HeadFixture f;
  const HeadLogProbs lp = LogProbs(f.head, f.layout, f.actions);
  // option: 2 − log(1 + e + e²) = −0.4076060;  row 1: −log 3
  ExpectNear(lp.option, {-0.4076059644, -1.0986122887});
  // continuous: Σ_i −½ z_i² − log σ_i − ½ log 2π with z = (2, 1.5): (−2 + 0.693147 − 0.918939) + (−1.125 − 0.918939)
  //   row 1: z = (0, 0): (0.693147 − 0.918939) + (−0.918939)
  ExpectNear(lp.continuous, {-4.2697298858, -1.1447298858});
  // termination: log σ(0.3) (terminate = 1);  log σ(1) = log(1 − σ(−1)) (terminate = 0)
  ExpectNear(lp.termination, {-0.5543552445, -0.3132616875});
}

TEST(HybridHeadTest, EntropiesHandComputed) {
  HeadFixture f;
  const HeadEntropies h = Entropies(f.head, f.layout);
  ExpectNear(h.option, {0.8323955818, 1.0986122887});        // −Σ p log p; uniform: log 3
  ExpectNear(h.continuous, {2.1447298858, 2.1447298858});    // Σ (½ + ½ log 2π + log σ_i), state-independent
  ExpectNear(h.termination, {0.6820224894, 0.5822031089});   // Bernoulli(σ(0.3)), Bernoulli(σ(−1))
}

TEST(HybridHeadTest, JointLogProbMasksTheOptionAndTermination) {
  HeadFixture f;
  const HeadLogProbs lp = LogProbs(f.head, f.layout, f.actions);
  // row 0: option started and an option was running: all three heads count
  // row 1: option not started (the option index was ignored), first step of an episode (no termination decision)
  ExpectNear(JointLogProb(lp, T({1, 0}), T({1, 0})), {-0.4076059644 - 4.2697298858 - 0.5543552445, -1.1447298858});
  // with the continuous mask (options.parameter_period): row 1's parameters were held, not read, so only the
  // termination flag would count there — and its mask is 0 in this row, so nothing does
  ExpectNear(JointLogProb(lp, T({1, 0}), T({1, 0}), T({1, 0})), {-0.4076059644 - 4.2697298858 - 0.5543552445, 0.0});
  ExpectNear(JointLogProb(lp, T({0, 0}), T({0, 1}), T({1, 0})), {-0.5543552445, -1.1447298858});
}

TEST(HybridHeadTest, HeadSizesComeFromTheActionSpec) {
  torch::manual_seed(1);
  for (const auto& [options, continuous, termination] :
       std::vector<std::tuple<int, int, bool>>{{3, 1, true}, {0, 4, false}, {5, 0, false}, {0, 0, true}, {2, 7, true}}) {
    tasks::EnvSpec spec;
    spec.task = "sizes";
    spec.local_obs_dim = 4;
    spec.global_state_dim = 6;
    spec.action.num_options = options;
    spec.action.num_continuous = continuous;
    spec.action.low.assign(continuous, -1.0f);
    spec.action.high.assign(continuous, 1.0f);
    spec.action.has_termination = termination;
    Ppo ppo(spec, NetworkOptions{}.actor_hidden({8}).critic_hidden({8}), PpoOptions{}, 3);
    const HeadOutputs head = ppo.actor()->forward(torch::randn({5, 4}));
    EXPECT_EQ(head.option_logits.defined() ? head.option_logits.size(1) : 0, options);
    EXPECT_EQ(head.mean.defined() ? head.mean.size(1) : 0, continuous);
    EXPECT_EQ(head.termination_logit.defined(), termination);
    const ActResult r = ppo.Act(torch::randn({5, 4}), torch::randn({5, 6}), true, false);
    EXPECT_EQ(r.sampled.actions.size(1), spec.action.size());
    if (options > 0) {
      const torch::Tensor o = r.sampled.actions.select(1, 0);
      EXPECT_TRUE((o >= 0).all().item<bool>() && (o < options).all().item<bool>());
      EXPECT_TRUE(torch::equal(o, o.round()));
    }
    if (termination) {
      const torch::Tensor b = r.sampled.actions.select(1, spec.action.termination_offset());
      EXPECT_TRUE(((b == 0) | (b == 1)).all().item<bool>());
    }
  }
  tasks::EnvSpec empty;
  empty.local_obs_dim = empty.global_state_dim = 2;
  EXPECT_THROW(Ppo(empty, NetworkOptions{}, PpoOptions{}, 1), InputError);
}

TEST(HybridHeadTest, SampledLogProbsMatchTheEmpiricalFrequencies) {
  HeadFixture f;
  torch::Generator gen = at::make_generator<at::CPUGeneratorImpl>(7);
  HeadOutputs one;
  one.option_logits = f.head.option_logits.narrow(0, 0, 1).expand({20000, 3});
  one.mean = f.head.mean.narrow(0, 0, 1).expand({20000, 2});
  one.log_std = f.head.log_std;
  one.termination_logit = f.head.termination_logit.narrow(0, 0, 1).expand({20000});
  const SampledActions s = SampleActions(one, f.layout, gen, false);
  EXPECT_NEAR((s.actions.select(1, 0) == 2).to(torch::kFloat).mean().item<double>(), 0.66524, 0.01);
  EXPECT_NEAR(s.actions.select(1, 1).mean().item<double>(), 0.5, 0.02);
  EXPECT_NEAR(s.actions.select(1, 1).std().item<double>(), 0.5, 0.02);
  EXPECT_NEAR(s.actions.select(1, 3).mean().item<double>(), 0.574443, 0.01);
  const SampledActions mode = SampleActions(f.head, f.layout, gen, true);
  ExpectNear(mode.actions, {2, 0.5, -1, 1, 0, 0, 0, 0});  // argmax (first of ties), means, σ(logit) > ½
}

TEST(PpoLossTest, ComputePpoLossComposesTheTerms) {
  HeadFixture f;
  LossInputs in;
  in.layout = f.layout;
  in.head = f.head;
  in.actions = f.actions;
  in.old_log_probs = LogProbs(f.head, f.layout, f.actions);  // ratio 1
  in.option_mask = T({1, 0});
  in.termination_mask = T({1, 1});
  in.advantages = T({1, 3});
  in.values = T({1, 2});
  in.old_values = T({0.5, 2.5});
  in.returns = T({2, 1});
  const PpoOptions o = PpoOptions{}.clip(0.2).value_clip(0.2).value_coef(0.5).entropy_option(0.1)
                           .entropy_continuous(0.01).entropy_termination(0.2);
  const LossTerms terms = ComputePpoLoss(in, o);
  EXPECT_NEAR(terms.policy.item<double>(), -2.0, 1e-6);  // −mean(1·1, 1·3)
  EXPECT_NEAR(terms.value.item<double>(), 0.845, 1e-6);
  // entropies: option over the masked row 0 only; continuous over both; termination over both
  EXPECT_NEAR(terms.entropy_option, 0.8323955818, 1e-5);
  EXPECT_NEAR(terms.entropy_continuous, 2.1447298858, 1e-5);
  EXPECT_NEAR(terms.entropy_termination, (0.6820224894 + 0.5822031089) / 2, 1e-5);
  const double bonus = 0.1 * 0.8323955818 + 0.01 * 2.1447298858 + 0.2 * (0.6820224894 + 0.5822031089) / 2;
  EXPECT_NEAR(terms.entropy.item<double>(), bonus, 1e-5);
  EXPECT_NEAR(terms.total.item<double>(), -2.0 + 0.5 * 0.845 - bonus, 1e-5);
  EXPECT_NEAR(terms.approx_kl, 0.0, 1e-7);
  EXPECT_NEAR(terms.clip_fraction, 0.0, 1e-7);
}

// ---------------------------------------------------------------------------------------------------- normalisers
TEST(RunningMeanStdTest, MatchesTheBatchStatisticsAfterSeveralUpdates) {
  RunningMeanStd norm(2);
  const torch::Tensor a = T2({1, 10, 2, 20, 3, 30}, 3), b = T2({4, 40, 5, 50}, 2);
  norm.Update(a);
  norm.Update(b);
  // all five rows: mean (3, 30), population variance (2, 200) (the 1e-4 prior count is negligible)
  ExpectNear(norm.mean(), {3, 30}, 1e-3);
  ExpectNear(norm.var(), {2, 200}, 5e-2);
  ExpectNear(norm.Normalize(T2({3, 30, 5, 30}, 2)), {0, 0, 2 / std::sqrt(2.0), 0}, 1e-3);
  ExpectNear(norm.Normalize(T2({100, 30}, 1), 5.0), {5, 0}, 1e-4);  // clipped
  ExpectNear(norm.Denormalize(norm.Normalize(T2({1.5, -7}, 1))), {1.5, -7}, 1e-4);
}

// ---------------------------------------------------------------------------------------------------- runtime
tasks::EnvSpec ToySpec(int agents) { return ToyReachEnv(ToyReachOptions{.agents = agents, .options = true}).spec(); }

// a learner with non-trivial weights and observation statistics.
std::unique_ptr<Ppo> TrainedLookingLearner() {
  const tasks::EnvSpec spec = ToySpec(7);
  auto ppo = std::make_unique<Ppo>(spec, NetworkOptions{}.actor_output_gain(1.0), PpoOptions{}, 11);
  torch::manual_seed(3);
  ppo->obs_norm().Update(torch::randn({64, spec.local_obs_dim}) * 3.0 + 1.0);
  return ppo;
}

TEST(PolicyRuntimeTest, MatchesLibtorchWithin1em5) {
  auto ppo = TrainedLookingLearner();
  const control::PolicyWeights weights = ppo->Export();
  control::PolicyRuntime avx(weights, 9), portable(weights, 9);
  portable.DisableAvx2();
  const int d = weights.obs_dim, hs = weights.head_size();
  for (int agents = 1; agents <= 9; ++agents) {
    torch::manual_seed(agents);
    const torch::Tensor obs = torch::randn({agents, d}) * 4.0;
    const HeadOutputs head = ppo->actor()->forward(ppo->obs_norm().Normalize(obs, 10.0));
    const torch::Tensor want = torch::cat({head.option_logits, head.mean, head.termination_logit.unsqueeze(1)}, 1);
    for (control::PolicyRuntime* rt : {&avx, &portable}) {
      std::vector<float> got(static_cast<size_t>(agents) * hs);
      rt->EvaluateHead(obs.contiguous().data_ptr<float>(), agents, got.data());
      double max_error = 0.0;
      for (int i = 0; i < agents * hs; ++i) {
        max_error = std::max<double>(max_error, std::abs(got[i] - want.reshape({-1})[i].item<float>()));
      }
      EXPECT_LT(max_error, 1e-5) << agents << " agents, avx2 " << rt->uses_avx2();
      EXPECT_GT(want.abs().max().item<double>(), 0.1);  // the comparison is not between near-zeros
    }
  }
}

TEST(PolicyRuntimeTest, ActionsEqualTheDeterministicLibtorchActions) {
  auto ppo = TrainedLookingLearner();
  control::PolicyRuntime rt(ppo->Export(), 7);
  torch::manual_seed(5);
  const torch::Tensor obs = torch::randn({7, rt.obs_dim()}) * 2.0;
  const ActResult r = ppo->Act(obs, torch::zeros({1, ppo->spec().global_state_dim}), false, true);
  std::vector<float> actions(7 * rt.action_size());
  rt.Act(obs.data_ptr<float>(), 7, actions.data());
  const torch::Tensor want = r.sampled.actions.contiguous();
  for (int a = 0; a < 7; ++a) {
    EXPECT_EQ(actions[a * 3 + 0], want[a][0].item<float>());  // option
    EXPECT_NEAR(actions[a * 3 + 1], std::clamp(want[a][1].item<float>(), 0.0f, 1.0f), 1e-5);  // clamped to [low, high]
    EXPECT_EQ(actions[a * 3 + 2], want[a][2].item<float>());  // terminate
  }
}

TEST(PolicyRuntimeTest, FileRoundTripAndCorruptFilesRefused) {
  auto ppo = TrainedLookingLearner();
  const control::PolicyWeights w = ppo->Export();
  const std::string path = ::testing::TempDir() + "/runtime_test.rmpp";
  control::PolicyFile file;
  file.weights = w;
  file.task_yaml = ControllerTaskYaml(tasks::TaskConfigPath("reach-avoid"), "{options: {gain_range: 3}, scenario: "
                                      "{num_obstacles: 1}}", "per-joint-direct");
  file.provenance_yaml = "{seed: 4, commit: abc}";
  control::SavePolicyFile(file, path);
  const control::PolicyFile loaded = control::LoadPolicyFile(path);
  const control::PolicyWeights& back = loaded.weights;
  EXPECT_EQ(loaded.provenance_yaml, file.provenance_yaml);
  // the controller sections keep the training overrides, the scene goes back to the shipped task's
  const tasks::TaskConfig task = PolicyTaskConfig(loaded, path);
  EXPECT_EQ(task.options.gain_range, 3.0);
  EXPECT_EQ(task.interface, tasks::InterfaceMode::kPerJointDirect);
  EXPECT_EQ(task.scenario.crossing.num_obstacles, tasks::LoadShippedTaskConfig("reach-avoid").scenario.crossing.num_obstacles);
  EXPECT_NE(PolicyCard(loaded, path).find("gain_range: 3"), std::string::npos);
  EXPECT_EQ(back.hidden.size(), 3u);
  EXPECT_EQ(back.hidden[1].weight, w.hidden[1].weight);
  EXPECT_EQ(back.head.bias, w.head.bias);
  EXPECT_EQ(back.obs_inv_std, w.obs_inv_std);
  EXPECT_EQ(back.high, w.high);

  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), {});
  }
  auto expect_refused = [&](const std::string& content, const std::string& words) {
    const std::string bad = ::testing::TempDir() + "/runtime_test_bad.rmpp";
    std::ofstream(bad, std::ios::binary | std::ios::trunc) << content;
    try {
      control::LoadPolicyFile(bad);
      ADD_FAILURE() << "accepted a bad file (" << words << ")";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  std::string flipped = bytes;
  flipped[bytes.size() / 2] ^= 0x10;
  expect_refused(flipped, "checksum mismatch");
  expect_refused(bytes.substr(0, bytes.size() / 2), "checksum");
  expect_refused("hello world, not a policy", "not an rmpmarl policy file");
  std::string version = bytes;
  version[8] = 7;
  expect_refused(version, "format version 7");
  // a format-1 file (the network alone) is refused with the upgrade command, and still readable for the upgrade
  std::string v1 = bytes.substr(0, 12);
  v1[8] = 1;
  {
    std::ifstream in(path, std::ios::binary);
    in.seekg(12);
    std::string weights_bytes(std::istreambuf_iterator<char>(in), {});
    // drop the two texts (length-prefixed) and the checksum from the end
    const std::size_t texts = 8 + file.task_yaml.size() + file.provenance_yaml.size();
    v1 += weights_bytes.substr(0, weights_bytes.size() - 4 - texts);
  }
  const std::uint32_t crc = control::Crc32c(v1.data(), v1.size());
  v1.append(reinterpret_cast<const char*>(&crc), 4);
  expect_refused(v1, "rmpmarl policy upgrade");
  const std::string v1_path = ::testing::TempDir() + "/runtime_test_v1.rmpp";
  std::ofstream(v1_path, std::ios::binary | std::ios::trunc) << v1;
  EXPECT_EQ(control::LoadPolicyFileV1(v1_path).head.weight, w.head.weight);
  // a text that is not a mapping is refused when saved
  control::PolicyFile not_a_map = file;
  not_a_map.provenance_yaml = "[1, 2]";
  EXPECT_THROW(control::SavePolicyFile(not_a_map, path), InputError);
}

// ---------------------------------------------------------------------------------------------------- tensorboard
TEST(TensorBoardTest, MaskedCrcAndEventEncoding) {
  EXPECT_EQ(control::Crc32c("123456789", 9), 0xE3069283u);  // the CRC-32C check value
  EXPECT_EQ(MaskedCrc32c("123456789", 9), 0xC78AB0E5u);
  // Event{wall_time 1.0, step 2, summary{value{tag "a", simple_value 0.5}}}, encoded by hand:
  const std::string want = std::string("\x09\x00\x00\x00\x00\x00\x00\xF0\x3F", 9) + std::string("\x10\x02", 2) +
                           std::string("\x2A\x0A", 2) + std::string("\x0A\x08", 2) +
                           std::string("\x0A\x01\x61\x15\x00\x00\x00\x3F", 8);
  EXPECT_EQ(EncodeScalarEvent(1.0, 2, {{"a", 0.5f}}), want);
  const std::string record = FrameRecord("xyz");
  ASSERT_EQ(record.size(), 8u + 4 + 3 + 4);
  EXPECT_EQ(record.substr(0, 8), std::string("\x03\0\0\0\0\0\0\0", 8));
  std::uint32_t data_crc;
  std::memcpy(&data_crc, record.data() + 15, 4);
  EXPECT_EQ(data_crc, MaskedCrc32c("xyz", 3));
}

}  // namespace
}  // namespace rmpmarl::rl
