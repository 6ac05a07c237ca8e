// Your own control loop with a shipped learned controller (docs/control-your-robot.md):
//   control_loop [POLICY.rmpp] [ROBOT]
// loads the controller file and a robot, then every 10 ms hands the controller the joint state, the end-effector
// target and the obstacles, and integrates the joint accelerations it returns into joint commands. Here MuJoCo plays
// the robot (a World with one cube crossing the arm); on hardware the measured state comes from your driver and
// q_cmd()/qd_cmd() go to it.
#include <Eigen/Geometry>
#include <cmath>
#include <algorithm>
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rl/learned_controller.h"
#include "rmpmarl/rl/policy_file.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/sim/controller.h"
#include "rmpmarl/sim/world.h"

using namespace rmpmarl;

int main(int argc, char** argv) {
  try {
    const std::string policy_path =
        argc > 1 ? argv[1] : (kinematics::ModelsDirectory() / "policies" / "marl-rmp-residual.rmpp").string();
    const std::string robot_name = argc > 2 ? argv[2] : "panda";

    // 1. the robot and the controller file (network + basic layer + observation, all in the file)
    const kinematics::Robot robot = kinematics::LoadShippedRobot(robot_name);
    const rl::PolicyFile file = rl::LoadPolicyFile(policy_path);
    std::unique_ptr<rl::LearnedController> learned =
        rl::MakeLearnedController(robot, file, policy_path, 1);
    const sim::ControllerOptions options = learned->controller_options();

    // 2. a MuJoCo stand-in for the real arm: one box obstacle, position servos
    sim::SceneSpec spec;
    spec.obstacles.push_back(sim::ObstacleSpec::Box(Eigen::Vector3d::Constant(0.05)));
    auto world_model = std::make_shared<const sim::WorldModel>(robot, spec);
    sim::World world(world_model);
    sim::ReactiveController controller(*world_model, std::move(learned), options);
    controller.Reset(world);

    // 3. the loop: state in, commands out, at the control rate
    rmp::Scene scene;
    scene.obstacles.resize(1);
    kinematics::Data kin(robot.model);
    auto end_effector = [&](const Eigen::VectorXd& q) {
      kinematics::CalcForwardKinematics(robot.model, q, &kin);
      return kinematics::CalcPointPosition(kin, robot.end_effector.link, robot.end_effector.X_LE.translation());
    };
    const Eigen::Vector3d p_W0 = end_effector(world.q());
    const int physics_steps = controller.physics_steps_per_control();
    double final_error = 0.0, min_clearance = INFINITY;
    for (int k = 0; k < 400; ++k) {
      const double t = k * controller.control_period();
      // the target circles around the start position; the cube crosses between at 0.3 m/s
      scene.p_WT = p_W0 + 0.1 * Eigen::Vector3d(std::cos(t) - 1.0, std::sin(t), 0.0);
      scene.v_WT = 0.1 * Eigen::Vector3d(-std::sin(t), std::cos(t), 0.0);
      const Eigen::Vector3d p_WO = p_W0 + Eigen::Vector3d(-0.1, -0.6 + 0.3 * t, 0.25);
      scene.obstacles[0] = rmp::Obstacle::MakeBox(Eigen::Isometry3d(Eigen::Translation3d(p_WO)),
                                                  Eigen::Vector3d::Constant(0.05), Eigen::Vector3d(0, 0.3, 0));
      world.SetObstaclePose(0, Eigen::Isometry3d(Eigen::Translation3d(p_WO)));
      world.SetTargetPosition(scene.p_WT);
      const sim::ControlStepResult r = controller.Step(world, scene);  // q, q̇ in; q_cmd, q̇_cmd to the servos
      if (!r.finite) std::printf("step %d: non-finite acceleration, position held\n", k);
      world.Step(physics_steps);
      final_error = (end_effector(world.q()) - scene.p_WT).norm();
      min_clearance = std::min(min_clearance, world.QueryContacts().min_clearance);
    }
    std::printf("%s on %s: final tracking error %.1f mm, min clearance %.1f mm, %.1f us per control step\n",
                policy_path.c_str(), robot.name.c_str(), 1000.0 * final_error, 1000.0 * min_clearance,
                controller.stats().mean_compute_us());
    return final_error < 0.05 && min_clearance > 0.0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "control_loop: %s\n", e.what());
    return 2;
  }
}
