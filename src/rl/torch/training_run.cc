// Training and evaluation runs: the training loop with its log, CSV and TensorBoard output, checkpoint cadence and
// resume; evaluating a policy or checkpoint on held-out episodes.
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
#include <limits>
#include <sstream>

#include "rmpmarl/common/error.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/control/policy_runtime.h"
#include "rmpmarl/tasks/task_config.h"
#include "rmpmarl/rl/torch/ppo.h"
#include "rmpmarl/rl/torch/tensor_archive.h"
#include "rmpmarl/rl/torch/tensorboard.h"

namespace rmpmarl::rl {

using namespace internal;


namespace {

const char* kCsvHeader =
    "update,env_steps,episodes,window_episodes,mean_return,success_rate,tracking_error_mm,final_tracking_error_mm,min_clearance_m,"
    "collisions_per_episode,episode_length,policy_loss,value_loss,entropy_option,entropy_continuous,"
    "entropy_termination,approx_kl,clip_fraction,explained_variance,actor_grad_norm,critic_grad_norm,lr,rollout_seconds,learn_seconds,fps,seconds";

std::vector<std::pair<std::string, double>> Columns(const UpdateSummary& s) {
  return {{"episodes", s.episodes},
          {"window_episodes", s.window_episodes},
          {"mean_return", s.mean_return},
          {"success_rate", s.success_rate},
          {"tracking_error_mm", s.tracking_error_mm},
          {"final_tracking_error_mm", s.final_tracking_error_mm},
          {"min_clearance_m", s.min_clearance_m},
          {"collisions_per_episode", s.collisions_per_episode},
          {"episode_length", s.episode_length},
          {"policy_loss", s.policy_loss},
          {"value_loss", s.value_loss},
          {"entropy_option", s.entropy_option},
          {"entropy_continuous", s.entropy_continuous},
          {"entropy_termination", s.entropy_termination},
          {"approx_kl", s.approx_kl},
          {"clip_fraction", s.clip_fraction},
          {"explained_variance", s.explained_variance},
          {"actor_grad_norm", s.actor_grad_norm},
          {"critic_grad_norm", s.critic_grad_norm},
          {"lr", s.lr},
          {"rollout_seconds", s.rollout_seconds},
          {"learn_seconds", s.learn_seconds},
          {"fps", s.fps},
          {"seconds", s.seconds}};
}

// keeps the CSV rows of updates <= `update` (a resumed run rewrites what came after its checkpoint).
void TruncateCsv(const std::string& path, int update) {
  std::ifstream in(path);
  if (!in) return;
  std::string line, kept;
  bool header = true;
  while (std::getline(in, line)) {
    if (header || std::atoi(line.c_str()) <= update) kept += line + "\n";
    header = false;
  }
  in.close();
  std::ofstream(path, std::ios::trunc) << kept;
}

}  // namespace

UpdateSummary RunTraining(const TrainConfig& config, const tasks::EnvFactory& factory, const RunOptions& options) {
  namespace fs = std::filesystem;
  // a data-parallel run: every rank trains, rank 0 alone prints and writes (its checkpoints hold every rank's state)
  const int rank = options.collective != nullptr ? options.collective->rank() : 0;
  const int world = options.collective != nullptr ? options.collective->world_size() : 1;
  const bool checkpoints = !config.output_dir.empty();
  const bool files = checkpoints && rank == 0;
  const bool progress = config.progress && rank == 0;
  const std::string out = config.output_dir;
  const std::string checkpoint = out + "/checkpoint.ckpt";
  if (options.resume && !checkpoints) throw InputError("--resume needs output_dir in the training config");
  if (options.resume && !fs::exists(checkpoint)) {
    throw InputError(fmt::format("--resume: no checkpoint at {} (train without --resume to start)", checkpoint));
  }
  Trainer trainer(config, factory, options.collective);
  if (options.resume) trainer.Resume(checkpoint);
  UpdateSummary last;
  if (trainer.finished()) {
    if (progress) {
      fmt::print("{}: training already complete ({} of {} updates)\n", config.name, trainer.update(),
                 config.total_updates);
    }
    return last;
  }
  std::ofstream csv;
  std::unique_ptr<TensorBoardWriter> tb;
  if (files) {
    fs::create_directories(out);
    std::ofstream(out + "/config.yaml", std::ios::trunc) << ToYaml(config);
    if (config.write_csv) {
      const std::string path = out + "/metrics.csv";
      if (options.resume && fs::exists(path)) {
        TruncateCsv(path, trainer.update());
        csv.open(path, std::ios::app);
      } else {
        csv.open(path, std::ios::trunc);
        csv << kCsvHeader << "\n";
      }
      if (!csv) throw InputError(fmt::format("cannot write {}", path));
    }
    if (config.write_tensorboard) tb = std::make_unique<TensorBoardWriter>(out + "/tb");
  }
  const bool tty = isatty(fileno(stderr));
  const int first = trainer.update();
  const auto start = std::chrono::steady_clock::now();
  if (progress) {
    fmt::print("{}: task {} (agents {}, local obs {}, global state {}), {}{} envs × {} steps per update, updates {}..{}\n",
               config.name, trainer.spec().task, trainer.spec().num_agents, trainer.spec().local_obs_dim,
               trainer.spec().global_state_dim, world > 1 ? fmt::format("{} ranks × ", world) : "", config.num_envs,
               config.ppo.rollout_steps(), first + 1, config.total_updates);
    if (config.ppo.bf16_autocast() && !CpuHasFastBf16()) {
      fmt::print("{}: bf16_autocast stays off on this CPU (no AMX-BF16 or AVX512-BF16: fp32 is faster here)\n",
                 config.name);
    }
    std::fflush(stdout);
  }
  while (!trainer.finished()) {
    last = trainer.RunUpdate();
    const int u = last.update;
    if (csv.is_open()) {
      csv << u << "," << last.env_steps;
      for (const auto& [name, value] : Columns(last)) csv << "," << fmt::format("{}", value);
      csv << "\n";
      csv.flush();
    }
    if (tb) {
      std::vector<std::pair<std::string, float>> scalars;
      for (const auto& [name, value] : Columns(last)) {
        if (std::isfinite(value)) scalars.emplace_back("train/" + name, static_cast<float>(value));
      }
      tb->Write(last.env_steps, scalars);
    }
    // the snapshot first: a process killed between the two resumes from the previous checkpoint and re-exports it
    if (files && std::find(config.snapshot_updates.begin(), config.snapshot_updates.end(), u) !=
                     config.snapshot_updates.end()) {
      trainer.ExportPolicy(fmt::format("{}/policy-u{}.rmpp", out, u));
    }
    if (checkpoints && (u % config.checkpoint_every == 0 || trainer.finished())) trainer.SaveCheckpoint(checkpoint);
    if (options.on_update) options.on_update(last);
    if (progress) {
      const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const double eta = elapsed / (u - first) * (config.total_updates - u);
      if (tty) fmt::print(stderr, "\r\033[K");
      fmt::print("[{:>{}}/{}] return {} | success {} | track {} mm | entropy opt {} cont {} term {} | kl {} | "
                 "{:.0f} fps ({:.0f}% learning)\n", u, std::to_string(config.total_updates).size(), config.total_updates,
                 Num(last.mean_return), Num(100.0 * last.success_rate, "{:.1f}%"), Num(last.tracking_error_mm, "{:.1f}"),
                 Num(last.entropy_option, "{:.2f}"), Num(last.entropy_continuous, "{:.2f}"),
                 Num(last.entropy_termination, "{:.2f}"), Num(last.approx_kl, "{:.4f}"), last.fps,
                 100.0 * last.learn_seconds / std::max(last.seconds, 1e-9));
      std::fflush(stdout);
      if (tty) {
        const int width = 30, done = width * u / config.total_updates;
        fmt::print(stderr, "[{}{}] {}/{} updates  elapsed {}  ETA {}", std::string(done, '#'),
                   std::string(width - done, '.'), u, config.total_updates, FormatDuration(elapsed),
                   FormatDuration(eta));
        std::fflush(stderr);
      }
    }
  }
  if (progress && tty) fmt::print(stderr, "\r\033[K");
  if (checkpoints) trainer.SaveCheckpoint(out + "/final.ckpt");
  if (world > 1) {
    // every rank holds the same learner: the check a user (and the tests) can read off the log
    fmt::print("{}: rank {} of {}: learner checksum {:08x} after {} updates\n", config.name, rank, world,
               trainer.LearnerChecksum(), trainer.update());
    std::fflush(stdout);
  }
  if (files) {
    trainer.ExportPolicy(out + "/policy.rmpp");
    if (progress) {
      fmt::print("{}: wrote {}/checkpoint.ckpt, final.ckpt, policy.rmpp{}{}\n", config.name, out,
                 config.write_csv ? ", metrics.csv" : "", tb ? ", tb/" : "");
    }
  }
  return last;
}

// ------------------------------------------------------------------------------------------------- Evaluate
EvalResult Evaluate(const std::string& policy_path, const tasks::EnvFactory& factory, const EvalOptions& options) {
  if (options.episodes < 1) throw InputError(fmt::format("episodes: expected >= 1, got {}", options.episodes));
  const std::string head = ReadFile(policy_path, "policy").substr(0, 8);
  const bool is_checkpoint = head == std::string(kCheckpointMagic, 8);
  const int N = std::max(1, std::min(options.num_envs, options.episodes));
  VecEnv env(factory, VecEnvOptions{N, options.seed, options.env_threads});
  const tasks::EnvSpec& spec = env.spec();
  const int A = spec.num_agents, d = spec.local_obs_dim, S = spec.global_state_dim, as = spec.action.size();

  std::function<void(const Batch&, float*)> act;
  LoadedCheckpoint loaded;
  std::unique_ptr<control::PolicyRuntime> runtime;
  if (is_checkpoint) {
    loaded = LoadLearner(policy_path);
    if (SpecFingerprint(loaded.spec) != SpecFingerprint(spec) &&
        (loaded.spec.local_obs_dim != d || loaded.spec.action.size() != as)) {
      throw InputError(fmt::format("policy {} does not fit this task: trained on {}, the env is {}", policy_path,
                                   SpecFingerprint(loaded.spec), SpecFingerprint(spec)));
    }
    SetTorchThreads(loaded.config.torch_threads);
    Ppo* ppo = loaded.ppo.get();
    const bool deterministic = !options.stochastic;
    act = [=](const Batch& b, float* actions) {
      const torch::Tensor local = torch::from_blob(const_cast<float*>(b.local_obs.data()), {N * A, d}, torch::kFloat);
      torch::Tensor global = torch::from_blob(const_cast<float*>(b.global_state.data()), {N, S}, torch::kFloat);
      if (ppo->spec().global_state_dim != S) global = torch::zeros({N, ppo->spec().global_state_dim});
      const ActResult r = ppo->Act(local, global, false, deterministic);
      const torch::Tensor a = r.sampled.actions.contiguous();
      std::memcpy(actions, a.data_ptr<float>(), sizeof(float) * N * A * as);
    };
  } else {
    if (options.stochastic) throw InputError("stochastic evaluation needs a checkpoint (.ckpt), not a policy file");
    const control::PolicyWeights weights = control::LoadPolicyFile(policy_path).weights;
    if (weights.obs_dim != d || weights.action_size() != as) {
      throw InputError(fmt::format("policy {} does not fit task {}: it takes obs {} and gives {} action floats, the "
                                   "env has obs {} and actions of {}", policy_path, spec.task, weights.obs_dim,
                                   weights.action_size(), d, as));
    }
    runtime = std::make_unique<control::PolicyRuntime>(weights, A);
    control::PolicyRuntime* rt = runtime.get();
    act = [=](const Batch& b, float* actions) {
      for (int k = 0; k < N; ++k) rt->Act(b.local_obs.data() + static_cast<size_t>(k) * A * d, A, actions + k * A * as);
    };
  }

  const std::vector<int> quota = EvaluationShares(options.episodes, N);
  std::vector<int> done(N, 0);
  std::vector<float> actions(static_cast<size_t>(N) * A * as);
  std::vector<tasks::EpisodeMetrics> ended;
  env.Reset();
  const long max_steps = std::max(spec.max_episode_steps, 1000) * static_cast<long>(quota[0] + 1) * 4;
  for (long step = 0; static_cast<int>(ended.size()) < options.episodes; ++step) {
    if (step > max_steps) {
      throw InputError(fmt::format("evaluation: episodes did not end within {} steps per env", max_steps));
    }
    act(env.batch(), actions.data());
    env.Step(actions.data());
    const Batch& b = env.batch();
    for (int k = 0; k < N; ++k) {
      if (!(b.terminated[k] || b.truncated[k]) || done[k] >= quota[k]) continue;
      ++done[k];
      ended.push_back(b.metrics[k]);
    }
  }
  return SummarizeEpisodes(ended);
}

std::vector<int> EvaluationShares(int episodes, int num_envs) {
  if (episodes < 1 || num_envs < 1) {
    throw InputError(fmt::format("EvaluationShares: expected episodes >= 1 and num_envs >= 1, got {} and {}", episodes,
                                 num_envs));
  }
  std::vector<int> share(num_envs, episodes / num_envs);
  for (int k = 0; k < episodes % num_envs; ++k) ++share[k];
  return share;
}

EvalResult SummarizeEpisodes(const std::vector<tasks::EpisodeMetrics>& episodes) {
  if (episodes.empty()) throw InputError("SummarizeEpisodes: expected at least 1 episode, got none");
  EpisodeStats stats;
  for (const tasks::EpisodeMetrics& m : episodes) stats.Add(m);
  EvalResult r;
  r.episodes = stats.episodes;
  r.success_rate = static_cast<double>(stats.successes) / stats.episodes;
  r.tracking_error_mean_mm = stats.track_sum / stats.episodes;
  double var = 0.0;
  for (const tasks::EpisodeMetrics& m : episodes) {
    const double t = 1000.0 * m.mean_tracking_error;
    var += (t - r.tracking_error_mean_mm) * (t - r.tracking_error_mean_mm);
  }
  r.tracking_error_std_mm = std::sqrt(var / stats.episodes);
  r.final_tracking_error_mean_mm = stats.final_track_sum / stats.episodes;
  r.settled_tracking_error_mean_mm = stats.settled_count > 0 ? stats.settled_sum / stats.settled_count : kNaN;
  r.min_clearance_mean_m = stats.clearance_count > 0 ? stats.clearance_sum / stats.clearance_count : kNaN;
  r.collisions_per_episode = static_cast<double>(stats.collisions) / stats.episodes;
  r.collision_free_rate = static_cast<double>(stats.collision_free) / stats.episodes;
  r.mean_return = stats.return_sum / stats.episodes;
  r.mean_length = stats.length_sum / stats.episodes;
  return r;
}

}  // namespace rmpmarl::rl
