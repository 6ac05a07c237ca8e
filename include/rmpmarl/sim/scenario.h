#pragma once
/// The scenarios of the paper's experiments (section IV; docs/control.md): a target in uniform linear motion inside a
/// per-robot workspace box, cube obstacles crossing the workspace, a line of obstacles crossing it where an obstacle
/// that hits the robot stops at the point of impact (Fig. 7), cluttered static obstacles, and static set-ups for
/// tests. A Scenario is a plain, seeded, step-able object: Reset(seed) draws an episode, Advance(dt) moves obstacles
/// and target and writes their poses into the World's mocap bodies, FillScene() gives the policies the same obstacles
/// and target with their velocities. Scenarios are reusable by the RL environments (one Scenario per World).
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include "rmpmarl/planning/planning_scene.h"
#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/sim/mjcf.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::sim {

/// How the target workspace box is derived from the robot's reach R (in the robot's front frame: x forward).
struct WorkspaceOptions {
  double near = 0.35;         ///< the box spans [near·R, far·R] along the front axis from the base z axis
  double far = 0.75;
  double half_width = 0.4;    ///< and ± half_width·R sideways
  double half_height = 0.25;  ///< |z − z_S| ≤ half_height·R, z_S the shoulder height
  double min_height = 0.1;    ///< and z ≥ min_height [m] (above the base plane; spatial arms only)
  int samples = 4000;         ///< random configurations sampled for the reach (fixed internal seed)
};

/// The region in front of a robot where targets move and obstacles cross (docs/control.md).
struct Workspace {
  Eigen::Vector3d p_WS = Eigen::Vector3d::Zero();  ///< shoulder point (0, 0, z of the link moved by dof 1 at q = 0)
  /// the front axis: of ±x, ±y the one closest to the horizontal direction of the end effector at the start posture
  Eigen::Vector3d front = Eigen::Vector3d::UnitX();
  double reach = 0.0;             ///< R = max ‖p_WE − p_WS‖ over the sampled configurations [m]
  double horizontal_reach = 0.0;  ///< max horizontal distance of the end effector from the base z axis [m]
  bool planar = false;            ///< the end effector stays in a plane z = const (planar2); box.z is that plane
  Eigen::AlignedBox3d box;        ///< the target region (axis-aligned, since `front` is)

  /// the horizontal axis to the left of `front`: z × front.
  Eigen::Vector3d lateral() const { return Eigen::Vector3d(-front.y(), front.x(), 0.0); }
};

/// the workspace of `robot` whose start posture is q_start (deterministic). Throws InputError for bad options.
Workspace MakeWorkspace(const kinematics::Robot& robot, const Eigen::VectorXd& q_start,
                        const WorkspaceOptions& options = {});

/// the start posture of the scenarios: the `home` of the robot's shipped RMPflow config
/// (configs/rmpflow/<robot>.yaml) when it has one, else the middle of each joint's limits (0 for continuous joints).
Eigen::VectorXd ReadyConfiguration(const kinematics::Robot& robot);

/// The end-effector target of an episode: p_WT moves with constant v_WT and is reflected at the faces of `bounds`
/// (velocity component flipped); along a degenerate axis of `bounds` the coordinate is pinned.
struct TargetState {
  Eigen::Vector3d p_WT = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_WT = Eigen::Vector3d::Zero();  ///< [m/s]
  Eigen::AlignedBox3d bounds;                       ///< reflection box (only used while v_WT ≠ 0)
};

/// One obstacle of an episode. Its centre moves along the line p_start + s·direction with ṡ = speed (s < 0: still on
/// its way to the start of the path, outside the robot's reach); at s > path_length the scenario re-draws the path
/// or wraps s back by `wrap`. An obstacle with stop_on_impact that collides with the robot stops for the rest of the
/// episode (paper Fig. 7).
struct ObstacleState {
  Eigen::Vector3d p_start = ParkedPose().translation();
  Eigen::Vector3d direction = Eigen::Vector3d::UnitX();  ///< unit
  Eigen::Matrix3d R_WO = Eigen::Matrix3d::Identity();     ///< orientation of the obstacle centre frame
  double speed = 0.0;        ///< [m/s] ≥ 0; 0: static
  double s = 0.0;            ///< arc length along the path [m]
  double path_length = 0.0;  ///< [m]
  double wrap = 0.0;         ///< at s > path_length: s −= wrap (> 0), or the scenario re-draws the path (0)
  bool stop_on_impact = false;
  bool stopped = false;      ///< hit the robot and stopped (stop_on_impact)
  double stop_time = -1.0;   ///< World::time() of the state in which the impact was seen [s], −1 before
  int paths = 1;             ///< paths travelled so far (1 + re-draws/wraps)

