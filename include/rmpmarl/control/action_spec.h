#pragma once
/// The layout of one agent's action (shared by the agents, the policy runtime and the RL environments).
#include <string>
#include <vector>

namespace rmpmarl::control {

/// Layout of one agent's action as a flat float vector: [option?, continuous..., terminate?].
///  - option: a categorical choice in {0, …, num_options − 1}, sent as a float holding the index (absent when
///    num_options == 0);
///  - continuous: num_continuous raw values; the env clips each to [low, high] (documented per task);
///  - terminate: a Bernoulli flag (≥ 0.5 means terminate the running option), present when has_termination.
struct ActionSpec {
  int num_options = 0;
  std::vector<std::string> option_names;   ///< size num_options
  int num_continuous = 0;
  std::vector<std::string> continuous_names;  ///< size num_continuous
  std::vector<float> low;                  ///< size num_continuous
  std::vector<float> high;                 ///< size num_continuous
  bool has_termination = false;

  /// floats per agent action.
  int size() const { return (num_options > 0 ? 1 : 0) + num_continuous + (has_termination ? 1 : 0); }
  /// offset of the first continuous value in the flat action.
  int continuous_offset() const { return num_options > 0 ? 1 : 0; }
  /// offset of the termination flag (valid when has_termination).
  int termination_offset() const { return continuous_offset() + num_continuous; }
};

}  // namespace rmpmarl::control
