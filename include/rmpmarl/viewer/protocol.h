#pragma once
/// The viewer's wire format (docs/viewer.md, "Protocol"): the commands a page sends, parsed and checked at the
/// boundary into plain structs, and the `hello` / `frame` messages the server sends, encoded from plain views of the
/// simulation. Nothing here touches a socket or a file; the simulation (live_sim.h), the recorder (recording.h) and
/// the server (server.h) share it.
#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "rmpmarl/control/warning.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/viewer/visuals.h"

namespace rmpmarl::control {
class LearnedController;
}
namespace rmpmarl::sim {
class World;
}

namespace rmpmarl::viewer {

/// protocol version in every hello.
inline constexpr int kProtocolVersion = 1;
/// the largest message a page may send [bytes]; larger ones are refused (the socket's read limit is set to this).
inline constexpr std::size_t kMaxMessageBytes = 16 * 1024;

/// What a page asks for.
enum class CommandKind {
  kSetTarget, kReleaseTarget, kSetObstacle, kAddObstacle, kRemoveObstacle,
  kPause, kResume, kStep, kReset, kSpeed, kController, kSideBySide, kSeek,
};

/// One checked command. Only the fields of its kind are meaningful.
struct Command {
  CommandKind kind = CommandKind::kPause;
  Eigen::Vector3d p = Eigen::Vector3d::Zero();  ///< set_target, set_obstacle, add_obstacle [m]
  int id = -1;                                  ///< set_obstacle, remove_obstacle: obstacle id
  rmp::ObstacleShape shape = rmp::ObstacleShape::kBox;  ///< add_obstacle
  double value = 1.0;                           ///< speed
  std::optional<std::uint64_t> seed;            ///< reset
  std::string name;                             ///< controller
  bool on = false;                              ///< side_by_side
  long frame = 0;                               ///< seek
};

/// The ranges a command is checked against (from the running simulation).
struct CommandLimits {
  double arena = 5.0;              ///< |p_i| ≤ arena [m]
  int num_obstacle_ids = 16;       ///< obstacle ids are in [0, num_obstacle_ids)
  double min_speed = 0.1, max_speed = 1.0;
  std::vector<std::string> controllers{"learned", "rmpflow"};
  long num_frames = 0;             ///< replay: seek frames are in [0, num_frames)
};

/// A parsed message: the command, or why it was refused (one line naming the field, expected and received).
struct ParsedCommand {
  std::optional<Command> command;
  std::string error;
};

/// parses one text message of a page. Never throws; a refusal says why.
ParsedCommand ParseCommand(std::string_view text, const CommandLimits& limits);

/// the protocol name of a command kind ("set_target").
std::string_view CommandName(CommandKind kind);

// ---- server → page

/// One arm in a hello.
struct ArmLabel {
  std::string label;       ///< "marl-rmp-residual", "RMPflow"
  std::string controller;  ///< "learned" or "rmpflow"
};

/// What a hello says besides the robot.
struct HelloInfo {
  std::string mode = "live";  ///< "live" or "replay"
  std::vector<ArmLabel> arms;
  std::vector<std::string> controllers;
  std::string controller;     ///< the first arm's
  bool side_by_side = false;
  Eigen::Vector3d workspace_min = Eigen::Vector3d::Zero(), workspace_max = Eigen::Vector3d::Zero();
  int max_obstacles = 16;
  double arena = 5.0;
  double min_speed = 0.1, max_speed = 1.0;
  double control_rate = 100.0;
  std::string scenario;
  std::uint64_t seed = 0;
  /// the robot's visual elements (visuals.h), drawn besides the capsules
  std::vector<VisualShape> visuals;
  long replay_frames = 0;     ///< replay only
  double replay_duration = 0.0;
};

/// the hello message (JSON text) for `robot`.
std::string EncodeHello(const kinematics::Robot& robot, const HelloInfo& info);

/// One obstacle in a frame.
struct ObstacleView {
  int id = 0;
  rmp::Obstacle obstacle;
  bool held = false;
};

/// One arm in a frame: its world (link poses, q), and the learned controller that drives it, if any (its agents'
/// options, parameters and warnings are shown).
struct ArmView {
  const sim::World* world = nullptr;
  /// the arm's warning contacts (sim::EpisodeLoop::warnings: their robot–obstacle witness points are drawn for an
  /// arm without a learned controller); may be empty
  std::span<const control::WarningContact> warnings{};
  const control::LearnedController* learned = nullptr;
  Eigen::Vector3d p_WE = Eigen::Vector3d::Zero();
  double clearance = 0.0;  ///< smallest robot–obstacle distance [m] (Clearance); +inf: no obstacle
  long collisions = 0;     ///< collision events of the arm (sim::EpisodeLoop: a link–obstacle pair entering penetration)
  double step_us = 0.0;    ///< last control step's compute time
};

/// Everything else in a frame.
struct FrameView {
  long seq = 0;
  double time = 0.0;
  bool paused = false;
  double speed = 1.0, rtf = 1.0, load = 0.0;
  long refused = 0;
  Eigen::Vector3d p_WT = Eigen::Vector3d::Zero();
  bool target_held = false;
  std::span<const ObstacleView> obstacles;
  std::span<const ArmView> arms;
};

/// writes the frame message (JSON text) into `out` (cleared first). For an arm without a learned controller the
/// witness points are the robot–obstacle warnings of `contacts` (nearest per capsule and obstacle).
void EncodeFrame(const FrameView& frame, std::string* out);

/// the smallest signed distance between a world's robot capsules (at MuJoCo's link poses) and `obstacles` [m];
/// +inf without obstacles.
double Clearance(const sim::World& world, std::span<const ObstacleView> obstacles);

/// an error message to the sender of a refused command.
std::string EncodeError(std::string_view message);

}  // namespace rmpmarl::viewer
