// The batched environment engine: a persistent thread pool whose threads (the caller's included) take the envs of a
// step one at a time from a shared counter, so a thread that drew cheap envs takes more; each env draws only from
// its own RNG (seeded seed + env_id), so results depend neither on the thread count nor on which thread ran an env.
// Between steps a thread first spins for a short while before it sleeps on a condition variable: the rollout's
// steps follow each other within tens of microseconds, about what a sleeping thread takes to wake.
#include "rmpmarl/rl/vec_env.h"

#include <fmt/format.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>

#include "rmpmarl/common/error.h"

namespace rmpmarl::rl {
namespace {

// how long a thread spins for the next step or for the other threads' envs before it sleeps
constexpr std::chrono::microseconds kSpinFor{200};

inline void CpuRelax() {
#if defined(__x86_64__) || defined(__i386__)
  __builtin_ia32_pause();
#endif
}

// spins until done() or kSpinFor has passed; true when done() became true
template <class Done>
bool SpinUntil(Done&& done) {
  const auto until = std::chrono::steady_clock::now() + kSpinFor;
  while (!done()) {
    for (int i = 0; i < 64; ++i) CpuRelax();
    if (done()) return true;
    if (std::chrono::steady_clock::now() > until) return false;
  }
  return true;
}

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
  std::atomic<std::uint64_t> generation{0};  // one more per job
  std::atomic<int> next_env{0};               // the next env of the current job to take
  std::atomic<int> pending{0};                // workers still in the current job
  std::atomic<bool> stopping{false};
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

  // runs the current job on env k.
  void RunOne(int k) {
    const int A = spec.num_agents;
    const size_t action_stride = static_cast<size_t>(A) * spec.action.size();
    if (job == Job::kReset || reset_next[k]) {
      reset_next[k] = 0;
      envs[k]->Reset(rngs[k], OutputOf(k));
      return;
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

  // takes envs of the current job from the shared counter until none is left, keeping the first exception for the
  // calling thread (an exception must not end a worker).
  void RunShare() {
    const int n = static_cast<int>(envs.size());
    for (int k = next_env.fetch_add(1, std::memory_order_relaxed); k < n;
         k = next_env.fetch_add(1, std::memory_order_relaxed)) {
      try {
        RunOne(k);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!error) error = std::current_exception();
      }
    }
  }

  void WorkerLoop() {
    std::uint64_t seen = 0;
    auto woken = [&] {
      return stopping.load(std::memory_order_acquire) || generation.load(std::memory_order_acquire) != seen;
    };
    while (true) {
      if (!SpinUntil(woken)) {
        std::unique_lock<std::mutex> lock(mutex);
        work_ready.wait(lock, woken);
      }
      if (stopping.load(std::memory_order_acquire)) return;
      seen = generation.load(std::memory_order_acquire);
      RunShare();
      if (pending.fetch_sub(1, std::memory_order_acq_rel) == 1) {
        // under the lock: the caller may be between testing `pending` and sleeping
        std::lock_guard<std::mutex> lock(mutex);
        work_done.notify_one();
      }
    }
  }

  void Run(Job new_job, const float* new_actions) {
    job = new_job;
    actions = new_actions;
    error = nullptr;
    next_env.store(0, std::memory_order_relaxed);
    if (workers.empty()) {
      RunShare();
      if (error) std::rethrow_exception(error);
      return;
    }
    {
      std::lock_guard<std::mutex> lock(mutex);
      pending.store(static_cast<int>(workers.size()), std::memory_order_relaxed);
      generation.fetch_add(1, std::memory_order_release);  // publishes the job, its actions and the counter
    }
    work_ready.notify_all();
    RunShare();
    auto all_done = [&] { return pending.load(std::memory_order_acquire) == 0; };
    if (!SpinUntil(all_done)) {
      std::unique_lock<std::mutex> lock(mutex);
      work_done.wait(lock, all_done);
    }
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
    impl.workers.emplace_back([&impl] { impl.WorkerLoop(); });
  }
}

VecEnv::~VecEnv() {
  {
    std::lock_guard<std::mutex> lock(impl_->mutex);
    impl_->stopping.store(true, std::memory_order_release);
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