  Eigen::Vector3d p_WO() const { return p_start + s * direction; }
  Eigen::Vector3d v_WO() const { return (stopped ? 0.0 : speed) * direction; }
};

/// What moves the obstacles and the target of an episode (sim::EpisodeLoop): a Scenario, or a scene a user edits
/// live (the viewer).
class SceneSource {
 public:
  virtual ~SceneSource();
  /// moves obstacles and target by dt [s] (`contacts`: the report of the world's current state) and writes their
  /// poses into `world`. Allocates nothing.
  virtual void Advance(double dt, const ContactReport& contacts, World& world) = 0;
  /// the obstacles (shape, pose, velocity) and the target (position, velocity) as the policies see them.
  virtual void FillScene(rmp::Scene* scene) const = 0;
  /// the target now.
  virtual const TargetState& target() const = 0;
};

/// Base of every scenario: owns the episode state and its RNG (std::mt19937_64, seeded by Reset only).
class Scenario : public SceneSource {
 public:
  virtual ~Scenario();
  Scenario(const Scenario&) = delete;
  Scenario& operator=(const Scenario&) = delete;

  /// registry name ("crossing", ...).
  const std::string& name() const { return name_; }
  /// obstacle shapes/sizes (parked) and the target marker: build the WorldModel from this.
  const SceneSpec& scene_spec() const { return spec_; }
  int num_obstacles() const { return static_cast<int>(spec_.obstacles.size()); }
  const kinematics::Robot& robot() const { return robot_; }
  const Workspace& workspace() const { return workspace_; }
  /// a sensible episode length for this scenario [s] (the CLI's default).
  double default_duration() const { return default_duration_; }

  /// draws episode `seed` (same seed → the same episode), resets the world's robot to q_start() with q̇ = 0 and
  /// places obstacles and target. Throws InputError when `world` was not built from scene_spec() and robot().
  void Reset(std::uint64_t seed, World& world);
  /// advances the scenario by dt [s]: obstacles with stop_on_impact that collide in `contacts` (the report of the
  /// world's current state) stop where they are; the others move; the target moves and reflects. Writes the new
  /// poses of what moved into `world`. Allocates nothing.  \pre Reset.
  void Advance(double dt, const ContactReport& contacts, World& world) override;
  /// the obstacles (shape, pose, velocity) and the target (position, velocity) as the policies see them. Allocates
  /// only when scene->obstacles has to grow.
  void FillScene(rmp::Scene* scene) const override;

  /// scenario time since Reset [s].
  double time() const { return time_; }
  const Eigen::VectorXd& q_start() const { return q_start_; }
  const TargetState& target() const override { return target_; }
  const std::vector<ObstacleState>& obstacles() const { return obstacles_; }
  /// the obstacle as an rmp::Obstacle (shape from scene_spec(), pose and velocity from obstacles()).
  rmp::Obstacle ObstacleAsRmp(int j) const;
  /// the joint-space goal the controllers are given (FillScene's q_T), empty when the episode has none.
  const Eigen::VectorXd& joint_goal() const { return joint_goal_; }

 protected:
  /// `spec` fixes the obstacle shapes; q_start defaults to ReadyConfiguration(robot) when empty.
  Scenario(std::string name, const kinematics::Robot& robot, SceneSpec spec, double default_duration,
           const WorkspaceOptions& workspace, const Eigen::VectorXd& q_start);

  /// draws a new episode into q_start_, target_ and obstacles_ (already sized num_obstacles()); time_ = 0.
  virtual void Draw(std::mt19937_64& rng) = 0;
  /// obstacle j passed the end of its path and has wrap == 0: re-draw its path (default: it stays at the end).
  virtual void OnPathEnd(int j, std::mt19937_64& rng);

