// The trainer: rollouts over a VecEnv, PPO/MAPPO updates, checkpoints (format, resume, upgrade) and policy export;
// the training loop and evaluation runs are in training_run.cc.
#include "rmpmarl/rl/torch/trainer.h"

#include "trainer_internal.h"

#include <dlfcn.h>
#include <fcntl.h>
#include <fmt/format.h>
#include <torch/serialize.h>
#include <torch/types.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/tasks/task_config.h"
#include "rmpmarl/rl/torch/ppo.h"
#include "rmpmarl/rl/torch/tensor_archive.h"
#include "rmpmarl/rl/torch/tensorboard.h"

namespace rmpmarl::rl {
namespace {

using namespace internal;

/// format 2: a TensorArchive payload; format 1: a torch::serialize archive, read only by
/// UpgradeCheckpoint (TorchScript's reader is not safe on untrusted files, tensor_archive.h)
constexpr std::uint32_t kCheckpointVersion = 2;
constexpr std::uint32_t kTorchArchiveVersion = 1;
constexpr std::size_t kCheckpointHeader = 8 + 4 + 8 + 4;  // magic, version, payload size, crc32c

// keys that may differ between a checkpoint's config and the resuming config.
bool IsRunLocalKey(const std::string& key) {
  return key == "name" || key == "output_dir" || key == "env_threads" || key == "torch_threads" ||
         key == "snapshot_updates" ||
         key.rfind("logging.", 0) == 0;
}


// ---- the checkpoint container: header + archive bytes (TensorArchive; format 1: torch::serialize)
void WriteFileAtomically(const std::string& path, const std::string& bytes) {
  const std::filesystem::path p(path);
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
  const std::string tmp = fmt::format("{}.tmp.{}", path, getpid());
  FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) throw InputError(fmt::format("checkpoint {}: cannot create {}: {}", path, tmp, std::strerror(errno)));
  const bool ok = std::fwrite(bytes.data(), 1, bytes.size(), f) == bytes.size() && std::fflush(f) == 0 &&
                  fsync(fileno(f)) == 0;
  std::fclose(f);
  if (!ok || std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    throw InputError(fmt::format("checkpoint {}: cannot write it ({})", path, std::strerror(errno)));
  }
}


std::string WrapPayload(const std::string& payload) {
  std::string out(kCheckpointMagic, 8);
  const std::uint32_t version = kCheckpointVersion;
  const std::uint64_t size = payload.size();
  const std::uint32_t crc = control::Crc32c(payload.data(), payload.size());
  out.append(reinterpret_cast<const char*>(&version), 4);
  out.append(reinterpret_cast<const char*>(&size), 8);
  out.append(reinterpret_cast<const char*>(&crc), 4);
  return out + payload;
}

// a checkpoint file's payload after its header and checksum were checked.
struct CheckpointPayload {
  std::uint32_t version = 0;
  std::string bytes;
};

CheckpointPayload ReadCheckpointPayload(const std::string& path) {
  const std::string bytes = ReadFile(path, "checkpoint");
  if (bytes.size() < kCheckpointHeader || std::memcmp(bytes.data(), kCheckpointMagic, 8) != 0) {
    throw InputError(fmt::format("checkpoint {}: not an rmpmarl checkpoint (expected magic \"RMPMCKPT\")", path));
  }
  std::uint32_t version, crc;
  std::uint64_t size;
  std::memcpy(&version, bytes.data() + 8, 4);
  std::memcpy(&size, bytes.data() + 12, 8);
  std::memcpy(&crc, bytes.data() + 20, 4);
  if (version != kCheckpointVersion && version != kTorchArchiveVersion) {
    throw InputError(fmt::format("checkpoint {}: format version {} is not supported (expected {})", path, version,
                                 kCheckpointVersion));
  }
  if (size != bytes.size() - kCheckpointHeader) {
    throw InputError(fmt::format("checkpoint {} is corrupt: expected a {}-byte payload, got {} bytes (truncated?)",
                                 path, size, bytes.size() - kCheckpointHeader));
  }
  const std::uint32_t computed = control::Crc32c(bytes.data() + kCheckpointHeader, size);
  if (computed != crc) {
    throw InputError(fmt::format("checkpoint {} is corrupt: checksum mismatch (stored crc32c {:08x}, computed {:08x})",
                                 path, crc, computed));
  }
  return {version, bytes.substr(kCheckpointHeader)};
}

// reads a checkpoint file, checks its header and checksum, and parses its archive (format 2 only).
TensorArchive OpenCheckpoint(const std::string& path) {
  CheckpointPayload payload = ReadCheckpointPayload(path);
  if (payload.version == kTorchArchiveVersion) {
    throw InputError(fmt::format(
        "checkpoint {}: format 1 (a torch::serialize archive, written before rmpmarl's checkpoint format 2) is not "
        "read by training, export or evaluation, because TorchScript's reader is not safe on untrusted files; if you "
        "trust the file, convert it once with `rmpmarl upgrade-checkpoint {}`", path, path));
  }
  return TensorArchive::Parse(payload.bytes, "checkpoint " + path);
}

// bounds of a stored env layout: no env of this project comes near them, a corrupt file may go far beyond
void CheckSpecValue(const std::string& key, std::int64_t value, std::int64_t lo, std::int64_t hi) {
  if (value < lo || value > hi) {
    throw InputError(fmt::format("{}: expected an integer in [{}, {}], got {}", key, lo, hi, value));
  }
}

// the env layout stored in a checkpoint (enough to rebuild the networks).
tasks::EnvSpec ReadSpec(const TensorArchive& archive) {
  tasks::EnvSpec s;
  auto read = [&](const char* key, std::int64_t lo, std::int64_t hi) {
    const std::int64_t v = archive.Int(key);
    CheckSpecValue(key, v, lo, hi);
    return static_cast<int>(v);
  };
  s.task = archive.String("spec/task");
  s.num_agents = read("spec/num_agents", 1, 256);
  s.local_obs_dim = read("spec/local_obs_dim", 1, 1 << 16);
  s.global_state_dim = read("spec/global_state_dim", 1, 1 << 16);
  s.action.num_options = read("spec/num_options", 0, 256);
  s.action.num_continuous = read("spec/num_continuous", 0, 256);
  s.action.has_termination = read("spec/has_termination", 0, 1) != 0;
  s.reward_terms.assign(read("spec/reward_terms", 0, 256), "");
  const std::int64_t n = s.action.num_continuous;
  const torch::Tensor low = archive.Tensor("spec/low", torch::kFloat, {n});
  const torch::Tensor high = archive.Tensor("spec/high", torch::kFloat, {n});
  s.action.low.assign(low.data_ptr<float>(), low.data_ptr<float>() + n);
  s.action.high.assign(high.data_ptr<float>(), high.data_ptr<float>() + n);
  return s;
}

void WriteSpec(TensorArchive& archive, const tasks::EnvSpec& s) {
  archive.Put("spec/task", s.task);
  archive.Put("spec/num_agents", std::int64_t{s.num_agents});
  archive.Put("spec/local_obs_dim", std::int64_t{s.local_obs_dim});
  archive.Put("spec/global_state_dim", std::int64_t{s.global_state_dim});
  archive.Put("spec/num_options", std::int64_t{s.action.num_options});
  archive.Put("spec/num_continuous", std::int64_t{s.action.num_continuous});
  archive.Put("spec/has_termination", std::int64_t{s.action.has_termination});
  archive.Put("spec/reward_terms", static_cast<std::int64_t>(s.reward_terms.size()));
  archive.Put("spec/low", torch::tensor(s.action.low, torch::kFloat));
  archive.Put("spec/high", torch::tensor(s.action.high, torch::kFloat));
}

// Before networks are built from a stored config and layout: their weight matrices alone (consecutive layer sizes,
// float32) must fit in the archive that holds them, so a corrupt config cannot make the reader allocate more than
// the file's size in networks.
void CheckNetworkFitsArchive(const TrainConfig& config, const tasks::EnvSpec& spec, std::size_t archive_bytes,
                             const std::string& path) {
  auto weights = [](std::int64_t in, const std::vector<int>& hidden) {
    double n = 0.0;
    for (int h : hidden) {
      n += static_cast<double>(in) * h;
      in = h;
    }
    return n;
  };
  const double bytes = 4.0 * (weights(spec.local_obs_dim, config.network.actor_hidden()) +
                              weights(spec.global_state_dim, config.network.critic_hidden()));
  if (bytes > static_cast<double>(archive_bytes)) {
    throw InputError(fmt::format("checkpoint {}: its stored networks would need {:.0f} bytes of weights but the "
                                 "archive holds {} bytes (corrupt config or layout)", path, bytes, archive_bytes));
  }
}






// the learner's state every rank of a run shares, in a fixed order: each parameter with its Adam moments and step,
// then each normaliser's mean, variance and count (tensors to on_tensor, numbers to on_scalar)
void ForEachLearnerValue(Ppo& ppo, const std::function<void(const torch::Tensor&)>& on_tensor,
                         const std::function<void(double)>& on_scalar) {
  std::vector<torch::Tensor> params = ppo.actor()->parameters();
  for (const torch::Tensor& p : ppo.critic()->parameters()) params.push_back(p);
  auto& state = ppo.optimizer().state();
  for (const torch::Tensor& p : params) {
    on_tensor(p);
    auto it = state.find(c10::guts::to_string(p.unsafeGetTensorImpl()));
    if (it == state.end()) continue;
    const auto& adam = static_cast<const torch::optim::AdamParamState&>(*it->second);
    on_tensor(adam.exp_avg());
    on_tensor(adam.exp_avg_sq());
    on_scalar(static_cast<double>(adam.step()));
  }
  for (RunningMeanStd* n : {&ppo.obs_norm(), &ppo.state_norm(), &ppo.value_norm()}) {
    on_tensor(n->mean());
    on_tensor(n->var());
    on_scalar(n->count());
  }
}

}  // namespace

