#pragma once
// Each subcommand lives in its own file and registers itself on the CLI11 app.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rmpmarl/setup/robot_setup.h"
#include "rmpmarl/perception/depth_perception.h"
#include "rmpmarl/perception/recorded_cloud.h"
#include "rmpmarl/tasks/manipulator_env.h"

namespace rmpmarl::apps {

/// `rmpmarl check-robot URDF COLLISION_YAML`: validates a robot description and prints it.
void RegisterCheckRobot(CLI::App& app);

/// `rmpmarl setup-robot URDF [--out DIR] ...`: collision YAML + per-robot settings from the URDF alone.
void RegisterSetupRobot(CLI::App& app);

/// A user's robot (check-robot, demo): loaded from its collision YAML, or fitted in memory (`setup` then set).
struct UserRobot {
  kinematics::Robot robot;
  std::optional<setup::RobotSetup> setup;
};
/// `collision` when given, else <urdf stem>.collision.yaml or collision.yaml beside the URDF, else setup::SetupRobot
/// in memory (saying so on stdout; the home found goes into robot.home).
UserRobot LoadUserRobot(const std::string& urdf, const std::string& collision,
                        const std::vector<std::string>& package_paths = {});
/// a seed option's check: a whole number from 0 to 2^64 − 1 (a negative one would wrap around silently).
inline CLI::Validator SeedCheck() {
  return CLI::Validator(
      [](std::string& value) {
        const bool digits = !value.empty() && value.find_first_not_of("0123456789") == std::string::npos;
        return digits ? std::string() : "expected a seed: a whole number from 0 to 2^64 − 1, got '" + value + "'";
      },
      "SEED");
}

/// adds the robot and scenario options every simulation command takes: --robot (a shipped robot), --urdf and
/// --collision (a user's robot), --scenario and --seed.
void AddRobotAndScenarioOptions(CLI::App* cmd, std::string* robot, std::string* urdf, std::string* collision,
                                std::string* scenario, std::uint64_t* seed);
/// the shipped default controller, models/policies/marl-rmp-residual.rmpp: MAPPO's residual over the hand gate of the
/// target stiffness on the coupled basic layer (docs/method.md). demo and view run it when no --policy is given.
std::filesystem::path ShippedDefaultPolicyPath();
/// prints setup-robot's per-link table (capsule, stick-out, source) and warnings.
void PrintLinkFits(const setup::RobotSetup& setup);

/// `rmpmarl robots`: sweeps every shipped robot in its MuJoCo world and prints a table.
// --perception truth|depth and the depth camera's settings (perception_options.cc).
struct PerceptionArgs {
  std::string mode = "truth";
  double rate = 30.0;      // camera frames per second
  double noise = 0.002;    // sigma_at_1m [m]
  double dropout = 0.01;
  double voxel = 0.02;     // [m]
  double point_margin = control::CloudObstacleOptions{}.point_margin;  // [m] added to each point's radius
  int width = 320, height = 240;
  std::string memory = "on";  // on: static obstacles the arm hides are remembered (perception::OcclusionMemory)
  std::string cloud;       // a recorded cloud (file or folder) instead of the scene's obstacles ("" none)
};
void AddPerceptionOptions(CLI::App* cmd, PerceptionArgs* args);
bool UsesDepth(const PerceptionArgs& args);
// depth or a recorded cloud: the controllers' obstacles come from a sensor
bool UsesSensor(const PerceptionArgs& args);
perception::DepthPerceptionOptions DepthOptions(const PerceptionArgs& args, std::uint64_t seed);
// the env's sensor maker for --perception depth (empty for truth); it throws when offscreen rendering is unavailable.
std::function<std::unique_ptr<sim::ObstacleSensor>(const sim::WorldModel&)> MakeSensorFactory(
    const PerceptionArgs& args, std::uint64_t seed);
// a line describing the perception, for the commands' headers.
std::string DescribePerception(const PerceptionArgs& args);

void RegisterRobots(CLI::App& app);
void RunRobotsTable(double duration);

/// `rmpmarl benchmark mbm --problems DIR`: MotionBenchMaker problems run by every method (benchmark.cc).
void RegisterBenchmark(CLI::App& app, int argc, char** argv);

/// `rmpmarl demo`: the README's main job.
void RegisterDemo(CLI::App& app);
/// `rmpmarl view`: the live viewer in the browser (docs/viewer.md).
void RegisterView(CLI::App& app);
/// `rmpmarl policy show|upgrade`: a controller file's card; format-1 files rewritten as format 2.
void RegisterPolicy(CLI::App& app);

#ifdef RMPMARL_HAS_TORCH
/// `rmpmarl train CONFIG [--resume] [--seed N]`: PPO/MAPPO training (docs/learning.md).
void RegisterTrain(CLI::App& app, int argc, char** argv);
/// `rmpmarl eval POLICY [--robot/--urdf/--scenario/--obstacle-speed] --episodes N`: success rate, tracking error, clearance, collisions.
void RegisterEval(CLI::App& app);
/// `rmpmarl export-policy CHECKPOINT OUTPUT`: the actor for the torch-free runtime.
void RegisterExportPolicy(CLI::App& app);
/// `rmpmarl upgrade-checkpoint FILE...`: format-1 checkpoints (torch::serialize) rewritten as format 2, in place.
void RegisterUpgradeCheckpoint(CLI::App& app);
/// `rmpmarl experiment NAME ...`: the paper's tables and figures (docs/experiments.md); argv goes into the report.
void RegisterExperiment(CLI::App& app, int argc, char** argv);
/// `rmpmarl probe-lookahead POLICY --recipe KEY`: a learned agent's response to the look-ahead block (probe.h).
void RegisterProbeLookahead(CLI::App& app);
#endif

}  // namespace rmpmarl::apps