  /// a random unit direction: uniform on the sphere, or on the circle z = 0 for a planar workspace.
  Eigen::Vector3d RandomDirection(std::mt19937_64& rng) const;
  /// a uniform random point of the workspace box.
  Eigen::Vector3d RandomWorkspacePoint(std::mt19937_64& rng) const;
  /// a target starting at a random workspace point moving at `speed` in a random direction, reflected in the box.
  TargetState RandomMovingTarget(double speed, std::mt19937_64& rng) const;
  /// A horizontal crossing path: through a random workspace point at a random heading, at least min_base_distance
  /// from the base z axis, starting and ending spawn_margin outside the horizontal reach; the speed drawn from
  /// [speed, speed_max] when speed_max > speed (otherwise `speed`, and no draw).
  struct HorizontalCrossing {
    double min_base_distance = 0.3;
    double spawn_margin = 0.3;
    double speed = 0.3;
    double speed_max = 0.0;
    const char* min_base_distance_key = "";  ///< the option named when no path passes (InputError)
  };
  /// draws obstacle j's next crossing path (s = 0 at its start, no wrap).
  void DrawHorizontalCrossing(int j, const HorizontalCrossing& crossing, std::mt19937_64& rng);
  /// smallest signed distance between the robot's capsules at q and obstacle j placed at p_WO (shape from spec).
  double RobotClearance(const Eigen::VectorXd& q, int j, const Eigen::Vector3d& p_WO) const;
  /// smallest signed distance between the robot's capsules (forward kinematics in `at`) and `obstacle`.
  double RobotClearance(const kinematics::Data& at, const rmp::Obstacle& obstacle) const;
  /// end-effector position at q.
  Eigen::Vector3d EndEffectorAt(const Eigen::VectorXd& q) const;

  std::string name_;
  kinematics::Robot robot_;
  collision::RobotCollisionModel checker_;  // the clearances of sampled starts, goals and obstacles
  Workspace workspace_;
  SceneSpec spec_;
  double default_duration_ = 10.0;
  Eigen::VectorXd q_start_;
  std::mt19937_64 rng_;
  double time_ = 0.0;
  TargetState target_;
  std::vector<ObstacleState> obstacles_;
  Eigen::VectorXd joint_goal_;  ///< the joint-space goal given to the controllers (empty: none), set by Draw
};

/// Options of `static-reach`: a static target at the end effector of a random configuration near the start posture
/// (reachable by construction, away from singularities and self-collision), optionally with one obstacle in the
/// middle of the straight segment from the start end-effector position to the target.
struct StaticReachOptions {
  Eigen::VectorXd q_start{};            ///< empty: ReadyConfiguration(robot)
  double joint_spread = 1.0;          ///< q_goal,i = q_start,i + U(−spread, spread) [rad or m] ...
  double limit_margin = 0.2;          ///< ... clamped this far inside the joint limits
  double min_distance = 0.25;         ///< ‖p_WT − p_WE(q_start)‖ ≥ this [m]
  double min_singular_value = 0.1;    ///< smallest singular value of the end-effector position Jacobian at q_goal
  double min_self_clearance = 0.02;   ///< [m] between checked link pairs at q_goal
  double min_height = 0.05;           ///< capsules of links moved by ≥ 2 dofs above this z at q_goal [m] (3-D arms)
  bool obstacle_on_path = false;      ///< one obstacle at the midpoint of the segment p_WE(q_start) → p_WT
  ObstacleSpec obstacle = ObstacleSpec::Sphere(0.04);  ///< its shape and size (the pose is drawn)
  double obstacle_clearance = 0.05;   ///< the obstacle is this far from the arm at q_start and q_goal [m]
  int max_attempts = 20000;           ///< draws before giving up (InputError)
  WorkspaceOptions workspace{};
};

/// `static-reach` (and `static-obstacle` with obstacle_on_path).
class StaticReachScenario final : public Scenario {
 public:
  StaticReachScenario(const kinematics::Robot& robot, const StaticReachOptions& options = {});
  /// the configuration whose end effector is the target of the current episode.
  const Eigen::VectorXd& q_goal() const { return q_goal_; }
  const StaticReachOptions& options() const { return options_; }

 private:
  void Draw(std::mt19937_64& rng) override;
  StaticReachOptions options_;
  Eigen::VectorXd q_goal_;
};

/// An obstacle crossing a fixed scene in a straight line at constant velocity (a benchmark's dynamic variant).
struct LinearMotion {
  ObstacleSpec spec;                                  ///< shape and size (its pose is the motion's)
  Eigen::Vector3d p_W0 = Eigen::Vector3d::Zero();     ///< centre at t = 0 [m]
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();      ///< velocity [m/s]
};