void SetTorchThreads(int threads) {
  torch::set_num_threads(std::max(threads, 1));
  using SetThreads = void (*)(int);
  if (auto fn = reinterpret_cast<SetThreads>(dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))) {
    fn(std::max(threads, 1));
  }
}

// ------------------------------------------------------------------------------------------------- Trainer
struct Trainer::Impl {
  Collective* collective = nullptr;
  int rank = 0, world = 1;
  TrainConfig config;
  tasks::EnvFactory factory;
  tasks::EnvSpec spec;
  std::unique_ptr<VecEnv> env;
  std::unique_ptr<Ppo> ppo;
  int update = 0;
  std::int64_t env_steps = 0;
  int env_built_for = 0;   // the segment-start update the current VecEnv was seeded for
  int envs_reset_at = -1;  // update at which the current envs were seeded and reset
  std::deque<tasks::EpisodeMetrics> recent;  // the last stats_window finished episodes (checkpointed)

  // seeds and resets the envs for the segment that starts at update u (env k: seed + u·N + k).
  void ResetEnvs(int u) {
    if (!env || env_built_for != u) {
      const std::uint64_t seed = config.seed + static_cast<std::uint64_t>(u) * config.num_envs * world +
                                 static_cast<std::uint64_t>(rank) * config.num_envs;
      env = std::make_unique<VecEnv>(factory, VecEnvOptions{config.num_envs, seed, config.env_threads});
      env_built_for = u;
    }
    env->Reset();  // re-seeds env k's RNG with the VecEnv's seed + k
    envs_reset_at = u;
  }

