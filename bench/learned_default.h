#pragma once
// The shipped learned default's own task as its controller file carries it (models/policies/marl-rmp-residual.rmpp):
// its coupled basic layer, hand gate and look-ahead block, for the benchmarks of its layer and its env.
#include <string>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::bench {

inline tasks::TaskConfig LearnedDefaultConfig() {
  const std::string path = (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string();
  return rl::PolicyTaskConfig(control::LoadPolicyFile(path), path);
}

}  // namespace rmpmarl::bench
