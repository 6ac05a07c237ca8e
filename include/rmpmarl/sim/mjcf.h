#pragma once
/// MJCF generation: a kinematics::Robot (Model + capsules) plus a scene (mocap obstacles, a visual-only target, an
/// optional floor) written as one MuJoCo 2.2.2 XML string, and its in-memory compilation to an mjModel.
/// See docs/sim.md for the conventions (gravity off, servo gains, sensing margin, contact filtering).
#include <mujoco/mjmodel.h>

#include <Eigen/Geometry>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::sim {

/// Numerical integrator of the MuJoCo step (mjtIntegrator). Both support the split step mj_step1/mj_step2 the World
/// uses; RK4 does not and is therefore not offered.
enum class Integrator {
  kEuler,     ///< semi-implicit Euler (damping explicit)
  kImplicit,  ///< implicit in velocity: joint damping and velocity-dependent forces are integrated implicitly
};

/// Position servo of every dof: τ_i = kp_i (q_cmd,i − q_i) − d_i q̇_i (MuJoCo <position> actuator + joint damping).
/// By default the gains are computed per dof from the joint-space inertia at the reference configuration q_ref
/// (middle of the joint range, 0 for continuous joints), including the armature:
///   kp_i = ω_n² M_ii(q_ref),   d_i = 2 ζ ω_n M_ii(q_ref)   (a critically damped 2nd-order system for ζ = 1).
struct ServoOptions {
  double natural_frequency = 40.0;  ///< ω_n [rad/s]
  double damping_ratio = 1.0;       ///< ζ
  double armature = 0.1;            ///< rotor inertia added to every dof [kg m² (revolute) or kg (prismatic)]
  Eigen::VectorXd kp;               ///< explicit stiffness per dof (size nq, > 0); empty: computed as above
  Eigen::VectorXd damping;          ///< explicit joint damping per dof (size nq, ≥ 0); empty: computed as above
  bool limit_force_to_effort = false;  ///< clamp each servo's force to ± the URDF effort limit (when > 0)
  /// World::SetJointTargets(q_cmd, q̈_cmd) offsets each target by τ_i / kp_i, τ = M(q) q̈_cmd + c(q, q̇) + h D q̈_cmd
  /// (MuJoCo integrates the joint damping D implicitly, with either integrator), the torque the commanded
  /// acceleration needs, with M (armature included) and the Coriolis/centrifugal forces c of the state at the control
  /// step, held over its physics steps: a model-based joint controller's inverse-dynamics feed-forward, so that the arm
  /// does not trail its command by M q̈ / kp where the command accelerates (a corner of a path). Off: the PD alone.
  bool inverse_dynamics_feedforward = false;
};

/// Physics and sensing options of a world (one mjModel per distinct value).
struct WorldOptions {
  double timestep = 0.002;                       ///< [s]
  Integrator integrator = Integrator::kImplicit;
  double warning_margin = 0.15;                  ///< sensing margin: contacts are reported up to this distance [m]
  double link_density = 1000.0;                  ///< link mass = capsule volume × density [kg/m³]
  double min_link_mass = 0.01;                   ///< mass of links without capsules [kg] (inertia of a 5 cm sphere)
  ServoOptions servo;
};

/// Shape of an obstacle (the paper's obstacles are cubes; benchmark cells add cylinders).
enum class ObstacleShape { kBox, kSphere, kCylinder };

/// Where obstacles wait until placed: 10 m below the origin, out of reach of any arm (and below a floor).
inline Eigen::Isometry3d ParkedPose() {
  return Eigen::Isometry3d(Eigen::Translation3d(0.0, 0.0, -10.0));
}

/// One mocap obstacle. Its size is part of the compiled model; its pose is set per World.
struct ObstacleSpec {
  ObstacleShape shape = ObstacleShape::kBox;
  Eigen::Vector3d half_size = Eigen::Vector3d::Constant(0.05);  ///< box half side lengths [m]
  double radius = 0.05;                                        ///< sphere or cylinder radius [m]
  double half_length = 0.05;                                   ///< cylinder half length along O's z axis [m]
  Eigen::Isometry3d X_WO = ParkedPose();                       ///< initial pose of the obstacle centre frame O