  UpdateSummary RunUpdate();
};

Trainer::Trainer(const TrainConfig& config, tasks::EnvFactory factory, Collective* collective)
    : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  if (collective != nullptr) {
    m.collective = collective;
    m.rank = collective->rank();
    m.world = collective->world_size();
  }
  m.config = config;
  m.factory = std::move(factory);
  SetTorchThreads(config.torch_threads);
  m.env = std::make_unique<VecEnv>(
      m.factory, VecEnvOptions{config.num_envs, config.seed + static_cast<std::uint64_t>(m.rank) * config.num_envs,
                               config.env_threads});
  m.spec = m.env->spec();
  if (config.algorithm == "ppo" && m.spec.num_agents != 1) {
    throw InputError(fmt::format("algorithm \"ppo\" is single-agent, but task {} has {} agents (use \"mappo\", or a "
                                 "single-agent interface of the task)", m.spec.task, m.spec.num_agents));
  }
  m.ppo = std::make_unique<Ppo>(m.spec, config.network, config.ppo, config.seed);
  if (!config.init_actor_from.empty()) {
    if (!std::filesystem::is_regular_file(config.init_actor_from)) {
      throw InputError(fmt::format("init_actor_from: expected the checkpoint of a finished pre-training run, got '{}' "
                                   "(no such file: train that run first, e.g. `rmpmarl train "
                                   "configs/train/pretrain-2link.yaml`, or set init_actor_from)",
                                   config.init_actor_from));
    }
    LoadedCheckpoint pre = LoadLearner(config.init_actor_from);
    try {
      m.ppo->InitActorFrom(*pre.ppo);
    } catch (const InputError& e) {
      throw InputError(fmt::format("init_actor_from {}: {}", config.init_actor_from, e.what()));
    }
  }
  m.ppo->SetCollective(collective);
}

Trainer::~Trainer() = default;

