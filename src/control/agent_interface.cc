// Action layouts, the option state machine, observation/state layouts.
#include "rmpmarl/control/agent_interface.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "rmpmarl/common/error.h"

namespace rmpmarl::control {

int NumAgents(InterfaceMode mode, int nq) { return mode == InterfaceMode::kDirect ? 1 : nq; }

ActionSpec MakeActionSpec(const AgentConfig& config, int nq) {
  ActionSpec a;
  switch (config.interface) {
    case InterfaceMode::kPerJointRmp:
      a.num_options = kNumRmpOptions;
      a.option_names = {"target", "collision", "target_then_collision"};
      a.num_continuous = RmpActionLayout::kNumContinuous;
      a.continuous_names = {"target_accel_scale", "target_metric_scale", "collision_accel_scale",
                            "collision_metric_scale"};
      a.has_termination = config.options.termination == OptionTermination::kLearned;
      break;
    case InterfaceMode::kDirect:
      a.num_continuous = nq;
      for (int i = 0; i < nq; ++i) a.continuous_names.push_back(fmt::format("dq{}", i));
      break;
    case InterfaceMode::kPerJointDirect:
      a.num_continuous = 1;
      a.continuous_names = {"dq"};
      break;
  }
  a.low.assign(a.num_continuous, -1.0f);
  a.high.assign(a.num_continuous, 1.0f);
  return a;
}

double GainScale(double u, double gain_range) { return std::exp(std::clamp(u, -1.0, 1.0) * std::log(gain_range)); }

int DecodeOptionIndex(float value, int num_options) {
  if (!std::isfinite(value)) return -1;
  const float r = std::round(value);
  if (std::abs(value - r) > 1e-3f || r < 0.0f || r >= static_cast<float>(num_options)) return -1;
  return static_cast<int>(r);
}

// --------------------------------------------------------------------------------------------------- options

OptionMachine::OptionMachine(OptionTermination termination, int horizon) : termination_(termination), horizon_(horizon) {
  RMPMARL_ASSERT(horizon >= 1, "OptionMachine: horizon must be >= 1");
}

void OptionMachine::Reset() {
  option_ = -1;
  phase_b_ = false;
  not_applicable_ = false;
  age_ = 0;
}

OptionSelection OptionMachine::Begin(int chosen, bool warning) {
  OptionSelection s;
  if (option_ < 0) {
    RMPMARL_ASSERT(chosen >= 0 && chosen < kNumRmpOptions, "OptionMachine::Begin: option index out of range");
    s.started = true;
    option_ = chosen;
    age_ = 0;
    phase_b_ = chosen == static_cast<int>(RmpOption::kTargetThenCollision) && warning;
    not_applicable_ = chosen == static_cast<int>(RmpOption::kCollision) && !warning;
  }
  switch (static_cast<RmpOption>(option_)) {
    case RmpOption::kTarget: s.use_target = true; break;
    case RmpOption::kCollision:
      s.use_collision = !not_applicable_;
      s.use_target = not_applicable_;
      break;
    case RmpOption::kTargetThenCollision:
      s.use_collision = phase_b_;
      s.use_target = !phase_b_;
      break;
  }
  return s;
}

bool OptionMachine::End(bool terminate_flag, bool warning_next) {
  RMPMARL_ASSERT(option_ >= 0, "OptionMachine::End without a running option");
  ++age_;
  bool end = termination_ == OptionTermination::kFixed ? age_ >= horizon_ : terminate_flag;
  switch (static_cast<RmpOption>(option_)) {
    case RmpOption::kTarget: break;
    case RmpOption::kCollision: end = end || not_applicable_ || !warning_next; break;
    case RmpOption::kTargetThenCollision:
      if (!phase_b_) {
        phase_b_ = warning_next;
      } else if (!warning_next) {
        end = true;
      }
      break;
  }
  if (end) Reset();
  return end;
}

// ------------------------------------------------------------------------------------------------- layouts

void WriteLookaheadBlock(double clearance, double time, double speed, const ObservationConfig& observation,
                         float* block) {
  const bool none = !std::isfinite(clearance);
  block[LocalObs::kLookaheadClearance] =
      none ? 2.0f : static_cast<float>(std::clamp(clearance / observation.length_scale, -1.0, 2.0));
  block[LocalObs::kLookaheadTime] = none ? 1.0f : static_cast<float>(time / observation.lookahead);
  block[LocalObs::kLookaheadSpeed] = none ? 0.0f : static_cast<float>(speed / observation.speed_scale);
}

std::vector<std::string> PerJointObservationNames(InterfaceMode mode, bool lookahead) {
  std::vector<std::string> n = {
      "ee_to_target_x", "ee_to_target_y", "ee_to_target_z", "ee_target_log_distance",
      "ee_rel_velocity_x", "ee_rel_velocity_y", "ee_rel_velocity_z",
      "lever_x", "lever_y", "lever_z",
      "axis_x", "axis_y", "axis_z",
      "ee_jacobian_x", "ee_jacobian_y", "ee_jacobian_z",
      "warning", "warning_direction_x", "warning_direction_y", "warning_direction_z",
      "warning_distance", "warning_closing_speed",
      "witness_lever_x", "witness_lever_y", "witness_lever_z",
      "warning_distance_gradient", "warning_is_self",
      "q", "sin_q", "cos_q", "qd", "joint_index", "progress"};
  RMPMARL_ASSERT(static_cast<int>(n.size()) == LocalObs::kBaseSize, "local observation names out of sync");
  if (mode == InterfaceMode::kPerJointRmp) {
    for (const char* s : {"option_target", "option_collision", "option_target_then_collision", "option_phase_b",
                          "option_age"}) {
      n.push_back(s);
    }
    RMPMARL_ASSERT(static_cast<int>(n.size()) == LocalObs::kRmpSize, "local observation names out of sync");
  }
  if (lookahead) {
    for (const char* s : {"lookahead_clearance", "lookahead_time", "lookahead_speed"}) n.push_back(s);
  }
  return n;
}

GlobalStateLayout::GlobalStateLayout(InterfaceMode mode, int nq_, int max_obstacles_)
    : nq(nq_), max_obstacles(max_obstacles_), has_options(mode == InterfaceMode::kPerJointRmp) {
  int k = 0;
  joint_position = k; k += nq;
  joint_velocity = k; k += nq;
  ee_position = k; k += 3;
  ee_velocity = k; k += 3;
  target_position = k; k += 3;
  target_velocity = k; k += 3;
  ee_to_target = k; k += 3;
  log_distance = k; k += 1;
  joint_warning = k; k += 2 * nq;
  joint_option = k; k += has_options ? 4 * nq : 0;
  obstacles = k; k += kObstacleSlot * max_obstacles;
  robot_reach = k; k += 1;
  progress = k; k += 1;
  size = k;
}

std::vector<std::string> GlobalStateLayout::Names() const {
  std::vector<std::string> n;
  for (int i = 0; i < nq; ++i) n.push_back(fmt::format("q{}", i));
  for (int i = 0; i < nq; ++i) n.push_back(fmt::format("qd{}", i));
  for (const char* p : {"ee_x", "ee_y", "ee_z", "ee_vx", "ee_vy", "ee_vz", "target_x", "target_y", "target_z",
                        "target_vx", "target_vy", "target_vz", "ee_to_target_x", "ee_to_target_y",
                        "ee_to_target_z", "ee_target_log_distance"}) {
    n.push_back(p);
  }
  for (int i = 0; i < nq; ++i) {
    n.push_back(fmt::format("warning{}", i));
    n.push_back(fmt::format("warning_distance{}", i));
  }
  if (has_options) {
    for (int i = 0; i < nq; ++i) {
      for (const char* p : {"option_target", "option_collision", "option_target_then_collision", "option_phase_b"}) {
        n.push_back(fmt::format("{}{}", p, i));
      }
    }
  }
  for (int j = 0; j < max_obstacles; ++j) {
    for (const char* p : {"present", "x", "y", "z", "vx", "vy", "vz", "rxx", "rxy", "rxz", "ryx", "ryy", "ryz",
                          "half_x", "half_y", "half_z"}) {
      n.push_back(fmt::format("obstacle{}_{}", j, p));
    }
  }
  n.push_back("robot_reach");
  n.push_back("progress");
  RMPMARL_ASSERT(static_cast<int>(n.size()) == size, "global state names out of sync");
  return n;
}

std::vector<std::string> RewardTermNames() { return {"joint_reach", "distance", "time", "collision"}; }

}  // namespace rmpmarl::control