/// Options of a fully specified static set-up (tests, benchmark problems): fixed start, target and obstacles, and
/// obstacles in uniform linear motion; no randomness.
struct StaticSceneOptions {
  Eigen::VectorXd q_start{};                  ///< empty: ReadyConfiguration(robot)
  Eigen::Vector3d p_WT = Eigen::Vector3d(0.4, 0.0, 0.4);
  std::vector<ObstacleSpec> obstacles{};    ///< with their poses X_WO
  /// a joint-space goal the controllers are given beside p_WT (rmp::Scene::q_T; e.g. a benchmark problem's goal
  /// configuration, whose end effector is p_WT); empty: none
  Eigen::VectorXd q_goal{};
  /// obstacles moving through the scene (after `obstacles` in the world's and the scene's order)
  std::vector<LinearMotion> moving{};
};

/// a planning scene (planning::ReadPlanningScene: its primitives as static obstacles) with, when given, a motion-plan
/// request's start (q_start) and joint goal (q_goal, and p_WT the end effector there); without a request the start is
/// ReadyConfiguration(robot) and the target the end effector there. Throws InputError (a joint of the robot missing
/// from the request, a point-set obstacle).
StaticSceneOptions StaticSceneOf(const kinematics::Robot& robot, const planning::PlanningScene& scene,
                                 const planning::MotionPlanRequest* request = nullptr, std::string_view source = "");

/// `static`: the set-up of StaticSceneOptions (not in the registry: it needs explicit data).
class StaticScenario final : public Scenario {
 public:
  StaticScenario(const kinematics::Robot& robot, const StaticSceneOptions& options);

 private:
  void Draw(std::mt19937_64& rng) override;
  StaticSceneOptions options_;
};

/// Options of `crossing` (the default): the paper's moving-target tracking with four cube obstacles crossing the
/// workspace on straight horizontal lines, each re-drawn when it leaves.
struct CrossingOptions {
  int num_obstacles = 4;            ///< the paper's red, green, yellow and blue cubes
  double obstacle_side = 0.1;       ///< cube side [m]
  double obstacle_speed = 0.3;      ///< [m/s]
  /// > obstacle_speed: every path's speed is drawn from U[obstacle_speed, obstacle_speed_max] (domain randomisation
  /// of the training scene); otherwise every cube moves at obstacle_speed and no speed is drawn [m/s]
  double obstacle_speed_max = 0.0;
  double target_speed = 0.1;        ///< [m/s], random direction, reflected in the workspace box
  double min_base_distance = 0.3;   ///< every path passes at least this far from the base z axis (horizontally) [m]
  double spawn_margin = 0.3;        ///< paths start and end this far outside the horizontal reach [m]
  Eigen::VectorXd q_start{};          ///< empty: ReadyConfiguration(robot)
  WorkspaceOptions workspace{};
};

/// `crossing`.
class CrossingScenario final : public Scenario {
 public:
  CrossingScenario(const kinematics::Robot& robot, const CrossingOptions& options = {});
  const CrossingOptions& options() const { return options_; }

 private:
  void Draw(std::mt19937_64& rng) override;
  void OnPathEnd(int j, std::mt19937_64& rng) override;
  // a new horizontal path through a random workspace point for obstacle j (s = 0 at its start).
  void DrawPath(int j, std::mt19937_64& rng);
  CrossingOptions options_;
};

/// How the obstacles of a line-crossing are lined up.
enum class LineArrangement {
  kAlongMotion,   ///< one behind the other on the line of motion (a train; the paper's Fig. 7)
  kAcrossMotion,  ///< side by side, horizontally across the line of motion (a rake sweeping the workspace)
};

