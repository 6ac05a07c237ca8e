#pragma once
/// Real-time evaluation of a trained actor without libtorch: an Eigen / AVX2 forward pass that evaluates the per-joint
/// agents (shared parameters) at batch 1 without allocating. The weights come from a controller file
/// (rl/policy_file.h).
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rmpmarl/control/action_spec.h"

namespace rmpmarl::control {

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
  /// Act for the agents whose `read[a]` is not 0 (num_agents flags, e.g. StepOutput::next_action_read); the other
  /// agents' actions are left as they are, and with none to read the network does not run. The actions equal Act's
  /// bit for bit: the AVX2 kernel computes each agent's row alone, the portable path evaluates the whole batch.
  /// Allocates nothing. Returns how many agents' actions were written.
  int ActWhere(const float* obs, int num_agents, const float* read, float* actions);
  /// forces the portable path (for tests of both kernels).
  void DisableAvx2();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace rmpmarl::control
