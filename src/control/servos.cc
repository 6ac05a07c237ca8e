// The joints of a robot as a ReactiveController commands them in a user's loop.
#include "rmpmarl/control/servos.h"

#include <limits>

namespace rmpmarl::control {

ServoSpec ServosOf(const kinematics::Robot& robot) {
  const kinematics::Model& model = robot.model;
  const int nq = model.nq();
  ServoSpec s;
  s.robot = robot.name;
  s.lower.resize(nq);
  s.upper.resize(nq);
  s.velocity.resize(nq);
  const double inf = std::numeric_limits<double>::infinity();
  for (int i = 0; i < nq; ++i) {
    const bool continuous = model.link(model.dof_link(i)).joint_type == kinematics::JointType::kContinuous;
    s.lower[i] = continuous ? -inf : model.limits()[i].lower;
    s.upper[i] = continuous ? inf : model.limits()[i].upper;
    s.velocity[i] = model.limits()[i].velocity;
  }
  return s;
}

}  // namespace rmpmarl::control
