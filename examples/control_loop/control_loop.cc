// Your own control loop with a shipped controller (docs/control-your-robot.md), built against rmpmarl::control alone
// (no simulator, no MuJoCo, no libtorch):
//   control_loop [POLICY.rmpp | rmpflow] [ROBOT]
// loads the controller file (or RMPflow) and a robot, then every 10 ms hands the controller the measured joint state,
// the end-effector target and the obstacles, and sends the commanded joint positions and velocities it integrates to
// the robot. Here the "robot" is ideal position servos (the measured state is the last command); on hardware the
// measured state comes from your driver and q_cmd()/qd_cmd() (or servo_target()) go to it.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <exception>
#include <limits>
#include <memory>
#include <string>

#include "rmpmarl/control/controller.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/scene.h"

using namespace rmpmarl;

int main(int argc, char** argv) {
  try {
    const std::string policy =
        argc > 1 ? argv[1] : (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string();
    const std::string robot_name = argc > 2 ? argv[2] : "panda";

    // 1. the robot and the controller: a controller file (network + basic layer + observation, all in the file) or
    //    RMPflow with the robot's shipped parameters, behind the same interface
    const kinematics::Robot robot = kinematics::LoadShippedRobot(robot_name);
    std::unique_ptr<control::AccelerationPolicy> accelerations;
    control::ControllerOptions options;
    if (policy == "rmpflow") {
      accelerations = std::make_unique<control::RmpflowAccelerationPolicy>(robot, /*max_obstacles=*/1);
    } else {
      const control::PolicyFile file = control::LoadPolicyFile(policy);
      auto learned = control::MakeLearnedController(robot, file, policy, /*max_obstacles=*/1);
      options = learned->controller_options();
      accelerations = std::move(learned);
    }
    control::ReactiveController controller(control::ServosOf(robot), std::move(accelerations), options);

    // 2. the loop: measured state in, commands out, at the control rate
    kinematics::Data kin(robot.model);
    Eigen::VectorXd q = Eigen::VectorXd::Zero(robot.model.nq()).cwiseMax(controller.lower_limits())
                            .cwiseMin(controller.upper_limits());
    Eigen::VectorXd qd = Eigen::VectorXd::Zero(robot.model.nq());
    controller.Reset(q, qd);
    kinematics::CalcForwardKinematics(robot.model, q, &kin);
    const Eigen::Vector3d p_W0 =
        kinematics::CalcPointPosition(kin, robot.end_effector.link, robot.end_effector.X_LE.translation());
    rmp::Scene scene;
    scene.has_target = true;
    scene.obstacles.resize(1);
    const Eigen::Vector3d half_size = Eigen::Vector3d::Constant(0.05);
    double final_error = 0.0, min_clearance = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 400; ++k) {
      const double t = k * controller.control_period();
      // the target circles around the start position; the cube crosses between at 0.3 m/s
      scene.p_WT = p_W0 + 0.1 * Eigen::Vector3d(std::cos(t) - 1.0, std::sin(t), 0.0);
      scene.v_WT = 0.1 * Eigen::Vector3d(-std::sin(t), std::cos(t), 0.0);
      const Eigen::Vector3d p_WO = p_W0 + Eigen::Vector3d(-0.1, -0.6 + 0.3 * t, 0.25);
      scene.obstacles[0] = rmp::Obstacle::MakeBox(Eigen::Isometry3d(Eigen::Translation3d(p_WO)), half_size,
                                                  Eigen::Vector3d(0, 0.3, 0));
      const control::ControlStepResult r = controller.Update(q, qd, scene);
      if (!r.finite) std::printf("step %d: non-finite acceleration, position held\n", k);
      q = controller.q_cmd();  // ideal servos: the next measured state is this command
      qd = controller.qd_cmd();

      kinematics::CalcForwardKinematics(robot.model, q, &kin);
      final_error = (kinematics::CalcPointPosition(kin, robot.end_effector.link,
                                                   robot.end_effector.X_LE.translation()) - scene.p_WT).norm();
      for (const kinematics::LinkCapsule& c : robot.capsules) {
        const Eigen::Isometry3d& X_WL = kin.X_WL[c.link];
        const math::Capsule capsule{X_WL * c.p_LA, X_WL * c.p_LB, c.radius};
        min_clearance = std::min(min_clearance, rmp::CapsuleObstacleDistance(capsule, scene.obstacles[0]).distance);
      }
    }
    std::printf("%s on %s: final tracking error %.1f mm, min clearance %.1f mm, %.1f us per control step\n",
                policy.c_str(), robot.name.c_str(), 1000.0 * final_error, 1000.0 * min_clearance,
                controller.stats().mean_compute_us());
    return final_error < 0.05 && min_clearance > 0.0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "control_loop: %s\n", e.what());
    return 2;
  }
}
