// The batched engine with a toy environment whose dynamics are known exactly.
#include "rmpmarl/rl/vec_env.h"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rl {
namespace {

// A 1-D random walk per agent: x_a += action + N(0, 0.1); terminated when any |x_a| > 3, truncated after 15 steps.
class RandomWalkEnv : public tasks::Env {
 public:
  explicit RandomWalkEnv(int num_agents = 2) : x_(num_agents, 0.0) {
    spec_.task = "random-walk";
    spec_.num_agents = num_agents;
    spec_.local_obs_dim = 2;
    spec_.global_state_dim = num_agents;
    spec_.action.num_continuous = 1;
    spec_.action.continuous_names = {"dx"};
    spec_.action.low = {-1.0f};
    spec_.action.high = {1.0f};
    spec_.reward_terms = {"distance", "alive"};
    spec_.max_episode_steps = 15;
  }
  const tasks::EnvSpec& spec() const override { return spec_; }

  void Reset(std::mt19937_64& rng, const tasks::StepOutput& out) override {
    for (double& x : x_) x = std::uniform_real_distribution<double>(-1.0, 1.0)(rng);
    steps_ = 0;
    Write(out);
    out.reward[0] = out.reward_terms[0] = out.reward_terms[1] = 0.0f;
    out.terminated[0] = out.truncated[0] = 0;
  }

  void Step(const float* actions, std::mt19937_64& rng, const tasks::StepOutput& out) override {
    double distance = 0.0;
    bool out_of_bounds = false;
    for (size_t a = 0; a < x_.size(); ++a) {
      x_[a] += std::clamp<double>(actions[a], -1.0, 1.0) + std::normal_distribution<double>(0.0, 0.1)(rng);
      distance += std::abs(x_[a]);
      out_of_bounds |= std::abs(x_[a]) > 3.0;
    }
    ++steps_;
    Write(out);
    out.reward_terms[0] = static_cast<float>(-distance);
    out.reward_terms[1] = 1.0f;
    out.reward[0] = out.reward_terms[0] + out.reward_terms[1];
    out.terminated[0] = out_of_bounds;
    out.truncated[0] = !out_of_bounds && steps_ >= spec_.max_episode_steps;
    if (out.terminated[0] || out.truncated[0]) {
      out.metrics->length = steps_;
      out.metrics->success = !out_of_bounds;
    }
  }

