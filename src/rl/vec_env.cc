// The batched environment engine: a persistent thread pool steps contiguous blocks of envs; each env draws only
// from its own RNG (seeded seed + env_id), so results do not depend on the thread count.
#include "rmpmarl/rl/vec_env.h"

#include <fmt/format.h>

#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rl {
namespace {

// checks that two specs describe the same batch layout.
void CheckSameLayout(const tasks::EnvSpec& a, const tasks::EnvSpec& b, int env_id) {
  if (a.num_agents != b.num_agents || a.local_obs_dim != b.local_obs_dim ||
      a.global_state_dim != b.global_state_dim || a.action.size() != b.action.size() ||
      a.reward_terms.size() != b.reward_terms.size()) {
    throw InputError(fmt::format("env {}: layout differs from env 0 (agents {} vs {}, obs {} vs {}, state {} vs {}, "
                                 "action {} vs {}, reward terms {} vs {})", env_id, b.num_agents, a.num_agents,
                                 b.local_obs_dim, a.local_obs_dim, b.global_state_dim, a.global_state_dim,
                                 b.action.size(), a.action.size(), b.reward_terms.size(), a.reward_terms.size()));
  }
}

}  // namespace

struct VecEnv::Impl {
  VecEnvOptions options;
  std::vector<std::unique_ptr<tasks::Env>> envs;
  std::vector<std::mt19937_64> rngs;
  tasks::EnvSpec spec;
  Batch batch;
  // scratch of auto-resets: rewards and flags a reset writes must not overwrite the finished step's
  Eigen::Matrix<float, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> reset_reward_terms;
  Eigen::VectorXf reset_reward;
  std::vector<std::uint8_t> reset_flags;
  Eigen::VectorXf reset_option_started, reset_parameters_read;
  std::vector<tasks::EpisodeMetrics> reset_metrics;
  std::vector<std::uint8_t> reset_next;  // kNextStep: the env's episode ended last Step, reset it in this one

  // thread pool
  std::vector<std::thread> workers;
  std::mutex mutex;
  std::condition_variable work_ready;
  std::condition_variable work_done;
  std::uint64_t generation = 0;
  int pending = 0;
  bool stopping = false;
  enum class Job { kReset, kStep } job = Job::kStep;
  std::exception_ptr error;  // first exception thrown by an env during the current job
  const float* actions = nullptr;

  tasks::StepOutput OutputOf(int k) {
    const int A = spec.num_agents;
    tasks::StepOutput out;
    out.local_obs = batch.local_obs.data() + static_cast<size_t>(k) * A * spec.local_obs_dim;
    out.global_state = batch.global_state.data() + static_cast<size_t>(k) * spec.global_state_dim;
    out.reward_terms = batch.reward_terms.data() + static_cast<size_t>(k) * spec.reward_terms.size();
    out.reward = batch.reward.data() + k;
    out.terminated = &batch.terminated[k];
    out.truncated = &batch.truncated[k];
    out.option_started = batch.option_started.data() + static_cast<size_t>(k) * A;
    out.metrics = &batch.metrics[k];
    out.parameters_read = batch.parameters_read.data() + static_cast<size_t>(k) * A;
    return out;
  }

  tasks::StepOutput ResetOutputOf(int k) {
    tasks::StepOutput out = OutputOf(k);
    out.reward_terms = reset_reward_terms.data() + static_cast<size_t>(k) * spec.reward_terms.size();
    out.reward = reset_reward.data() + k;
    out.terminated = &reset_flags[2 * k];
    out.truncated = &reset_flags[2 * k + 1];
    out.option_started = reset_option_started.data() + static_cast<size_t>(k) * spec.num_agents;
    out.metrics = &reset_metrics[k];
    out.parameters_read = reset_parameters_read.data() + static_cast<size_t>(k) * spec.num_agents;
    return out;
  }

  // runs the current job on envs [begin, end).
  void RunBlock(int begin, int end) {
    const int A = spec.num_agents;
    const size_t action_stride = static_cast<size_t>(A) * spec.action.size();
    for (int k = begin; k < end; ++k) {
      if (job == Job::kReset || reset_next[k]) {
        reset_next[k] = 0;
        envs[k]->Reset(rngs[k], OutputOf(k));
        continue;
      }
      const tasks::StepOutput out = OutputOf(k);
      envs[k]->Step(actions + k * action_stride, rngs[k], out);
      if (options.autoreset == Autoreset::kNextStep) {
        reset_next[k] = batch.terminated[k] || batch.truncated[k];
      } else if (batch.terminated[k] || batch.truncated[k]) {
        batch.final_global_state.row(k) = batch.global_state.row(k);
        batch.final_local_obs.middleRows(static_cast<Eigen::Index>(k) * A, A) =
            batch.local_obs.middleRows(static_cast<Eigen::Index>(k) * A, A);
        envs[k]->Reset(rngs[k], ResetOutputOf(k));
      }
    }
  }