bool Trainer::finished() const { return impl_->update >= impl_->config.total_updates; }
int Trainer::update() const { return impl_->update; }
int Trainer::rank() const { return impl_->rank; }
int Trainer::world_size() const { return impl_->world; }
std::int64_t Trainer::env_steps() const { return impl_->env_steps; }
const TrainConfig& Trainer::config() const { return impl_->config; }
const tasks::EnvSpec& Trainer::spec() const { return impl_->spec; }

UpdateSummary Trainer::RunUpdate() { return impl_->RunUpdate(); }

UpdateSummary Trainer::Impl::RunUpdate() {
  const auto start = std::chrono::steady_clock::now();
  if (update % config.checkpoint_every == 0 && envs_reset_at != update) ResetEnvs(update);
  if (envs_reset_at < 0) ResetEnvs(update);
  const int T = config.ppo.rollout_steps(), N = config.num_envs, A = spec.num_agents;
  const int d = spec.local_obs_dim, S = spec.global_state_dim, as = spec.action.size();
  const auto f = torch::kFloat;
  torch::Tensor obs = torch::empty({T, N * A, d}, f), state = torch::empty({T, N, S}, f);
  torch::Tensor actions = torch::empty({T, N * A, as}, f);
  torch::Tensor lp_option = torch::empty({T, N * A}, f), lp_cont = torch::empty({T, N * A}, f),
                lp_term = torch::empty({T, N * A}, f);
  // the option's log-prob counts where the option choice took effect; the termination flag is a decision at every
  // step (it ends the running option after the step), so its mask is all ones
  torch::Tensor option_mask = torch::empty({T, N * A}, f), term_mask = torch::ones({T, N * A}, f);
  // the continuous part counts where the env read it (parameters held between reads were not this step's action)
  torch::Tensor param_mask = torch::empty({T, N * A}, f);
  torch::Tensor raw_values = torch::empty({T, N}, f), values = torch::empty({T, N}, f);
  torch::Tensor rewards = torch::empty({T, N}, f), terminated = torch::zeros({T, N}, f),
                truncated = torch::zeros({T, N}, f), final_values = torch::zeros({T, N}, f);
  int finished = 0;

  for (int t = 0; t < T; ++t) {
    const Batch& b = env->batch();
    const torch::Tensor local = torch::from_blob(const_cast<float*>(b.local_obs.data()), {N * A, d}, f);
    const torch::Tensor global = torch::from_blob(const_cast<float*>(b.global_state.data()), {N, S}, f);
    const ActResult r = ppo->Act(local, global, /*update_normalizers=*/true, /*deterministic=*/false);
    obs[t].copy_(r.actor_obs);
    state[t].copy_(r.critic_state);
    actions[t].copy_(r.sampled.actions);
    lp_option[t].copy_(r.sampled.log_probs.option);
    lp_cont[t].copy_(r.sampled.log_probs.continuous);
    lp_term[t].copy_(r.sampled.log_probs.termination);
    raw_values[t].copy_(r.raw_values);
    values[t].copy_(r.values);
    const torch::Tensor step_actions = actions[t].contiguous();
    env->Step(step_actions.data_ptr<float>());
    const Batch& after = env->batch();
    std::memcpy(option_mask[t].data_ptr<float>(), after.option_started.data(), sizeof(float) * N * A);
    std::memcpy(param_mask[t].data_ptr<float>(), after.parameters_read.data(), sizeof(float) * N * A);
    std::memcpy(rewards[t].data_ptr<float>(), after.reward.data(), sizeof(float) * N);
    float* term = terminated[t].data_ptr<float>();
    float* trunc = truncated[t].data_ptr<float>();
    bool any_truncated = false;
    for (int k = 0; k < N; ++k) {
      term[k] = after.terminated[k] ? 1.0f : 0.0f;
      trunc[k] = (!after.terminated[k] && after.truncated[k]) ? 1.0f : 0.0f;
      any_truncated |= trunc[k] > 0.0f;
      if (after.terminated[k] || after.truncated[k]) {
        ++finished;
        recent.push_back(after.metrics[k]);
        if (static_cast<int>(recent.size()) > config.stats_window) recent.pop_front();
      }
    }
    if (any_truncated) {
      const torch::Tensor fin =
          torch::from_blob(const_cast<float*>(after.final_global_state.data()), {N, S}, f);
      final_values[t].copy_(ppo->Values(fin));
    }
  }
  const Batch& last = env->batch();
  const torch::Tensor last_state = torch::from_blob(const_cast<float*>(last.global_state.data()), {N, S}, f);
  const torch::Tensor last_values = ppo->Values(last_state);
  const auto rollout_end = std::chrono::steady_clock::now();
  const GaeResult gae = ComputeGae({rewards, values, terminated, truncated, final_values, last_values},
                                   config.ppo.gamma(), config.ppo.gae_lambda());

  RolloutBatch batch;
  batch.num_agents = A;
  batch.actor_obs = obs.reshape({T * N * A, d});
  batch.critic_state = state.reshape({T * N, S});
  batch.actions = actions.reshape({T * N * A, as});
  batch.old_log_probs = {lp_option.reshape({-1}), lp_cont.reshape({-1}), lp_term.reshape({-1})};
  batch.option_mask = option_mask.reshape({-1});
  batch.termination_mask = term_mask.reshape({-1});
  batch.continuous_mask = param_mask.reshape({-1});
  batch.old_values = raw_values.reshape({-1});
  batch.returns = gae.returns.reshape({-1});
  batch.advantages = gae.advantages.reshape({-1});
  double lr_scale = 1.0;
  if (config.ppo.lr_schedule() == LrSchedule::kLinear) {
    lr_scale = 1.0 - (1.0 - config.ppo.lr_final_fraction()) * update / config.total_updates;
  }
  const UpdateStats learn = ppo->Update(batch, lr_scale);
  ++update;
  env_steps += static_cast<std::int64_t>(T) * N * world;

  EpisodeStats episodes;
  for (const tasks::EpisodeMetrics& m : recent) episodes.Add(m);
  if (world > 1) {
    // the logs' episode statistics over every rank's window
    torch::Tensor sums = torch::tensor(
        {double(episodes.episodes), double(episodes.successes), double(episodes.collisions),
         double(episodes.clearance_count), episodes.return_sum, episodes.track_sum, episodes.final_track_sum,
         episodes.clearance_sum, episodes.length_sum, double(finished)}, torch::kDouble);
    collective->AllReduceSum(sums);
    const double* v = sums.data_ptr<double>();
    episodes.episodes = static_cast<int>(v[0]);
    episodes.successes = static_cast<int>(v[1]);
    episodes.collisions = static_cast<int>(v[2]);
    episodes.clearance_count = static_cast<int>(v[3]);
    episodes.return_sum = v[4];
    episodes.track_sum = v[5];
    episodes.final_track_sum = v[6];
    episodes.clearance_sum = v[7];
    episodes.length_sum = v[8];
    finished = static_cast<int>(v[9]);
  }
  UpdateSummary s;
  s.update = update;
  s.env_steps = env_steps;
  s.episodes = finished;
  s.window_episodes = episodes.episodes;
  s.mean_return = episodes.Mean(episodes.return_sum);
  s.success_rate = episodes.Mean(episodes.successes);
  s.tracking_error_mm = episodes.Mean(episodes.track_sum);
  s.final_tracking_error_mm = episodes.Mean(episodes.final_track_sum);
  s.min_clearance_m = episodes.clearance_count > 0 ? episodes.clearance_sum / episodes.clearance_count : kNaN;
  s.collisions_per_episode = episodes.Mean(episodes.collisions);
  s.episode_length = episodes.Mean(episodes.length_sum);
  s.policy_loss = learn.policy_loss;
  s.value_loss = learn.value_loss;
  s.entropy_option = learn.entropy_option;
  s.entropy_continuous = learn.entropy_continuous;
  s.entropy_termination = learn.entropy_termination;
  s.approx_kl = learn.approx_kl;
  s.clip_fraction = learn.clip_fraction;
  s.explained_variance = learn.explained_variance;
  s.actor_grad_norm = learn.actor_grad_norm;
  s.critic_grad_norm = learn.critic_grad_norm;
  s.lr = config.ppo.lr() * lr_scale;
  const auto end = std::chrono::steady_clock::now();
  s.seconds = std::chrono::duration<double>(end - start).count();
  s.rollout_seconds = std::chrono::duration<double>(rollout_end - start).count();
  s.learn_seconds = std::chrono::duration<double>(end - rollout_end).count();
  s.fps = static_cast<double>(T) * N * world / std::max(s.seconds, 1e-9);
  return s;
}

