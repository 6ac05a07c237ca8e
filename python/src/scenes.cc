// Planning scenes and motion-plan requests as MoveIt writes them (MotionBenchMaker's problem files), read into the
// keyword arguments Controller.update() takes: the same reader the benchmark uses (control/planning_scene.h).
#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <filesystem>
#include <string>

#include "bindings.h"
#include "rmpmarl/planning/planning_scene.h"

namespace rmpmarl::python {
namespace {

// rows of `n` doubles per obstacle of one kind
py::array_t<double> Rows(py::ssize_t count, py::ssize_t n) { return py::array_t<double>({count, n}); }
py::array_t<double> Rotations(py::ssize_t count) { return py::array_t<double>({count, py::ssize_t{3}, py::ssize_t{3}}); }

void CopyRotation(const Eigen::Matrix3d& R, double* out) {
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out[3 * r + c] = R(r, c);
  }
}

// update()'s obstacle arguments for `obstacles` (only the kinds present: update() refuses rotations without boxes)
py::dict SceneArguments(const std::vector<rmp::Obstacle>& obstacles) {
  auto count = [&](rmp::ObstacleShape shape) {
    return static_cast<py::ssize_t>(std::count_if(obstacles.begin(), obstacles.end(),
                                                  [shape](const rmp::Obstacle& o) { return o.shape == shape; }));
  };
  const py::ssize_t ns = count(rmp::ObstacleShape::kSphere), nb = count(rmp::ObstacleShape::kBox);
  const py::ssize_t ny = count(rmp::ObstacleShape::kCylinder);
  py::array_t<double> spheres = Rows(ns, 4), boxes = Rows(nb, 6), box_rotations = Rotations(nb);
  py::array_t<double> cylinders = Rows(ny, 5), cylinder_rotations = Rotations(ny);
  py::ssize_t is = 0, ib = 0, iy = 0;
  for (const rmp::Obstacle& o : obstacles) {
    if (o.shape == rmp::ObstacleShape::kSphere) {
      double* row = spheres.mutable_data(is++, 0);
      Eigen::Map<Eigen::Vector3d>{row} = o.sphere.p_WC;
      row[3] = o.sphere.radius;
    } else if (o.shape == rmp::ObstacleShape::kBox) {
      double* row = boxes.mutable_data(ib, 0);
      Eigen::Map<Eigen::Vector3d>{row} = o.box.X_WB.translation();
      Eigen::Map<Eigen::Vector3d>{row + 3} = o.box.half_size;
      CopyRotation(o.box.X_WB.linear(), box_rotations.mutable_data(ib++, 0, 0));
    } else if (o.shape == rmp::ObstacleShape::kCylinder) {
      double* row = cylinders.mutable_data(iy, 0);
      Eigen::Map<Eigen::Vector3d>{row} = o.cylinder.X_WC.translation();
      row[3] = o.cylinder.radius;
      row[4] = o.cylinder.half_length;
      CopyRotation(o.cylinder.X_WC.linear(), cylinder_rotations.mutable_data(iy++, 0, 0));
    }
  }
  py::dict args;
  if (ns > 0) args["spheres"] = spheres;
  if (nb > 0) {
    args["boxes"] = boxes;
    args["box_rotations"] = box_rotations;
  }
  if (ny > 0) {
    args["cylinders"] = cylinders;
    args["cylinder_rotations"] = cylinder_rotations;
  }
  return args;
}

py::array_t<double> ToNumpy(const Eigen::VectorXd& v) {
  py::array_t<double> a(v.size());
  std::copy_n(v.data(), v.size(), a.mutable_data());
  return a;
}

void CheckFile(const std::string& path, const char* what) {
  if (!std::filesystem::is_regular_file(path)) FileNotFound(path, "path", what);
}

}  // namespace

void BindScenes(py::module_& m) {
  m.def("read_planning_scene", [](const std::string& path, const py::handle& robot) {
    CheckFile(path, "a MoveIt planning scene (.yaml)");
    const std::string base = robot.is_none() ? std::string() : RobotOf(robot, "")->robot->model.link(0).name;
    return SceneArguments(planning::ReadPlanningScene(path, base).Obstacles());
  }, py::arg("path"), py::arg("robot") = py::none(),
        "the collision objects of a MoveIt planning scene (YAML of moveit_msgs/PlanningScene, as MotionBenchMaker "
        "writes them) as Controller.update()'s keyword arguments: a dict with 'spheres' [K, 4], 'boxes' [K, 6] "
        "(centre, half sizes) and 'box_rotations' [K, 3, 3], 'cylinders' [K, 5] (centre, radius, half length) and "
        "'cylinder_rotations', only the kinds present, in the robot's base frame: controller.update(q, qd, "
        "joint_target=..., **scene). The scene's frames are applied (the virtual joint's pose, fixed_frame_transforms, "
        "objects given in `robot`'s base link when it is passed); an unknown frame is refused by name. MoveIt's full box sizes and cylinder [height, radius] are converted; meshes, "
        "planes and cones are refused by object id (ValueError).");
  m.def("read_motion_plan_request", [](const std::string& path, const py::handle& robot) {
    CheckFile(path, "a MoveIt motion-plan request (.yaml)");
    const std::shared_ptr<RobotHandle> r = RobotOf(robot, "");
    const planning::MotionPlanRequest request = planning::ReadMotionPlanRequest(path);
    const std::string source = std::filesystem::path(path).filename().string();
    py::dict out;
    out["start"] = ToNumpy(planning::JointVector(*r->robot, request.start, source + ": start_state"));
    out["joint_target"] = ToNumpy(planning::JointVector(*r->robot, request.goal.joints, source + ": goal"));
    out["tolerance"] = ToNumpy(planning::JointGoalTolerance(*r->robot, request.goal, source + ": goal"));
    out["group"] = request.group;
    return out;
  }, py::arg("path"), py::arg("robot"),
        "a MoveIt motion-plan request (moveit_msgs/MotionPlanRequest YAML: the start state and the joint constraints "
        "of its first goal) in `robot`'s joint order (an rmpmarl.Robot, a name or a .urdf path): a dict with 'start' "
        "[nq], 'joint_target' [nq] (update()'s argument), 'tolerance' [nq] (per joint, the smaller of below and "
        "above) and 'group'. Every joint of the robot must be named (ValueError naming the missing ones); names the "
        "robot lacks (a gripper's fingers) are skipped.");
}

}  // namespace rmpmarl::python
