// `rmpmarl setup-robot ROBOT.urdf`: capsules fitted to the URDF's own geometry, self-collision exclusions by seeded
// sampling and a home posture, written as <stem>.collision.yaml + <stem>.rmpflow.yaml (docs/robot-description.md).
#include <fmt/core.h>

#include <array>
#include <chrono>
#include <cmath>
#include <fstream>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot_setup.h"

namespace rmpmarl::apps {

void PrintLinkFits(const kinematics::RobotSetup& setup) {
  const kinematics::Robot& robot = setup.robot;
  const kinematics::Model& model = robot.model;
  fmt::print("\n  {:<24} {:<9} {:<52} {}\n", "link", "capsule", "a, b [m] / radius [m]", "sticks out / from");
  for (const kinematics::LinkFit& fit : setup.links) {
    const std::string& name = model.link(fit.link).name;
    if (fit.capsules.empty()) {
      fmt::print("  {:<24} {:<9} {:<52} {}\n", name, "none", "-", fit.source);
      continue;
    }
    for (int c : fit.capsules) {
      const kinematics::LinkCapsule& cap = robot.capsules[c];
      const std::string geometry =
          fmt::format("[{:6.3f} {:6.3f} {:6.3f}] [{:6.3f} {:6.3f} {:6.3f}] r={:.3f}", cap.p_LA.x(), cap.p_LA.y(),
                      cap.p_LA.z(), cap.p_LB.x(), cap.p_LB.y(), cap.p_LB.z(), cap.radius);
      const std::string out = std::isfinite(fit.stick_out) ? fmt::format("{:5.1f} mm", 1000 * fit.stick_out)
                                                           : std::string("    ? mm");
      fmt::print("  {:<24} {:<9} {:<52} {}  {}\n", name, fit.fallback ? "FALLBACK" : "fitted", geometry, out,
                 fit.source);
    }
  }
  fmt::print("  end effector: {}\n", model.link(robot.end_effector.link).name);
  for (const std::string& w : setup.warnings) fmt::print("  WARNING: {}\n", w);
}

namespace {

struct SetupArgs {
  std::string urdf;
  std::string out;
  std::vector<std::string> package_paths;
  std::uint64_t seed = 1;
  int samples = 10000;
  std::vector<double> home;
  std::string ee;
  double warning_distance = 0.15;
  double home_centering = kinematics::RobotSetupOptions{}.home_centering;
};

void RunSetup(const SetupArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  kinematics::RobotSetupOptions options;
  for (const std::string& p : args.package_paths) options.package_paths.emplace_back(p);
  options.seed = args.seed;
  options.samples = args.samples;
  options.warning_distance = args.warning_distance;
  options.end_effector = args.ee;
  options.home_centering = args.home_centering;
  if (!args.home.empty()) options.home = Eigen::Map<const Eigen::VectorXd>(args.home.data(), args.home.size());
  const std::filesystem::path urdf(args.urdf);
  const kinematics::RobotSetup setup = kinematics::SetupRobot(urdf, options);
  const kinematics::Robot& robot = setup.robot;
  const kinematics::Model& model = robot.model;
  fmt::print("rmpmarl setup-robot: '{}' from {}: {} links, {} joints with a degree of freedom\n", robot.name,
             urdf.string(), model.num_links(), model.nq());
  PrintLinkFits(setup);

  std::array<int, 5> counts{};  // per kinematics::ExclusionReason
  for (const kinematics::Exclusion& e : setup.exclusions) ++counts.at(static_cast<size_t>(e.reason));
  const int parent_child = model.num_links() - 1;
  fmt::print("\n  self-collision exclusions ({} samples, seed {}): {} parent–child, {} adjacent across frame-only "
             "links, {} always in contact, {} never within {:.0f} mm, {} in contact at home, {} fingers of one "
             "gripper\n", setup.samples, args.seed, parent_child, counts[0], counts[1], counts[2],
             1000 * options.warning_distance, counts[3], counts[4]);
  int mimic = 0;
  for (int k = 1; k < model.num_links(); ++k) mimic += model.link(k).mimic_dof >= 0;
  if (mimic > 0) {
    fmt::print("  mimic joints: {} follow their leaders (no coordinate of their own; agents and RMPflow control the "
               "{} independent joints)\n", mimic, model.nq());
  }
  std::string home;
  for (int i = 0; i < setup.home.size(); ++i) home += fmt::format("{}{:.3f}", i ? " " : "", setup.home[i]);
  fmt::print("  home posture: [{}]{} (manipulability {:.4g}, closest checked pair {:.0f} mm)\n", home,
             options.home ? " (--home)" : "", setup.home_manipulability, 1000 * setup.home_min_distance);

  const std::filesystem::path dir = args.out.empty() ? (urdf.has_parent_path() ? urdf.parent_path()
                                                                                : std::filesystem::path("."))
                                                     : std::filesystem::path(args.out);
  std::filesystem::create_directories(dir);
  const auto collision_path = kinematics::CollisionYamlPathFor(urdf, dir);
  const auto settings_path = kinematics::SettingsPathFor(urdf, dir);
  std::ofstream(collision_path) << kinematics::CollisionYamlText(setup);
  std::ofstream(settings_path) << kinematics::SettingsYamlText(setup);
  if (!std::ofstream(collision_path, std::ios::app) || !std::ofstream(settings_path, std::ios::app)) {
    throw InputError(fmt::format("{}: cannot write the description files", dir.string()));
  }
  kinematics::LoadRobot(urdf, collision_path);  // the files must load as written
  fmt::print("\n  wrote {}\n        {}\n  {:.2f} s. Next: rmpmarl check-robot {} {}\n        rmpmarl demo --urdf {} "
             "--collision {} --video demo.mp4\n", collision_path.string(), settings_path.string(),
             std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), urdf.string(),
             collision_path.string(), urdf.string(), collision_path.string());
}

}  // namespace

void RegisterSetupRobot(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "setup-robot", "Make a robot description from a URDF alone: fitted capsules, self-collision exclusions, home");
  static SetupArgs args;
  cmd->add_option("urdf", args.urdf, "robot URDF file (plain URDF: expand xacro first)")->required();
  cmd->add_option("--out", args.out, "directory for <stem>.collision.yaml and <stem>.rmpflow.yaml (default: beside "
                                     "the URDF)");
  cmd->add_option("--package-path", args.package_paths,
                  "directory holding the packages of package:// meshes (repeatable; ROS_PACKAGE_PATH is read too)");
  cmd->add_option("--seed", args.seed, "seed of the configuration samples")
      ->check(SeedCheck())->capture_default_str();
  cmd->add_option("--samples", args.samples, "configuration samples for the exclusions")
      ->check(CLI::Range(1, 10'000'000))
      ->capture_default_str();
  cmd->add_option("--home", args.home, "home posture, one value per joint [rad or m] (default: searched)");
  cmd->add_option("--home-centering", args.home_centering,
                  "home search: weight of the distance from mid-range against log manipulability")
      ->check(CLI::Range(0.0, 1000.0))
      ->capture_default_str();
  cmd->add_option("--ee", args.ee, "end-effector link (default: the tip of the longest revolute chain)");
  cmd->add_option("--warning-distance", args.warning_distance,
                  "pairs never closer than this in any sample are excluded [m]")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  cmd->callback([] { RunSetup(args); });
}

}  // namespace rmpmarl::apps