namespace {

// the recent-episode window as a tensor (8 numbers per episode)
torch::Tensor RecentEpisodesTensor(const std::deque<tasks::EpisodeMetrics>& recent) {
  torch::Tensor t = torch::zeros({static_cast<int64_t>(recent.size()), 8}, torch::kDouble);
  for (size_t i = 0; i < recent.size(); ++i) {
    const tasks::EpisodeMetrics& e = recent[i];
    const double row[8] = {double(e.success), double(e.invalid), double(e.collisions), e.mean_tracking_error,
                           e.final_tracking_error, e.min_clearance, double(e.length), e.episode_return};
    for (int j = 0; j < 8; ++j) t[i][j] = row[j];
  }
  return t;
}

// the payload of a format-2 checkpoint
std::string CheckpointArchiveBytes(const TrainConfig& config, const tasks::EnvSpec& spec, std::int64_t update,
                                   std::int64_t env_steps, const torch::Tensor& recent, const Ppo& ppo,
                                   const std::vector<torch::Tensor>& rank_generators = {}) {
  TensorArchive archive;
  // a data-parallel run: its world size, and the sampling generators of ranks 1.. (rank 0's is the learner's)
  if (!rank_generators.empty()) {
    archive.Put("meta/world_size", static_cast<std::int64_t>(rank_generators.size() + 1));
    for (size_t r = 0; r < rank_generators.size(); ++r) {
      archive.Put(fmt::format("meta/generator_rank{}", r + 1), rank_generators[r]);
    }
  }
  archive.Put("meta/format", std::string("rmpmarl-checkpoint"));
  archive.Put("meta/config", ToYaml(config));
  archive.Put("meta/fingerprint", SpecFingerprint(spec));
  archive.Put("meta/update", update);
  archive.Put("meta/env_steps", env_steps);
  WriteSpec(archive, spec);
  archive.Put("meta/recent_episodes", recent);
  ppo.Save(archive);
  return archive.Serialize();
}

}  // namespace

