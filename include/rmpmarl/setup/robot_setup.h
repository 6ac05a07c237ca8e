#pragma once
/// A robot description made from a URDF alone (as MoveIt's Setup Assistant does for MoveIt): capsules fitted to each
/// link's own geometry, the end effector, self-collision exclusions found by seeded sampling and a home posture.
/// `rmpmarl setup-robot` writes the result as <urdf stem>.collision.yaml + <urdf stem>.rmpflow.yaml; `check-robot`
/// and `demo --urdf` use it in memory when there is no YAML. See docs/robot-description.md.
#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "rmpmarl/setup/capsule_cover.h"
#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::setup {

/// Options of FitRobot and SetupRobot.
struct RobotSetupOptions {
  std::vector<std::filesystem::path> package_paths;  ///< where package:// meshes are looked up (then ROS_PACKAGE_PATH)
  std::uint64_t seed = 1;                              ///< seed of the configuration samples
  int samples = 10000;                                 ///< configuration samples for the exclusions and the home search
  /// pairs never closer than this in every sample are excluded [m]; the default is sim::WorldOptions::warning_margin.
  double warning_distance = 0.15;
  double always_in_contact = 0.99;  ///< pairs in contact in at least this share of samples are excluded
  double fallback_radius = 0.04;    ///< capsule radius between joint origins when a mesh is missing [m]
  /// each link's cover: its tolerance on how far a capsule may stick out beyond the link's geometry, the most
  /// capsules per link, the spacing of the surface samples that check it (capsule_cover.h)
  CapsuleCoverOptions cover;
  /// per link (by name): its own cover tolerance [m] instead of cover.tolerance — tighter where the robot works close
  /// to things (a hand, its fingers), looser elsewhere. An unknown link name is an InputError.
  std::map<std::string, double> link_tolerance;
  /// a second cover of each link for self-collision checks only (Robot::self_capsules), e.g. the plane cuts beside a
  /// tight inscribed cover; none: the capsules of `cover` are checked for self-collision too
  std::optional<CapsuleCoverOptions> self_cover;
  /// the home search maximises log √det(J Jᵀ) − home_centering · mean_i ((q_i − mid_i) / half range_i)²
  double home_centering = 2.0;
  std::optional<Eigen::VectorXd> home;  ///< the home posture to use instead of searching for one
  std::string end_effector;             ///< end-effector link; "" picks the tip of the longest revolute chain
  /// the robot's MoveIt SRDF (srdf.h): its <disable_collisions> pairs are excluded beside the sampled ones and its
  /// first end effector's parent_link is the end effector when `end_effector` is "". "" looks for <urdf stem>.srdf
  /// beside the URDF, else the only *.srdf there.
  std::filesystem::path srdf;
  bool use_srdf = true;                 ///< false: no SRDF, not even one beside the URDF (`srdf` must be "")
};

/// What was done for one link.
struct LinkFit {
  int link = -1;
  std::string source;              ///< e.g. "collision mesh meshes/link1.stl (1204 vertices)", "frame only"
  std::vector<int> capsules;       ///< indices into Robot::capsules
  std::vector<int> self_capsules;  ///< indices into Robot::self_capsules (RobotSetupOptions::self_cover)
  double self_excess = 0.0;        ///< how far the self-collision capsules stick out beyond the geometry [m]
  /// largest distance from the surface of the link's capsules to its geometry [m] (CapsuleCover::max_excess)
  double excess = 0.0;
  double mean_excess = 0.0;        ///< the mean over the capsules' surface [m] (CapsuleCover::mean_excess)
  /// the check: largest distance of a sample of the link's geometry outside every capsule of the link [m]; ≤ 0 when
  /// the capsules cover it (NaN for a fallback)
  double outside = 0.0;
  int samples = 0;                 ///< surface samples of the check
  bool within_tolerance = true;    ///< excess ≤ the cover's tolerance
  bool reached_max_capsules = false;  ///< not within it and stopped at the most capsules per link
  bool fallback = false;           ///< geometry missing: a capsule between the joint origins
};

/// Why a link pair is excluded from self-collision checks.
/// kOneGripper: links only one dof with mimic followers moves against each other (the fingers of a gripper).
/// kSrdf: a <disable_collisions> pair of the robot's SRDF not already excluded as adjacent or one gripper.
enum class ExclusionReason { kAdjacent, kAlwaysInContact, kNeverClose, kContactAtHome, kOneGripper, kSrdf };

/// name as written in the collision YAML comments ("adjacent", "always in contact", ...).
std::string_view ExclusionReasonName(ExclusionReason reason);

/// A link pair excluded from self-collision checks, with the sampling statistics behind it.
struct Exclusion {
  int link_a = -1, link_b = -1;    ///< link_a < link_b
  ExclusionReason reason = ExclusionReason::kAdjacent;
  double contact_share = 0.0;      ///< share of samples in which the capsules overlap
  double min_distance = 0.0;       ///< smallest capsule distance over the samples [m] (negative: overlap)
  std::string srdf_reason;         ///< kSrdf: the SRDF's reason attribute ("Never", "Adjacent", ...; "" when none)
};