/// Options of `line-crossing` (paper section IV-C, Table 4, Fig. 7): a line of cubes crossing the workspace sideways
/// at `speed`, repeatedly; an obstacle that hits the robot stops at the point of impact.
struct LineCrossingOptions {
  int num_obstacles = 5;
  double obstacle_side = 0.08;      ///< cube side [m]
  LineArrangement arrangement = LineArrangement::kAlongMotion;
  double spacing = 0.25;            ///< centre-to-centre distance between neighbours [m]
  double speed = 0.6;               ///< [m/s]; the paper sweeps 0.2, 0.6, 1.2, 1.8, 2.8
  double target_speed = 0.1;        ///< [m/s]
  double max_yaw_deg = 30.0;        ///< the line runs sideways (±Workspace::lateral()) turned by U(±max_yaw) about z
  double min_base_distance = 0.3;   ///< the line passes at least this far from the base z axis [m]
  double spawn_margin = 0.3;        ///< the line starts and ends this far outside the horizontal reach [m]
  bool stop_on_impact = true;
  bool repeat = true;               ///< the line crosses again and again (false: once)
  /// the centre line of motion passes through this point (e.g. the start end-effector position); unset: a random
  /// workspace point
  std::optional<Eigen::Vector3d> through{};
  Eigen::VectorXd q_start{};          ///< empty: ReadyConfiguration(robot)
  WorkspaceOptions workspace{};
};

/// `line-crossing`.
class LineCrossingScenario final : public Scenario {
 public:
  LineCrossingScenario(const kinematics::Robot& robot, const LineCrossingOptions& options = {});
  const LineCrossingOptions& options() const { return options_; }

 private:
  void Draw(std::mt19937_64& rng) override;
  LineCrossingOptions options_;
};

/// Options of `cluttered` (paper section IV-C): static cubes at random distances of 20–50 cm from the start
/// end-effector position, in uniformly random directions (lateral and vertical), while the target moves.
struct ClutteredOptions {
  int num_obstacles = 6;
  double obstacle_side = 0.08;      ///< cube side [m]
  double min_distance = 0.2;        ///< obstacle centre distance from p_WE(q_start) [m]
  double max_distance = 0.5;
  double target_speed = 0.1;        ///< [m/s]
  double start_clearance = 0.05;    ///< obstacles are this far from the arm at q_start [m]
  double target_clearance = 0.05;   ///< and their surface this far from the target's start [m]
  int max_attempts = 20000;
  Eigen::VectorXd q_start{};          ///< empty: ReadyConfiguration(robot)
  WorkspaceOptions workspace{};
};

/// `cluttered`.
class ClutteredScenario final : public Scenario {
 public:
  ClutteredScenario(const kinematics::Robot& robot, const ClutteredOptions& options = {});
  const ClutteredOptions& options() const { return options_; }

 private:
  void Draw(std::mt19937_64& rng) override;
  ClutteredOptions options_;
};

/// The kinds of cell `cells` draws (CellsOptions::kind_weights, in this order).
enum class CellKind {
  kShelf,       ///< a compartment of a shelf (boards, back wall, side walls); the target inside, reached from the front
  kBox,         ///< an open box (floor and four walls); the target inside, reached from above
  kTable,       ///< a table top with objects on it; the target just above it
  kUnderTable,  ///< a table top above the target (and sometimes a board below it); reached from the front
};
inline constexpr int kNumCellKinds = 4;