void Trainer::SaveCheckpoint(const std::string& path) const {
  const Impl& m = *impl_;
  std::vector<torch::Tensor> rank_generators;
  if (m.world > 1) {
    // every rank's generator state to every rank (rows of zeros but one, summed), rank 0 writes ranks 1..
    const torch::Tensor own = m.ppo->generator().get_state();
    torch::Tensor all = torch::zeros({m.world, own.numel()}, torch::kDouble);
    all[m.rank].copy_(own.to(torch::kDouble));
    m.collective->AllReduceSum(all);
    if (m.rank != 0) return;
    for (int r = 1; r < m.world; ++r) rank_generators.push_back(all[r].to(own.scalar_type()).contiguous());
  }
  WriteFileAtomically(path, WrapPayload(CheckpointArchiveBytes(m.config, m.spec, m.update, m.env_steps,
                                                               RecentEpisodesTensor(m.recent), *m.ppo,
                                                               rank_generators)));
}

std::uint32_t Trainer::LearnerChecksum() const {
  std::uint32_t crc = 0;
  ForEachLearnerValue(
      *impl_->ppo,
      [&](const torch::Tensor& t) {
        const torch::Tensor c = t.detach().contiguous();
        crc = control::Crc32c(c.data_ptr(), c.numel() * c.element_size(), crc);
      },
      [&](double x) { crc = control::Crc32c(&x, sizeof(x), crc); });
  return crc;
}

