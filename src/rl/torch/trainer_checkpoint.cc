// The trainer's checkpoints: the file format (magic, version, CRC, a TensorArchive payload), saving, resuming and
// upgrading them, and exporting a policy file from one.
#include "rmpmarl/rl/torch/trainer.h"

#include "trainer_internal.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <torch/serialize.h>
#include <torch/types.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
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
