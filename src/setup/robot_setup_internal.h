#pragma once
// What robot_setup.cc and robot_setup_srdf.cc share (not installed).
#include <filesystem>

#include "rmpmarl/kinematics/model.h"
#include "rmpmarl/setup/robot_setup.h"

namespace rmpmarl::setup::internal {

/// link `tip`, or the link fixed below it (through fixed joints only) named like a tool frame, best name first.
int ToolFrameAtOrBelow(const kinematics::Model& model, int tip);

/// the SRDF's disabled pairs not yet excluded become kSrdf exclusions, and its first end effector's parent link the
/// end effector unless options.end_effector names one; setup->notes say what was used.
void ApplySrdf(const std::filesystem::path& urdf_path, const RobotSetupOptions& options, RobotSetup* setup);

}  // namespace rmpmarl::setup::internal