void Trainer::Resume(const std::string& path) {
  Impl& m = *impl_;
  const TensorArchive archive = OpenCheckpoint(path);
  try {
    const std::string fingerprint = archive.String("meta/fingerprint");
    if (fingerprint != SpecFingerprint(m.spec)) {
      throw InputError(fmt::format("checkpoint {} does not match this task's env layout:\n  checkpoint: {}\n  env:        "
                                   "{}", path, fingerprint, SpecFingerprint(m.spec)));
    }
    const TrainConfig stored = ParseTrainConfig(archive.String("meta/config"), path + " (stored config)");
    const auto a = FlattenTrainConfig(stored), b = FlattenTrainConfig(m.config);
    std::string differences;
    for (size_t i = 0; i < a.size(); ++i) {
      if (IsRunLocalKey(a[i].first) || a[i].second == b[i].second) continue;
      differences += fmt::format("\n  {}: {} in the checkpoint, {} now", a[i].first, a[i].second, b[i].second);
    }
    if (!differences.empty()) {
      throw InputError(fmt::format("checkpoint {} was written by a run with a different configuration (resuming "
                                   "would not continue it):{}", path, differences));
    }
    if (stored.torch_threads != m.config.torch_threads) {
      fmt::print(stderr, "rmpmarl: warning: torch_threads {} differs from the checkpoint's {}; results may differ in "
                         "the last bits\n", m.config.torch_threads, stored.torch_threads);
    }
    const std::int64_t stored_world = archive.Has("meta/world_size") ? archive.Int("meta/world_size") : 1;
    if (stored_world != m.world) {
      throw InputError(fmt::format("checkpoint {} was written by a run of {} rank{}; this run has {}: resume with "
                                   "--nproc {} (or that many ranks), or start a new run", path, stored_world,
                                   stored_world == 1 ? "" : "s", m.world, stored_world));
    }
    m.ppo->Load(archive);
    if (m.rank > 0) {
      const torch::Tensor current = m.ppo->generator().get_state();
      m.ppo->generator().set_state(archive.Tensor(fmt::format("meta/generator_rank{}", m.rank),
                                                  current.scalar_type(), current.sizes()));
    }
    const torch::Tensor recent = archive.Tensor("meta/recent_episodes");
    if (recent.scalar_type() != torch::kDouble || recent.dim() != 2 || recent.size(1) != 8) {
      throw InputError(fmt::format("checkpoint {}: meta/recent_episodes: expected a double tensor of N x 8", path));
    }
    m.recent.clear();
    // the window of finished episodes is rank 0's; the other ranks start theirs anew
    const torch::Tensor r = recent.contiguous();
    for (int64_t i = 0; m.rank == 0 && i < r.size(0); ++i) {
      const double* row = r.data_ptr<double>() + i * 8;
      tasks::EpisodeMetrics e;
      e.success = row[0] != 0.0;
      e.invalid = row[1] != 0.0;
      e.collisions = static_cast<int>(row[2]);
      e.mean_tracking_error = row[3];
      e.final_tracking_error = row[4];
      e.min_clearance = row[5];
      e.length = static_cast<int>(row[6]);
      e.episode_return = row[7];
      m.recent.push_back(e);
    }
    m.update = static_cast<int>(archive.Int("meta/update"));
    m.env_steps = archive.Int("meta/env_steps");
  } catch (const c10::Error& e) {
    throw InputError(fmt::format("checkpoint {}: cannot restore the training state: {}", path,
                                 e.what_without_backtrace()));
  }
  m.envs_reset_at = -1;  // the next update seeds and resets the envs for its segment
  m.env_built_for = -1;
  if (m.world > 1) {
    // every rank must have read the same checkpoint (a copy per machine may be stale): rank 0's learner is the run's
    torch::Tensor sum = torch::tensor({static_cast<std::int64_t>(LearnerChecksum())}, torch::kLong);
    const std::int64_t own = sum.item<std::int64_t>();
    m.collective->Broadcast(sum);
    if (sum.item<std::int64_t>() != own) {
      throw InputError(fmt::format("rank {} of {}: checkpoint {} holds another learner than rank 0's (checksum {:08x} "
                                   "against {:08x}): every rank must resume from the same file", m.rank, m.world, path,
                                   own, sum.item<std::int64_t>()));
    }
  }
}

namespace {

// the controller file of a learner: its actor, the task it runs on (the manipulator tasks) and its provenance.
control::PolicyFile MakePolicyFile(Ppo& ppo, const TrainConfig& config, int update, std::int64_t env_steps) {
  control::PolicyFile file;
  file.weights = ppo.Export();
  const std::vector<std::string> manipulator = tasks::TaskNames();
  if (std::find(manipulator.begin(), manipulator.end(), config.task.name) != manipulator.end()) {
    const std::filesystem::path task_file =
        config.task.config.empty() ? tasks::TaskConfigPath(config.task.name) : std::filesystem::path(config.task.config);
    file.task_yaml = ControllerTaskYaml(task_file, config.task.overrides_yaml, config.task.interface);
  }
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "name" << YAML::Value << config.name;
  out << YAML::Key << "algorithm" << YAML::Value << config.algorithm;
  out << YAML::Key << "seed" << YAML::Value << config.seed;
  out << YAML::Key << "updates" << YAML::Value << update;
  out << YAML::Key << "env_steps" << YAML::Value << env_steps;
  const YAML::Node training = YAML::Load(TrainingConfigProvenance(ToYaml(config)));
  out << YAML::Key << "training_config" << YAML::Value << training;
  out << YAML::EndMap;
  file.provenance_yaml = out.c_str();
  return file;
}

}  // namespace

void Trainer::ExportPolicy(const std::string& path) const {
  control::SavePolicyFile(MakePolicyFile(*impl_->ppo, impl_->config, impl_->update, impl_->env_steps), path);
}

std::vector<double> Trainer::StateVector() const {
  Ppo& ppo = *impl_->ppo;
  std::vector<double> out;
  auto append = [&](const torch::Tensor& t) {
    const torch::Tensor d = t.detach().to(torch::kDouble).contiguous().reshape({-1});
    out.insert(out.end(), d.data_ptr<double>(), d.data_ptr<double>() + d.numel());
  };
  ForEachLearnerValue(ppo, append, [&](double x) { out.push_back(x); });
  append(ppo.generator().get_state());
  out.push_back(impl_->update);
  out.push_back(static_cast<double>(impl_->env_steps));
  return out;
}