/// Options of `cells`: a procedurally generated work cell around a static target (MotionBenchMaker's families —
/// shelves, boxes, tables, under tables — drawn with random sizes and poses), with cubes crossing on top. Each
/// episode draws a collision-free joint goal first (uniform within the limits, away from singularities and self-
/// collision), takes its end effector as the target and builds the cell around it, facing the way the hand comes
/// in (the direction from the wrist to the end effector), then checks the arm's clearance from the cell at the goal
/// and at the start. A cell is built from `num_panels` boards of one size (placed so that they overlap or reach past
/// each other where a cell is smaller than a board, as the boards of a bookshelf continue into its next
/// compartment), `num_objects` cubes and the object reached for; what a cell does not use is parked out of reach.
/// Obstacle order: the boards, the cubes, the object reached for, the crossing cubes.
struct CellsOptions {
  std::array<double, kNumCellKinds> kind_weights = {1.0, 1.0, 1.0, 1.0};  ///< shelf, box, table, under-table (≥ 0)
  double panel_length = 0.8;      ///< the boards' long side [m]
  double panel_width = 0.45;      ///< their short side [m] (a shelf's depth and a box wall's height are at most this)
  double panel_thickness = 0.02;  ///< [m]
  int num_panels = 6;             ///< boards in the scene (a shelf or a box uses 6, a table 1–2)
  int num_objects = 2;            ///< cubes: up to this many on a table, one on a shelf board, in a box or under a table
  double object_side = 0.06;      ///< [m]
  std::array<double, 2> opening_width = {0.3, 0.7};   ///< a shelf compartment's inner width [m]
  std::array<double, 2> opening_height = {0.2, 0.4};  ///< its inner height [m]
  std::array<double, 2> depth = {0.25, 0.43};         ///< its inner depth [m]
  std::array<double, 2> box_size = {0.25, 0.55};      ///< a box's inner length and width [m] (its floor: two boards)
  std::array<double, 2> box_height = {0.1, 0.25};     ///< its walls above its floor [m]
  std::array<double, 2> table_gap = {0.08, 0.25};     ///< under a table: its underside above the target [m]
  /// the object being reached for: an upright box (a carton; MuJoCo 2.2.2's distances to a cylinder within a contact
  /// margin are off by millimetres) placed beside the hand at the goal — ahead of it in a
  /// shelf or under a table, beside it on a table or in a box — standing on the cell's surface, its clearance from
  /// the arm at the goal drawn from grasp_clearance (as a benchmark's goals are grasps millimetres from the object);
  /// with probability grasp_object_probability, else parked (also where it would not fit under a board above the
  /// target, or the hand keeps it farther than grasp_clearance's maximum)
  double grasp_object_probability = 0.75;
  double grasp_object_half_width = 0.03;   ///< [m] its half side, horizontally
  double grasp_object_half_length = 0.07;  ///< [m] its half height
  std::array<double, 2> grasp_clearance = {0.003, 0.02};  ///< [m]
  int num_crossing = 1;           ///< cubes crossing the workspace on horizontal lines, as in `crossing`
  double crossing_side = 0.1;     ///< [m]
  double crossing_speed = 0.2;    ///< [m/s]; with crossing_speed_max > it, each path's speed is U[speed, max]
  double crossing_speed_max = 2.8;
  double min_base_distance = 0.3;  ///< crossing paths pass this far from the base z axis [m]
  double spawn_margin = 0.3;       ///< and start this far outside the horizontal reach [m]
  double start_spread = 0.3;       ///< q_start = ReadyConfiguration + U(±spread) per joint [rad]
  double limit_margin = 0.1;       ///< the joint goal this far inside the limits [rad]
  double min_target_distance = 0.2;  ///< the target this far from the end effector at the start [m]
  double goal_clearance = 0.01;    ///< the arm's capsules this far from the cell at the joint goal [m]
  double start_clearance = 0.05;   ///< and at the start [m]
  bool joint_goal = true;          ///< give the controllers the joint goal (rmp::Scene::q_T), as a benchmark does
  int max_attempts = 200000;       ///< draws before giving up (InputError)
  WorkspaceOptions workspace{};

  /// the scene's obstacle index of the object reached for (after the boards and the cubes; the crossing cubes follow).
  int grasp_object_index() const { return num_panels + num_objects; }
  /// the scene's obstacles: boards, cubes, the object reached for, crossing cubes.
  int obstacle_count() const { return grasp_object_index() + 1 + num_crossing; }
};

/// `cells`.
class CellsScenario final : public Scenario {
 public:
  CellsScenario(const kinematics::Robot& robot, const CellsOptions& options = {});
  const CellsOptions& options() const { return options_; }
  /// the kind of the current episode's cell.
  CellKind cell_kind() const { return kind_; }
  /// the joint goal of the current episode (whose end effector is the target).
  const Eigen::VectorXd& q_goal() const { return q_goal_; }

 private:
  void Draw(std::mt19937_64& rng) override;
  void OnPathEnd(int j, std::mt19937_64& rng) override;
  // one attempt at a cell of `kind` around the end effector of q_goal_ (the arm's kinematics at q_start_ and q_goal_
  // given): the static obstacles' poses, or false
  bool BuildCell(CellKind kind, const kinematics::Data& start, const kinematics::Data& goal, std::mt19937_64& rng);
  // the object reached for beside the hand (end effector p_E at the goal's kinematics) along `dir`; false: no room
  bool PlaceGraspObject(const kinematics::Data& goal, const Eigen::Vector3d& p_E, const Eigen::Vector3d& dir,
                        double support, double ceiling, std::mt19937_64& rng);
  // the cell clears the arm at the goal (goal_clearance) and at the start (start_clearance)
  bool ClearOfCell(const kinematics::Data& start, const kinematics::Data& goal) const;
  void DrawCrossingPath(int j, std::mt19937_64& rng);
  CellsOptions options_;
  CellKind kind_ = CellKind::kShelf;
  Eigen::VectorXd q_goal_;
};

