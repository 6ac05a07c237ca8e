#pragma once
/// Real-time evaluation of a trained actor without libtorch: the exported weights file (format below) and an Eigen /
/// AVX2 forward pass that evaluates the per-joint agents (shared parameters) at batch 1 without allocating.
///
/// Policy file, format version 1 (all integers uint32 little-endian, all reals float32 little-endian):
///   magic "RMPMPOL\0" (8 bytes) · version · obs_dim · num_options · num_continuous · has_termination ·
///   activation (0 relu, 1 tanh) · num_hidden L · hidden sizes[L] ·
///   obs_clip (float; 0: no clipping) · obs_mean[obs_dim] · obs_inv_std[obs_dim] ·
///   for each hidden layer then the head: weight[out × in] (row-major, out rows) · bias[out] ·
///   log_std[num_continuous] · low[num_continuous] · high[num_continuous] ·
///   crc32c (uint32) of every preceding byte.
/// The head's outputs are [option logits (num_options) | Gaussian means (num_continuous) | termination logit (1 if
/// has_termination)], sized from the ActionSpec. The normalised observation is clamp((o − mean) · inv_std, ±clip).
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/rl/env.h"

namespace rmpmarl::rl {

/// CRC-32C (Castagnoli) of `size` bytes, continuing from `crc` (0 to start).
std::uint32_t Crc32c(const void* data, std::size_t size, std::uint32_t crc = 0);

/// One affine layer y = W x + b.
struct DenseLayer {
  Eigen::MatrixXf weight;  ///< out × in
  Eigen::VectorXf bias;    ///< out
};

/// An exported actor: everything the runtime needs, as plain arrays.
struct PolicyWeights {
  int obs_dim = 0;
  int num_options = 0;
  int num_continuous = 0;
  bool has_termination = false;
  int activation = 0;               ///< 0 relu, 1 tanh (rl::Activation)
  std::vector<DenseLayer> hidden;   ///< trunk, each followed by the activation
  DenseLayer head;                  ///< linear output layer: [logits | means | termination logit]
  float obs_clip = 0.0f;            ///< 0: no clipping
  Eigen::VectorXf obs_mean;         ///< obs_dim (zeros: no normalisation)
  Eigen::VectorXf obs_inv_std;      ///< obs_dim (ones: no normalisation)
  Eigen::VectorXf log_std;          ///< num_continuous
  Eigen::VectorXf low, high;        ///< num_continuous: the action bounds the env clips to

  /// outputs of the head: num_options + num_continuous + has_termination.
  int head_size() const { return num_options + num_continuous + (has_termination ? 1 : 0); }
  /// floats of one flat action in the ActionSpec layout.
  int action_size() const { return (num_options > 0 ? 1 : 0) + num_continuous + (has_termination ? 1 : 0); }
  /// throws InputError when the sizes are inconsistent.
  void Validate() const;
};

/// writes `weights` to `path` atomically (temporary file + rename). Throws InputError on I/O failure.
void SavePolicyFile(const PolicyWeights& weights, const std::string& path);
/// reads a policy file; a wrong magic/version, a truncated file or a checksum mismatch throws InputError naming it.
PolicyWeights LoadPolicyFile(const std::string& path);

/// the task overrides a shipped policy runs with (its basic-layer variant): the `task_overrides` key (a YAML mapping
/// in flow style, as a training config's task.overrides) of the YAML beside the policy file (`<stem>.yaml`, written by
/// scripts/ship-policies). "" when there is no such file or key; throws InputError naming the file when it is not a
/// YAML mapping or the key is not a string.
std::string LoadPolicyTaskOverrides(const std::string& policy_path);

/// Evaluates the shared-parameter actor for up to `max_agents` agents at once (one row of observations each).
/// Evaluate allocates nothing; one instance per thread.
class PolicyRuntime {
 public:
  explicit PolicyRuntime(const PolicyWeights& weights, int max_agents = 16);
  ~PolicyRuntime();
  PolicyRuntime(PolicyRuntime&&) noexcept;
  PolicyRuntime& operator=(PolicyRuntime&&) noexcept;

  int obs_dim() const;
  int head_size() const;
  int action_size() const;
  int max_agents() const;
  /// true when the AVX2/FMA kernel is in use (else the portable Eigen path).
  bool uses_avx2() const;

  /// head outputs for `num_agents` observations (num_agents × obs_dim, row-major) into
  /// `head` (num_agents × head_size, row-major). \pre num_agents <= max_agents.
  void EvaluateHead(const float* obs, int num_agents, float* head);
  /// deterministic actions (option = argmax logits, continuous = clamp(mean, low, high), terminate = logit > 0) in
  /// the flat ActionSpec layout (num_agents × action_size, row-major).
  void Act(const float* obs, int num_agents, float* actions);
  /// forces the portable path (for tests of both kernels).
  void DisableAvx2();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rmpmarl::rl