 private:
  void Write(const tasks::StepOutput& out) const {
    for (size_t a = 0; a < x_.size(); ++a) {
      out.local_obs[2 * a] = static_cast<float>(x_[a]);
      out.local_obs[2 * a + 1] = static_cast<float>(a);
      out.global_state[a] = static_cast<float>(x_[a]);
      out.option_started[a] = 0.0f;
    }
  }
  tasks::EnvSpec spec_;
  std::vector<double> x_;
  int steps_ = 0;
};

tasks::EnvFactory Factory() {
  return [](int) { return std::make_unique<RandomWalkEnv>(); };
}

// actions for step t: a deterministic pattern pushing agents outwards so that episodes terminate.
std::vector<float> Actions(int num_envs, int t) {
  std::vector<float> actions(num_envs * 2);
  for (size_t i = 0; i < actions.size(); ++i) actions[i] = 0.4f * std::sin(0.7f * t + static_cast<float>(i));
  return actions;
}

TEST(VecEnvTest, ResultsDoNotDependOnTheThreadCount) {
  const int num_envs = 7, steps = 60;
  std::vector<std::vector<float>> rewards_by_threads;
  for (int threads : {1, 2, 3, 7}) {
    VecEnv env(Factory(), {.num_envs = num_envs, .seed = 11, .num_threads = threads});
    env.Reset();
    std::vector<float> trace;
    for (int t = 0; t < steps; ++t) {
      const auto actions = Actions(num_envs, t);
      // now and then a pause longer than the threads spin, so that they also sleep and are woken
      if (t % 10 == 5) std::this_thread::sleep_for(std::chrono::milliseconds(2));
      env.Step(actions.data());
      const Batch& b = env.batch();
      for (int k = 0; k < num_envs; ++k) {
        trace.push_back(b.reward[k]);
        trace.push_back(b.local_obs(2 * k, 0));
        trace.push_back(b.terminated[k] + 2 * b.truncated[k]);
      }
    }
    rewards_by_threads.push_back(trace);
  }
  for (size_t i = 1; i < rewards_by_threads.size(); ++i) EXPECT_EQ(rewards_by_threads[i], rewards_by_threads[0]);
}

TEST(VecEnvTest, EnvKIsSeededWithSeedPlusK) {
  VecEnv env(Factory(), {.num_envs = 4, .seed = 100, .num_threads = 2});
  env.Reset();
  for (int k = 0; k < 4; ++k) {
    RandomWalkEnv reference;
    std::mt19937_64 rng(100 + k);
    std::vector<float> obs(4), state(2), terms(2), option(2);
    float reward;
    std::uint8_t term, trunc;
    tasks::EpisodeMetrics metrics;
    reference.Reset(rng, {obs.data(), state.data(), terms.data(), &reward, &term, &trunc, option.data(), &metrics});
    EXPECT_EQ(env.batch().local_obs(2 * k, 0), obs[0]);
    EXPECT_EQ(env.batch().global_state(k, 1), state[1]);
  }
}

TEST(VecEnvTest, AutoResetKeepsTheFinalStateAndTheStepsReward) {
  VecEnv env(Factory(), {.num_envs = 3, .seed = 5, .num_threads = 1});
  env.Reset();
  std::vector<float> push(6, 1.0f);  // every agent moves +1 per step: |x| > 3 within 5 steps
  std::vector<float> previous_state(3);
  bool saw_end = false;
  for (int t = 0; t < 6 && !saw_end; ++t) {
    for (int k = 0; k < 3; ++k) previous_state[k] = env.batch().global_state(k, 0);
    env.Step(push.data());
    const Batch& b = env.batch();
    for (int k = 0; k < 3; ++k) {
      if (!b.terminated[k]) continue;
      saw_end = true;
      // the final state is beyond the bound, the new episode's first state is within [-1, 1]
      EXPECT_GT(std::max(std::abs(b.final_global_state(k, 0)), std::abs(b.final_global_state(k, 1))), 3.0f);
      EXPECT_LE(std::abs(b.global_state(k, 0)), 1.0f);
      EXPECT_NEAR(b.final_global_state(k, 0), previous_state[k] + 1.0f, 0.6f);
      // the reward of the finished step is kept (not the reset's zero): −Σ|x| + 1 < −2
      EXPECT_LT(b.reward[k], -2.0f);
      EXPECT_EQ(b.metrics[k].success, false);
      EXPECT_EQ(b.metrics[k].length, t + 1);
    }
  }
  EXPECT_TRUE(saw_end);
}

// Next-step autoreset replays the same episodes as same-step autoreset: each env's sequence of (observation,
// reward, flags) is the same-step one with the final observation in place and one extra row per ended episode (the
// reset: the new first observation, reward 0, no flags), during which the env ignores its action.
TEST(VecEnvTest, NextStepAutoresetReplaysTheSameEpisodes) {
  const int num_envs = 3, steps = 40;
  VecEnv same(Factory(), {.num_envs = num_envs, .seed = 9, .num_threads = 1});
  VecEnv next(Factory(), {.num_envs = num_envs, .seed = 9, .num_threads = 2, .autoreset = Autoreset::kNextStep});
  same.Reset();
  next.Reset(9);
  struct Row {
    float obs, reward;
    int flags;
    bool operator==(const Row&) const = default;
  };
  std::vector<std::vector<Row>> expected(num_envs), got(num_envs);
  std::vector<int> t_same(num_envs, 0);  // per env: the same-step actions consumed so far
  // the next-step env consumes one same-step action per real step; its extra reset rows take a dummy action
  std::vector<std::vector<float>> same_actions;
  for (int t = 0; t < steps; ++t) {
    same_actions.push_back(Actions(num_envs, t));
    same.Step(same_actions.back().data());
    const Batch& b = same.batch();
    for (int k = 0; k < num_envs; ++k) {
      const bool ended = b.terminated[k] || b.truncated[k];
      expected[k].push_back({ended ? b.final_local_obs(2 * k, 0) : b.local_obs(2 * k, 0), b.reward[k],
                             b.terminated[k] + 2 * b.truncated[k]});
      if (ended) expected[k].push_back({b.local_obs(2 * k, 0), 0.0f, 0});
    }
  }
  std::vector<float> actions(num_envs * 2);
  bool done = false;
  std::vector<std::uint8_t> resetting(num_envs, 0);
  while (!done) {
    done = true;
    for (int k = 0; k < num_envs; ++k) {
      const int t = std::min(t_same[k], steps - 1);
      for (int a = 0; a < 2; ++a) actions[2 * k + a] = resetting[k] ? 99.0f : same_actions[t][2 * k + a];
    }
    next.Step(actions.data());
    const Batch& b = next.batch();
    for (int k = 0; k < num_envs; ++k) {
      if (!resetting[k]) ++t_same[k];
      got[k].push_back({b.local_obs(2 * k, 0), b.reward[k], b.terminated[k] + 2 * b.truncated[k]});
      resetting[k] = b.terminated[k] || b.truncated[k];
      if (t_same[k] < steps || resetting[k]) done = false;
    }
  }
  for (int k = 0; k < num_envs; ++k) {
    ASSERT_GE(got[k].size(), expected[k].size()) << "env " << k;
    got[k].resize(expected[k].size());
    EXPECT_TRUE(got[k] == expected[k]) << "env " << k;
    EXPECT_GT(expected[k].size(), static_cast<size_t>(steps)) << "env " << k << " never ended an episode";
  }
}

TEST(VecEnvTest, TruncationAtTheHorizon) {
  VecEnv env(Factory(), {.num_envs = 2, .seed = 1, .num_threads = 2});
  env.Reset();
  std::vector<float> still(4, 0.0f);
  for (int t = 1; t <= 15; ++t) {
    env.Step(still.data());
    for (int k = 0; k < 2; ++k) {
      if (env.batch().terminated[k]) continue;  // a noisy walk may still leave the bounds; rare with σ = 0.1
      EXPECT_EQ(env.batch().truncated[k], t == 15 ? 1 : 0) << "step " << t;
    }
  }
}

// An env whose reset throws (as a scenario that cannot place its obstacles does).
class ThrowingEnv : public RandomWalkEnv {
 public:
  void Reset(std::mt19937_64&, const tasks::StepOutput&) override { throw InputError("cannot place obstacles"); }
};

TEST(VecEnvTest, ExceptionsOnWorkerThreadsReachTheCaller) {
  auto factory = [](int k) -> std::unique_ptr<tasks::Env> {
    if (k == 3) return std::make_unique<ThrowingEnv>();
    return std::make_unique<RandomWalkEnv>();
  };
  VecEnv env(factory, {.num_envs = 4, .seed = 0, .num_threads = 2});
  try {
    env.Reset();
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "cannot place obstacles");
  }
}

TEST(VecEnvTest, RejectsBadOptionsAndMismatchedLayouts) {
  EXPECT_THROW(VecEnv(Factory(), {.num_envs = 0}), InputError);
  EXPECT_THROW(VecEnv(Factory(), {.num_envs = 2, .seed = 0, .num_threads = 0}), InputError);
  auto mixed = [](int k) { return std::make_unique<RandomWalkEnv>(k == 0 ? 2 : 3); };
  EXPECT_THROW(VecEnv(mixed, {.num_envs = 2}), InputError);
}

}  // namespace
}  // namespace rmpmarl::rl