/// "shelf", "box", "table", "under-table".
std::string_view CellKindName(CellKind kind);

/// The `pretrain-2link` scenario (docs/environments.md): a target in uniform linear motion in a random in-plane
/// direction (reflected in the workspace box) and one cube placed beside (or, with a zero offset, on) the target's
/// path.
struct PretrainScenarioOptions {
  std::array<double, 2> target_speed = {0.05, 0.25};   ///< [m/s], per episode
  double obstacle_side = 0.1;                          ///< cube side [m]
  std::array<double, 2> obstacle_lead_time = {1.0, 3.0};  ///< the cube sits where the target will be after t [s]
  /// [m] the cube's surface is moved this far beside the target's path there (perpendicular to the target's motion,
  /// to a random side), and the whole path over the scenario's duration keeps at least the range's minimum from it.
  /// {0, 0}: the cube sits on the path (the paper's scene: tracking means leaving the target while it passes). With
  /// obstacle_speed > 0 the offset holds where the cube is drawn only. No draw in max_attempts: InputError.
  std::array<double, 2> obstacle_path_offset = {0.0, 0.0};
  /// the scene drawn as usual (same targets, starts and random draws), then the cube lifted 10 m out of the arm's
  /// plane: the no-obstacle reference on the same episodes (Table 3's `basic-free`)
  bool obstacle_out_of_reach = false;
  std::array<double, 2> obstacle_speed = {0.0, 0.0};   ///< [m/s] (0: static), random in-plane direction
  double start_clearance = 0.05;  ///< cube ≥ this from the arm at q0 [m]
  double target_clearance = 0.0;  ///< cube surface ≥ this from the target's start [m]
  int max_attempts = 1000;
  WorkspaceOptions workspace;
};

/// Generic overrides a command line can apply to any registered scenario (unset: the scenario's default).
struct ScenarioOverrides {
  std::optional<double> obstacle_speed{};  ///< [m/s] (crossing, line-crossing; cells: its crossing cubes)
  std::optional<double> target_speed{};    ///< [m/s] (crossing, line-crossing, cluttered)
  std::optional<int> num_obstacles{};      ///< (crossing, line-crossing, cluttered; cells: its crossing cubes)
};

/// The options of the built-in scenes, one member each (a scene reads its own; the defaults are the scenes' own).
/// A task's `scenario` section is one of these (tasks::ScenarioConfig).
struct SceneOptions {
  PretrainScenarioOptions pretrain;       ///< pretrain-2link
  CrossingOptions crossing;               ///< crossing
  LineCrossingOptions line_crossing;      ///< line-crossing
  ClutteredOptions cluttered;             ///< cluttered
  StaticReachOptions static_reach;        ///< static-reach, static-obstacle (obstacle_on_path set by the name)
  CellsOptions cells;                     ///< cells
};

/// Makes a scenario for a robot from the scene options, with a command line's overrides applied on top.
using ScenarioFactory = std::function<std::unique_ptr<Scenario>(
    const kinematics::Robot& robot, const SceneOptions& options, const ScenarioOverrides& overrides)>;

/// the default scenario of the CLI.
inline constexpr std::string_view kDefaultScenario = "crossing";

/// The one registry of scenes: every scene has one name, the same for the CLI (`--scenario`), the tasks (a task
/// names its scene: tasks::TaskSceneName) and the viewer. Registered in this order: crossing, line-crossing,
/// cluttered, static-reach, static-obstacle, pretrain-2link, cells, then any added by RegisterScenario.
std::vector<std::string> ScenarioNames();
/// whether `name` is registered.
bool HasScenario(std::string_view name);
/// the scenario called `name`; throws InputError listing the known names, or for an override that does not apply.
std::unique_ptr<Scenario> MakeScenario(std::string_view name, const kinematics::Robot& robot,
                                       const ScenarioOverrides& overrides = {}, const SceneOptions& options = {});
/// adds a scenario to the registry (not thread-safe; call at start-up). Throws InputError for a taken name.
void RegisterScenario(const std::string& name, ScenarioFactory factory);

}  // namespace rmpmarl::sim
