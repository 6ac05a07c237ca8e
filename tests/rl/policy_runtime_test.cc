// control::PolicyRuntime::ActWhere against Act: the agents asked for get Act's actions bit for bit, in the AVX2
// kernel and in the portable one, and the agents left out keep what their action rows held.
#include "rmpmarl/control/policy_runtime.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <vector>

namespace rmpmarl::rl {
namespace {

// an actor of the shipped default's shape (41 → 128 → 128 → 128 → 3 options + 4 continuous), random weights
control::PolicyWeights RandomWeights(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> normal(0.0f, 1.0f);
  auto random = [&](Eigen::Index rows, Eigen::Index cols, float scale) {
    Eigen::MatrixXf m(rows, cols);
    for (Eigen::Index i = 0; i < m.size(); ++i) m.data()[i] = scale * normal(rng);
    return m;
  };
  control::PolicyWeights w;
  w.obs_dim = 41;
  w.num_options = 3;
  w.num_continuous = 4;
  int in = w.obs_dim;
  for (int l = 0; l < 3; ++l) {
    w.hidden.push_back({random(128, in, 1.0f / std::sqrt(static_cast<float>(in))), random(128, 1, 0.1f).col(0)});
    in = 128;
  }
  w.head = {random(w.head_size(), in, 0.1f), random(w.head_size(), 1, 0.1f).col(0)};
  w.obs_clip = 5.0f;
  w.obs_mean = random(w.obs_dim, 1, 0.1f).col(0);
  w.obs_inv_std = Eigen::VectorXf::Constant(w.obs_dim, 2.0f);
  w.log_std = Eigen::VectorXf::Zero(w.num_continuous);
  w.low = Eigen::VectorXf::Constant(w.num_continuous, -1.0f);
  w.high = Eigen::VectorXf::Constant(w.num_continuous, 1.0f);
  return w;
}

// 11 agents, so that the AVX2 kernel's batches of 8 are split differently in the two calls; random subsets,
// the empty and the full one included; compared bit for bit
TEST(PolicyRuntimeTest, ActWhereGivesActsActionsForTheAgentsItEvaluates) {
  const control::PolicyWeights w = RandomWeights(3);
  constexpr int kAgents = 11;
  for (const bool avx2 : {true, false}) {
    control::PolicyRuntime runtime(w, kAgents);
    if (!avx2) runtime.DisableAvx2();
    SCOPED_TRACE(runtime.uses_avx2());
    std::mt19937_64 rng(11);
    std::normal_distribution<float> normal(0.0f, 1.0f);
    std::bernoulli_distribution coin(0.4);
    const int as = runtime.action_size();
    int compared = 0;
    for (int trial = 0; trial < 64; ++trial) {
      std::vector<float> obs(static_cast<size_t>(kAgents) * w.obs_dim);
      for (float& o : obs) o = normal(rng);
      std::vector<float> all(static_cast<size_t>(kAgents) * as);
      runtime.Act(obs.data(), kAgents, all.data());
      std::vector<float> read(kAgents);
      int expected = 0;
      for (int a = 0; a < kAgents; ++a) {
        read[a] = trial == 0 ? 0.0f : trial == 1 ? 1.0f : static_cast<float>(coin(rng));
        expected += read[a] != 0.0f;
      }
      std::vector<float> some(all.size(), -9.0f);
      EXPECT_EQ(runtime.ActWhere(obs.data(), kAgents, read.data(), some.data()), expected);
      for (int a = 0; a < kAgents; ++a) {
        const float* got = some.data() + static_cast<size_t>(a) * as;
        if (read[a] != 0.0f) {
          EXPECT_EQ(std::memcmp(got, all.data() + static_cast<size_t>(a) * as, sizeof(float) * as), 0)
              << "agent " << a << " trial " << trial;
          compared += as;
        } else {
          EXPECT_EQ(std::vector<float>(got, got + as), std::vector<float>(as, -9.0f));  // left as it was
        }
      }
    }
    EXPECT_GT(compared, 64 * as);
  }
}

}  // namespace
}  // namespace rmpmarl::rl
