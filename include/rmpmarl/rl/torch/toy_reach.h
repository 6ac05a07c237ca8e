#pragma once
/// "toy-reach": a tiny multi-agent task for developing and testing the learners (and for running the CLI before
/// the manipulator tasks exist). Agent a moves a point x_a on a line towards its own target g_a.
///   - interface "options": the hybrid action [option, speed, terminate] with options {toward, hold, away}, timed
///     like the manipulator env's option machine: when the agent is idle (episode start, or its option ended) the
///     action's option starts (option_started = 1); the running option moves x by ±step·clamp(speed, 0, 1)
///     toward/away from g (never past it); terminate >= 0.5 ends it after the step. Local observation
///     [x, g − x, one-hot running option (zeros when idle)].
///   - interface "direct": one continuous velocity v ∈ [−1, 1], x += step·v. Local observation [x, g − x].
/// Global state [x_1..x_A, g_1..g_A]. Reward −Σ_a |g_a − x_a| / A per step; leaving |x| <= 1.5 terminates with −1.
/// Success: every |g_a − x_a| < tolerance at the end. Tracking error reported in mm (1 unit = 1 m).
#include <random>
#include <vector>

#include "rmpmarl/tasks/env.h"

namespace rmpmarl::rl {

struct ToyReachOptions {
  int agents = 1;
  bool options = true;  ///< hybrid option interface (else direct velocity)
  int horizon = 40;
  double step = 0.1;
  double tolerance = 0.05;
};

class ToyReachEnv : public tasks::Env {
 public:
  explicit ToyReachEnv(const ToyReachOptions& options);
  const tasks::EnvSpec& spec() const override { return spec_; }
  void Reset(std::mt19937_64& rng, const tasks::StepOutput& out) override;
  void Step(const float* actions, std::mt19937_64& rng, const tasks::StepOutput& out) override;

 private:
  void Write(const tasks::StepOutput& out) const;
  ToyReachOptions options_;
  tasks::EnvSpec spec_;
  std::vector<double> x_, g_;
  std::vector<int> option_;  // running option per agent (-1: none)
  int steps_ = 0;
  double error_sum_ = 0.0, return_ = 0.0;
};

}  // namespace rmpmarl::rl
