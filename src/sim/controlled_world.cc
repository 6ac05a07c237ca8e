// A ReactiveController on a World's servos.
#include "rmpmarl/sim/controlled_world.h"

namespace rmpmarl::sim {

void ResetController(control::ReactiveController& controller, const World& world) {
  controller.Reset(world.q(), world.qd());
}

control::ControlStepResult StepController(control::ReactiveController& controller, World& world,
                                          const rmp::Scene& scene) {
  const control::ControlStepResult result = controller.Update(world.q(), world.qd(), scene);
  world.SetJointTargets(controller.servo_target(), controller.qdd_cmd());
  return result;
}

}  // namespace rmpmarl::sim