/// Self-collision statistics of every pair of links with capsules over seeded configuration samples.
struct PairStatistics {
  int link_a = -1, link_b = -1;
  int contacts = 0;                ///< samples with the capsules overlapping
  double min_distance = 0.0;       ///< over the samples [m]
};

/// The generated description.
struct RobotSetup {
  kinematics::Robot robot;                     ///< capsules, end effector and every exclusion (adjacent ones included)
  std::vector<LinkFit> links;      ///< one per link, in model order
  std::vector<std::string> warnings;
  std::vector<Exclusion> exclusions;  ///< beyond parent–child pairs: what the YAML lists, with reasons
  Eigen::VectorXd home;            ///< home posture (empty before SetupRobot's home search)
  double home_manipulability = 0.0;   ///< √det(J Jᵀ) of the end effector's 6-D Jacobian at home
  double home_min_distance = 0.0;     ///< smallest capsule distance of non-excluded pairs at home [m]
  int samples = 0;
  /// the SRDF whose disabled pairs and end effector SetupRobot used ("" when none), and what was read from it and
  /// chosen, for the user ("SRDF: panda.srdf (beside the URDF): 34 disabled pairs, ...")
  std::filesystem::path srdf;
  std::vector<std::string> notes;
  /// where the end effector came from: "options.end_effector", "the SRDF's end effector 'hand' (its parent_link)",
  /// "the tip of the longest revolute chain or a tool frame below it"
  std::string end_effector_from;
};

/// capsules fitted to every link's <collision> (else <visual>) geometry (options.cover, a link's own tolerance from
/// options.link_tolerance; a second cover into Robot::self_capsules with options.self_cover) and the end effector; no
/// sampling. Adjacent pairs (parent–child, frame-only links skipped) are excluded. Throws InputError.
RobotSetup FitRobot(const std::filesystem::path& urdf_path, const RobotSetupOptions& options = {});

/// distance statistics (on the self-collision capsules, Robot::self_collision_capsules) of every non-adjacent pair of
/// links with capsules over options.samples configurations drawn
/// uniformly within the joint limits from options.seed (continuous joints in [−π, π]); identical for a seed.
std::vector<PairStatistics> SampleSelfCollision(const kinematics::Robot& robot, const RobotSetupOptions& options);

/// FitRobot, then the SRDF's disabled pairs and end effector (options.srdf), exclusions from SampleSelfCollision over
/// the remaining pairs (always in contact, never within warning_distance), the home posture (options.home, else the
/// best-conditioned collision-free sample near mid-range, refined locally) and the pairs touching at home. Throws
/// InputError when options.home is invalid or the SRDF cannot be read or names links the URDF lacks (srdf.h).
RobotSetup SetupRobot(const std::filesystem::path& urdf_path, const RobotSetupOptions& options = {});

/// √det(J Jᵀ) of the 6 x nq end-effector Jacobian (√det(Jᵀ J) when nq < 6) at q.
double Manipulability(const kinematics::Robot& robot, const Eigen::VectorXd& q);

/// smallest self-collision capsule distance between non-excluded link pairs at q, and the pair (links) that attains it
/// (-1, -1 and +inf when there is no such pair).
struct ClosestPair {
  int link_a = -1, link_b = -1;
  double distance = 0.0;
};
ClosestPair ClosestSelfCollisionPair(const kinematics::Robot& robot, const Eigen::VectorXd& q);

/// every non-excluded link pair whose self-collision capsules are closer than `distance` at q, closest first.
std::vector<ClosestPair> SelfCollisionPairsWithin(const kinematics::Robot& robot, const Eigen::VectorXd& q, double distance);

/// the collision YAML (docs/robot-description.md) of a setup, with comments saying where each capsule came from.
std::string CollisionYamlText(const RobotSetup& setup);

/// the per-robot settings (an RMPflow config: home posture, overrides) of a setup.
std::string SettingsYamlText(const RobotSetup& setup);

/// <stem>.collision.yaml and <stem>.rmpflow.yaml for a URDF <stem>.urdf, in `dir`.
std::filesystem::path CollisionYamlPathFor(const std::filesystem::path& urdf_path, const std::filesystem::path& dir);

/// A user's robot from its URDF: `collision` when given, else <urdf stem>.collision.yaml or collision.yaml beside
/// the URDF, else fitted in memory by SetupRobot (then `*fitted` holds the setup, when asked, and robot.home the home
/// it found). Used by check-robot, demo and the learning tasks (`robot: path/to/robot.urdf`). Throws InputError.
kinematics::Robot LoadOrFitRobot(const std::filesystem::path& urdf, const std::filesystem::path& collision = {},
                     const RobotSetupOptions& options = {}, std::optional<RobotSetup>* fitted = nullptr);
std::filesystem::path SettingsPathFor(const std::filesystem::path& urdf_path, const std::filesystem::path& dir);

}  // namespace rmpmarl::setup