  /// a box of half side lengths `half_size` at X_WO.
  static ObstacleSpec Box(const Eigen::Vector3d& half_size, const Eigen::Isometry3d& X_WO = ParkedPose());
  /// a cube of side length `side` at X_WO.
  static ObstacleSpec Cube(double side, const Eigen::Isometry3d& X_WO = ParkedPose());
  /// a sphere of radius `radius` centred at p_WO.
  static ObstacleSpec Sphere(double radius, const Eigen::Vector3d& p_WO = ParkedPose().translation());
  /// a cylinder of `radius` and `half_length` whose axis is the z axis of X_WO.
  static ObstacleSpec Cylinder(double radius, double half_length, const Eigen::Isometry3d& X_WO = ParkedPose());
  /// the spec of an rmp obstacle's shape and pose (sphere, box or cylinder; a point set is refused: InputError).
  static ObstacleSpec Of(const rmp::Obstacle& obstacle);
  /// this shape at pose X_WO (a sphere: its translation), moving with v_WO, as the RMPs see it.
  rmp::Obstacle AsRmp(const Eigen::Isometry3d& X_WO, const Eigen::Vector3d& v_WO = Eigen::Vector3d::Zero()) const;
};

/// Everything in the world besides the robot.
struct SceneSpec {
  std::vector<ObstacleSpec> obstacles;
  bool has_target = true;                                  ///< a visual-only mocap sphere marking the goal
  double target_radius = 0.02;                             ///< [m], display only (no collision volume)
  Eigen::Vector3d p_WT = Eigen::Vector3d(0.0, 0.0, -10.0);  ///< initial target position (parked)
  bool has_floor = false;                                  ///< a collision plane z = floor_height
  double floor_height = 0.0;                               ///< [m]
};

/// Servo gains per dof (rmpmarl dof order), as written into the MJCF.
struct ServoGains {
  Eigen::VectorXd kp;       ///< <position kp>, N m/rad or N/m
  Eigen::VectorXd damping;  ///< <joint damping>, N m s/rad or N s/m
};

/// Names the MJCF gives to MuJoCo elements (robot bodies and joints keep their URDF names).
struct MjcfNames {
  /// body of link k: the link's name, except a name MuJoCo reserves ("world", the world body) or one taken by the
  /// scene, which becomes "link/<name>".
  static std::string LinkBody(const kinematics::Robot& robot, int link);
  static std::string CapsuleGeom(const kinematics::Robot& robot, int capsule);  ///< "<link>/capsule<c>"
  /// "<link>/self_capsule<c>": Robot::self_capsules[c], which touches only other links' self-collision capsules
  static std::string SelfCapsuleGeom(const kinematics::Robot& robot, int capsule);
  static std::string Actuator(const kinematics::Robot& robot, int dof);         ///< "<joint>/servo"
  static std::string ObstacleBody(int obstacle);                               ///< "scene/obstacle<j>"
  static std::string ObstacleGeom(int obstacle);                               ///< "scene/obstacle<j>/geom"
  static constexpr const char* kTargetBody = "scene/target";
  static constexpr const char* kTargetGeom = "scene/target/geom";
  static constexpr const char* kFloorGeom = "scene/floor";
};

/// validates the options and scene (finite, positive sizes, gains of size nq); throws InputError.
void CheckWorldInputs(const kinematics::Robot& robot, const SceneSpec& scene, const WorldOptions& options);

/// the MJCF text of robot + scene with the given servo gains (numbers written with %.17g).
/// \pre CheckWorldInputs(robot, scene, options) passed; gains have size robot.model.nq().
std::string WriteMjcf(const kinematics::Robot& robot, const SceneSpec& scene, const WorldOptions& options,
                      const ServoGains& gains);

/// compiles MJCF text from memory (MuJoCo VFS); throws InputError with MuJoCo's compiler message, naming `source`.
std::shared_ptr<mjModel> CompileMjcf(const std::string& mjcf, std::string_view source);

}  // namespace rmpmarl::sim