TrainConfig ReadCheckpointConfig(const std::string& path) {
  return ParseTrainConfig(OpenCheckpoint(path).String("meta/config"), path + " (stored config)");
}

void UpgradeCheckpoint(const std::string& path, const std::string& out_path) {
  CheckpointPayload payload = ReadCheckpointPayload(path);
  if (payload.version == kCheckpointVersion) {
    throw InputError(fmt::format("checkpoint {}: already format {}", path, kCheckpointVersion));
  }
  torch::serialize::InputArchive archive;
  std::string bytes;
  try {
    std::istringstream stream(payload.bytes);
    archive.load_from(stream);
    auto string = [&](const std::string& key) {
      c10::IValue v;
      archive.read(key, v);
      return v.toStringRef();
    };
    auto integer = [&](const std::string& key) {
      c10::IValue v;
      archive.read(key, v);
      return v.toInt();
    };
    const TrainConfig config = ParseTrainConfig(string("meta/config"), path + " (stored config)");
    tasks::EnvSpec spec;
    spec.task = string("spec/task");
    spec.num_agents = static_cast<int>(integer("spec/num_agents"));
    spec.local_obs_dim = static_cast<int>(integer("spec/local_obs_dim"));
    spec.global_state_dim = static_cast<int>(integer("spec/global_state_dim"));
    spec.action.num_options = static_cast<int>(integer("spec/num_options"));
    spec.action.num_continuous = static_cast<int>(integer("spec/num_continuous"));
    spec.action.has_termination = integer("spec/has_termination") != 0;
    spec.reward_terms.assign(static_cast<int>(integer("spec/reward_terms")), "");
    torch::Tensor low, high, recent;
    archive.read("spec/low", low);
    archive.read("spec/high", high);
    spec.action.low.assign(low.data_ptr<float>(), low.data_ptr<float>() + low.numel());
    spec.action.high.assign(high.data_ptr<float>(), high.data_ptr<float>() + high.numel());
    archive.read("meta/recent_episodes", recent);
    Ppo ppo(spec, config.network, config.ppo, config.seed);
    ppo.Load(archive);
    bytes = CheckpointArchiveBytes(config, spec, integer("meta/update"), integer("meta/env_steps"), recent, ppo);
  } catch (const c10::Error& e) {
    throw InputError(fmt::format("checkpoint {}: cannot read its format-1 archive: {}", path,
                                 e.what_without_backtrace()));
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(fmt::format("checkpoint {}: cannot read its format-1 archive: {}", path, e.what()));
  }
  WriteFileAtomically(out_path, WrapPayload(bytes));
}

void ExportCheckpointPolicy(const std::string& checkpoint_path, const std::string& policy_path) {
  LoadedCheckpoint loaded = LoadLearner(checkpoint_path);
  control::SavePolicyFile(MakePolicyFile(*loaded.ppo, loaded.config, loaded.update, loaded.env_steps), policy_path);
}

// ------------------------------------------------------------------------------------------------- RunTraining
namespace internal {

std::string SpecFingerprint(const tasks::EnvSpec& s) {
  return fmt::format("task={} agents={} local_obs={} global_state={} options={} continuous={} termination={} "
                     "reward_terms={}", s.task, s.num_agents, s.local_obs_dim, s.global_state_dim,
                     s.action.num_options, s.action.num_continuous, s.action.has_termination, s.reward_terms.size());
}

std::string ReadFile(const std::string& path, const char* what) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(fmt::format("{} {}: cannot open it", what, path));
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

LoadedCheckpoint LoadLearner(const std::string& path) {
  const std::size_t file_bytes = std::filesystem::file_size(path);
  const TensorArchive archive = OpenCheckpoint(path);
  LoadedCheckpoint c;
  try {
    c.config = ParseTrainConfig(archive.String("meta/config"), path + " (stored config)");
    c.spec = ReadSpec(archive);
    CheckNetworkFitsArchive(c.config, c.spec, file_bytes, path);
    c.ppo = std::make_unique<Ppo>(c.spec, c.config.network, c.config.ppo, c.config.seed);
    c.ppo->Load(archive);
    c.update = static_cast<int>(archive.Int("meta/update"));
    c.env_steps = archive.Int("meta/env_steps");
  } catch (const c10::Error& e) {
    throw InputError(fmt::format("checkpoint {}: cannot restore the learner: {}", path, e.what_without_backtrace()));
  }
  return c;
}

}  // namespace internal

}  // namespace rmpmarl::rl
