// `rmpmarl setup-robot ROBOT.urdf`: capsules fitted to the URDF's own geometry, self-collision exclusions by seeded
// sampling and a home posture, written as <stem>.collision.yaml + <stem>.rmpflow.yaml (docs/robot-description.md).
#include <fmt/core.h>

#include <array>
#include <charconv>
#include <chrono>
#include <cmath>
#include <fstream>
#include <map>

#include "commands.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/setup/robot_setup.h"

namespace rmpmarl::apps {

void PrintLinkFits(const setup::RobotSetup& setup) {
  const kinematics::Robot& robot = setup.robot;
  const kinematics::Model& model = robot.model;
  // per link: its capsules, how far they stick out beyond its geometry (the farthest point, the mean over their
  // surface; '!' above the tolerance) and the check (the farthest surface sample outside every capsule, ≤ 0: covered)
  fmt::print("\n  {:<24} {:<9} {:<52} {:<19} {:<10} {}\n", "link", "capsule", "a, b [m] / radius [m]",
             "sticks out max/mean", "check", "from");
  for (const setup::LinkFit& fit : setup.links) {
    const std::string& name = model.link(fit.link).name;
    if (fit.capsules.empty()) {
      fmt::print("  {:<24} {:<9} {:<52} {:<19} {:<10} {}\n", name, "none", "-", "-", "-", fit.source);
      continue;
    }
    for (size_t i = 0; i < fit.capsules.size(); ++i) {
      const kinematics::LinkCapsule& cap = robot.capsules[fit.capsules[i]];
      const std::string geometry =
          fmt::format("[{:6.3f} {:6.3f} {:6.3f}] [{:6.3f} {:6.3f} {:6.3f}] r={:.3f}", cap.p_LA.x(), cap.p_LA.y(),
                      cap.p_LA.z(), cap.p_LB.x(), cap.p_LB.y(), cap.p_LB.z(), cap.radius);
      std::string out = "", check = "";
      if (i == 0) {
        out = std::isfinite(fit.excess) ? fmt::format("{:5.1f}{}/{:4.1f} mm", 1e3 * fit.excess,
                                                      fit.within_tolerance ? " " : "!", 1e3 * fit.mean_excess)
                                        : std::string("    ?/   ? mm");
        check = std::isfinite(fit.outside) ? fmt::format("{:6.3f} mm", 1e3 * fit.outside) : std::string("     ? mm");
      }
      fmt::print("  {:<24} {:<9} {:<52} {:<19} {:<10} {}\n", i == 0 ? name : "", fit.fallback ? "FALLBACK" : "fitted",
                 geometry, out, check, i == 0 ? fit.source : "");
    }
  }
  fmt::print("  end effector: {}{}\n", model.link(robot.end_effector.link).name,
             setup.end_effector_from.empty() ? std::string() : " (" + setup.end_effector_from + ")");
  for (const std::string& n : setup.notes) fmt::print("  {}\n", n);
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
  std::string srdf;
  bool no_srdf = false;
  double warning_distance = 0.15;
  double home_centering = setup::RobotSetupOptions{}.home_centering;
  double tolerance_mm = 1e3 * setup::CapsuleCoverOptions{}.tolerance;
  int max_capsules = setup::CapsuleCoverOptions{}.max_capsules;
  setup::CoverMethod cover = setup::CapsuleCoverOptions{}.method;
  std::string self_cover = "auto";
  std::vector<std::string> link_tolerance;
};

void RunSetup(const SetupArgs& args) {
  const auto start = std::chrono::steady_clock::now();
  setup::RobotSetupOptions options;
  for (const std::string& p : args.package_paths) options.package_paths.emplace_back(p);
  options.seed = args.seed;
  options.samples = args.samples;
  options.warning_distance = args.warning_distance;
  options.end_effector = args.ee;
  options.srdf = args.srdf;
  options.use_srdf = !args.no_srdf;
  options.home_centering = args.home_centering;
  options.cover.tolerance = 1e-3 * args.tolerance_mm;
  options.cover.max_capsules = args.max_capsules;
  options.cover.method = args.cover;
  for (const std::string& entry : args.link_tolerance) {
    const size_t eq = entry.rfind('=');
    double mm = 0.0;
    const bool parsed = eq != std::string::npos && eq > 0 &&
                        std::from_chars(entry.data() + eq + 1, entry.data() + entry.size(), mm).ptr ==
                            entry.data() + entry.size() && eq + 1 < entry.size();
    if (!parsed || !(mm >= 0.1 && mm <= 1000.0)) {
      throw InputError(fmt::format("--link-tolerance: expected LINK=MM with MM in [0.1, 1000], got '{}'", entry));
    }
    options.link_tolerance[entry.substr(0, eq)] = 1e-3 * mm;
  }
  // a tight cover's self pairs are most of a planner's checks: the default cuts cover proves links apart instead
  if (args.self_cover == "cuts" || (args.self_cover == "auto" && args.cover == setup::CoverMethod::kInscribed)) {
    options.self_cover = setup::CapsuleCoverOptions{};
  }
  if (!args.home.empty()) options.home = Eigen::Map<const Eigen::VectorXd>(args.home.data(), args.home.size());
  const std::filesystem::path urdf(args.urdf);
  const setup::RobotSetup setup = setup::SetupRobot(urdf, options);
  const kinematics::Robot& robot = setup.robot;
  const kinematics::Model& model = robot.model;
  fmt::print("rmpmarl setup-robot: '{}' from {}: {} links, {} joints with a degree of freedom\n", robot.name,
             urdf.string(), model.num_links(), model.nq());
  PrintLinkFits(setup);
  if (!robot.self_capsules.empty()) {
    double worst = 0.0;
    for (const setup::LinkFit& fit : setup.links) {
      if (std::isfinite(fit.self_excess)) worst = std::max(worst, fit.self_excess);
    }
    fmt::print("  self-collision: checked on a separate cover, {} capsules (plane cuts, up to {:.1f} mm out), "
               "beside the {} above\n", robot.self_capsules.size(), 1e3 * worst, robot.capsules.size());
  }

  std::array<int, 6> counts{};  // per setup::ExclusionReason
  for (const setup::Exclusion& e : setup.exclusions) ++counts.at(static_cast<size_t>(e.reason));
  const int parent_child = model.num_links() - 1;
  fmt::print("\n  self-collision exclusions ({} samples, seed {}): {} parent–child, {} adjacent across frame-only "
             "links, {} always in contact, {} never within {:.0f} mm, {} in contact at home, {} fingers of one "
             "gripper, {} disabled in the SRDF\n", setup.samples, args.seed, parent_child, counts[0], counts[1],
             counts[2], 1000 * options.warning_distance, counts[3], counts[4], counts[5]);
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
  const auto collision_path = setup::CollisionYamlPathFor(urdf, dir);
  const auto settings_path = setup::SettingsPathFor(urdf, dir);
  std::ofstream(collision_path) << setup::CollisionYamlText(setup);
  std::ofstream(settings_path) << setup::SettingsYamlText(setup);
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
  cmd->add_option("--ee", args.ee, "end-effector link (default: the parent link of the SRDF's end effector, else "
                                   "the tip of the longest revolute chain)");
  auto* srdf = cmd->add_option("--srdf", args.srdf, "the robot's MoveIt SRDF: its disabled collision pairs are "
                                                    "excluded, its end effector used (default: <stem>.srdf beside "
                                                    "the URDF, else the only .srdf there)")
                   ->check(CLI::Validator(
                       [](std::string& path) {
                         return std::filesystem::is_regular_file(path)
                                    ? std::string()
                                    : "expected an existing .srdf file, got '" + path + "' (no such file)";
                       },
                       "FILE"));
  cmd->add_flag("--no-srdf", args.no_srdf, "use no SRDF, not even one beside the URDF")->excludes(srdf);
  cmd->add_option("--warning-distance", args.warning_distance,
                  "pairs never closer than this in any sample are excluded [m]")
      ->check(CLI::Range(0.0, 10.0))
      ->capture_default_str();
  cmd->add_option("--tolerance", args.tolerance_mm,
                  "a link's capsules are split until none sticks out farther than this beyond its geometry [mm]")
      ->check(CLI::Range(0.1, 1000.0))
      ->capture_default_str();
  cmd->add_option("--max-capsules", args.max_capsules, "at most this many capsules per link")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  const std::map<std::string, setup::CoverMethod> covers = {{"cuts", setup::CoverMethod::kCuts},
                                                                 {"inscribed", setup::CoverMethod::kInscribed}};
  cmd->add_option("--cover", args.cover,
                  "cuts: split the link's smallest capsule by planes; inscribed: capsules grown inside the solid, "
                  "none sticking out farther than --tolerance (tight, more capsules)")
      ->transform(CLI::CheckedTransformer(covers, CLI::ignore_case))
      ->default_str("cuts");
  cmd->add_option("--link-tolerance", args.link_tolerance,
                  "LINK=MM: this link's own --tolerance (repeatable), e.g. tighter for the hand and fingers");
  cmd->add_option("--self-cover", args.self_cover,
                  "the capsules checked for self-collision: same (the cover's own), cuts (a separate cover by plane "
                  "cuts at the default tolerance: fewer pairs to check), auto (cuts for --cover inscribed, else same)")
      ->check(CLI::IsMember({"auto", "same", "cuts"}))
      ->capture_default_str();
  cmd->callback([] { RunSetup(args); });
}

}  // namespace rmpmarl::apps