  // runs a block, keeping the first exception for the calling thread (an exception must not end a worker).
  void RunBlockCatching(int begin, int end) {
    try {
      RunBlock(begin, end);
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!error) error = std::current_exception();
    }
  }

  // envs of block b when the envs are split into `blocks` contiguous blocks.
  std::pair<int, int> Block(int b, int blocks) const {
    const int n = static_cast<int>(envs.size());
    return {static_cast<int>(static_cast<long>(n) * b / blocks), static_cast<int>(static_cast<long>(n) * (b + 1) / blocks)};
  }

  void WorkerLoop(int worker) {
    std::uint64_t seen = 0;
    while (true) {
      {
        std::unique_lock<std::mutex> lock(mutex);
        work_ready.wait(lock, [&] { return stopping || generation != seen; });
        if (stopping) return;
        seen = generation;
      }
      const auto [begin, end] = Block(worker + 1, options.num_threads);
      RunBlockCatching(begin, end);
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (--pending == 0) work_done.notify_one();
      }
    }
  }

  void Run(Job new_job, const float* new_actions) {
    job = new_job;
    actions = new_actions;
    error = nullptr;
    if (workers.empty()) {
      RunBlock(0, static_cast<int>(envs.size()));
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      pending = static_cast<int>(workers.size());
      ++generation;
    }
    work_ready.notify_all();
    const auto [begin, end] = Block(0, options.num_threads);
    RunBlockCatching(begin, end);
    std::unique_lock<std::mutex> lock(mutex);
    work_done.wait(lock, [&] { return pending == 0; });
    if (error) std::rethrow_exception(error);
  }
};

VecEnv::VecEnv(const tasks::EnvFactory& factory, const VecEnvOptions& options) : impl_(std::make_unique<Impl>()) {
  if (options.num_envs < 1) throw InputError(fmt::format("num_envs: expected >= 1, got {}", options.num_envs));
  if (options.num_threads < 1) {
    throw InputError(fmt::format("num_threads: expected >= 1, got {}", options.num_threads));
  }
  Impl& impl = *impl_;
  impl.options = options;
  impl.options.num_threads = std::min(options.num_threads, options.num_envs);
  for (int k = 0; k < options.num_envs; ++k) {
    impl.envs.push_back(factory(k));
    if (!impl.envs.back()) throw InputError(fmt::format("env factory returned no env for env {}", k));
    if (k == 0) impl.spec = impl.envs[0]->spec();
    CheckSameLayout(impl.spec, impl.envs[k]->spec(), k);
    impl.rngs.emplace_back(options.seed + static_cast<std::uint64_t>(k));
  }
  const tasks::EnvSpec& spec = impl.spec;
  const int N = options.num_envs, A = spec.num_agents, T = static_cast<int>(spec.reward_terms.size());
  Batch& b = impl.batch;
  b.local_obs.setZero(N * A, spec.local_obs_dim);
  b.global_state.setZero(N, spec.global_state_dim);
  b.reward_terms.setZero(N, T);
  b.reward.setZero(N);
  b.terminated.assign(N, 0);
  b.truncated.assign(N, 0);
  b.option_started.setZero(N * A);
  b.parameters_read.setOnes(N * A);
  b.final_global_state.setZero(N, spec.global_state_dim);
  b.final_local_obs.setZero(N * A, spec.local_obs_dim);
  b.metrics.assign(N, tasks::EpisodeMetrics{});
  impl.reset_reward_terms.setZero(N, T);
  impl.reset_reward.setZero(N);
  impl.reset_flags.assign(2 * N, 0);
  impl.reset_option_started.setZero(N * A);
  impl.reset_parameters_read.setOnes(N * A);
  impl.reset_metrics.assign(N, tasks::EpisodeMetrics{});
  impl.reset_next.assign(N, 0);
  for (int w = 0; w + 1 < impl.options.num_threads; ++w) {
    impl.workers.emplace_back([&impl, w] { impl.WorkerLoop(w); });
  }
}

VecEnv::~VecEnv() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stopping = true;
  }
  impl_->work_ready.notify_all();
  for (std::thread& t : impl_->workers) t.join();
}

const tasks::EnvSpec& VecEnv::spec() const { return impl_->spec; }
int VecEnv::num_envs() const { return static_cast<int>(impl_->envs.size()); }
const Batch& VecEnv::batch() const { return impl_->batch; }

void VecEnv::Reset() {
  for (size_t k = 0; k < impl_->rngs.size(); ++k) impl_->rngs[k].seed(impl_->options.seed + k);
  impl_->Run(Impl::Job::kReset, nullptr);
}

void VecEnv::Reset(std::uint64_t seed) {
  impl_->options.seed = seed;
  Reset();
}

void VecEnv::ResetContinuing() { impl_->Run(Impl::Job::kReset, nullptr); }

const VecEnvOptions& VecEnv::options() const { return impl_->options; }

void VecEnv::Step(const float* actions) {
  RMPMARL_ASSERT(actions != nullptr, "VecEnv::Step needs actions");
  impl_->batch.parameters_read.setOnes();  // envs that always read the continuous part leave it at 1
  impl_->Run(Impl::Job::kStep, actions);
}

}  // namespace rmpmarl::rl
