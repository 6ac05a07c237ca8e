#pragma once
/// Scenes and problems as the field writes them: a MoveIt planning scene (YAML of moveit_msgs/PlanningScene:
/// `world.collision_objects`, each with box / sphere / cylinder `primitives` and their `primitive_poses`, under an
/// optional object `pose`) and a MoveIt motion-plan request (moveit_msgs/MotionPlanRequest: `start_state.joint_state`
/// and the joint constraints of `goal_constraints[0]`) — the files of MotionBenchMaker's problem sets. Obstacles come out in
/// the robot's base frame (the frames the file gives are applied: ParsePlanningScene); a pose is a position [x, y, z] and a
/// quaternion [x, y, z, w] (lists, or mappings with those keys). MoveIt's dimensions: a box [x, y, z] (full side
/// lengths), a sphere [radius], a cylinder [height, radius] (its axis along the primitive's z).
///
/// Refused by name, with the object's id: mesh and plane shapes (give a mesh's surface as a point cloud instead), cone
/// primitives, operations other than ADD, quaternions that are not unit (|‖q‖ − 1| > 1e-3), non-finite or
/// non-positive sizes. Octomaps and attached objects are not read (a scene holding them says so in `ignored`).
#include <Eigen/Core>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "rmpmarl/kinematics/robot.h"
#include "rmpmarl/rmp/scene.h"

namespace rmpmarl::planning {

/// One collision object: its id and its primitives as static obstacles in the base frame.
struct SceneObject {
  std::string id;
  std::vector<rmp::Obstacle> primitives;
};

/// The collision world of a planning scene.
struct PlanningScene {
  std::string name;                  ///< the scene's `name` ("" when absent)
  std::vector<SceneObject> objects;  ///< in file order
  std::vector<std::string> ignored;  ///< what the file holds that is not read (e.g. "world.octomap")

  /// every primitive of every object, in file order.
  std::vector<rmp::Obstacle> Obstacles() const;
};

/// Joint values by name (a sensor_msgs/JointState's name and position).
struct NamedJoints {
  std::vector<std::string> names;
  Eigen::VectorXd positions;  ///< [rad or m], one per name
};

/// A joint-space goal: per named joint a position and the tolerances below and above it (MoveIt's
/// moveit_msgs/JointConstraint).
struct JointGoal {
  NamedJoints joints;
  Eigen::VectorXd tolerance_below;  ///< ≥ 0 [rad or m]
  Eigen::VectorXd tolerance_above;  ///< ≥ 0
};

/// A motion-plan request: where the arm starts and the joint goal it must reach.
struct MotionPlanRequest {
  std::string group;  ///< `group_name` ("" when absent)
  NamedJoints start;
  JointGoal goal;
};

/// reads a planning scene from YAML text / a file, its obstacles in the robot's base frame. Frames: an object's poses
/// are in its `header.frame_id` — absent or empty: MoveIt's planning frame; a `fixed_frame_transforms` child frame
/// (its transform from the planning frame applied); `base_link` (the robot's root link, when the caller names it).
/// The planning frame is the parent of the robot's virtual joint, whose pose `robot_state.multi_dof_joint_state`
/// gives (one joint): objects in the planning frame are brought into the base frame by its inverse. An unknown frame
/// (a robot link: objects attached to links are not read) is refused by name with the scene's frames listed. Throws
/// InputError naming the source, the object and the key.
PlanningScene ParsePlanningScene(const std::string& yaml, std::string_view source, std::string_view base_link = "");
PlanningScene ReadPlanningScene(const std::filesystem::path& path, std::string_view base_link = "");

/// reads a motion-plan request. Throws InputError naming the source and the key; a request whose goal is not a set of
/// joint constraints (position or orientation constraints only) is refused with that said.
MotionPlanRequest ParseMotionPlanRequest(const std::string& yaml, std::string_view source);
MotionPlanRequest ReadMotionPlanRequest(const std::filesystem::path& path);

/// the robot's joint vector (dof order) from named values. Every dof of the robot must be named (InputError naming
/// `what`, the missing joints and the names given); names the robot lacks (a gripper's fingers) are skipped.
Eigen::VectorXd JointVector(const kinematics::Robot& robot, const NamedJoints& joints, std::string_view what);

/// the goal's per-dof tolerance (the smaller of below and above), in the robot's dof order (as JointVector).
Eigen::VectorXd JointGoalTolerance(const kinematics::Robot& robot, const JointGoal& goal, std::string_view what);

}  // namespace rmpmarl::planning
