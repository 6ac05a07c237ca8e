#pragma once
/// A control::ReactiveController driving a simulated World's position servos: the measured state in, the servo
/// targets out (the controller itself knows no simulator).
#include "rmpmarl/control/controller.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::sim {

/// starts an episode of `controller` at the world's measured state (ReactiveController::Reset).
void ResetController(control::ReactiveController& controller, const World& world);

/// one control step: controller.Update(world.q(), world.qd(), scene), then world.SetJointTargets(servo_target(),
/// qdd_cmd()) (the commanded acceleration is used only by servos with an inverse-dynamics feed-forward).
/// Does not step the physics (the caller steps physics_steps_per_control() times). Allocates nothing.
control::ControlStepResult StepController(control::ReactiveController& controller, World& world,
                                          const rmp::Scene& scene);

}  // namespace rmpmarl::sim
