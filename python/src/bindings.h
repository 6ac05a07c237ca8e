#pragma once
// The pieces of the rmpmarl._core module, one Bind* per file.
#include <pybind11/pybind11.h>

#include <memory>
#include <string>

#include "arrays.h"
#include "rmpmarl/kinematics/model.h"
#include "rmpmarl/kinematics/robot.h"

namespace rmpmarl::python {

/// a Robot shared with the controllers made for it, and the kinematics buffers of its methods.
struct RobotHandle {
  explicit RobotHandle(kinematics::Robot r);
  std::shared_ptr<const kinematics::Robot> robot;
  kinematics::Data data;
};

/// a shipped robot's name, "planar2" or a path to a .urdf (collision YAML beside it, else fitted).
std::shared_ptr<RobotHandle> LoadRobotArgument(const std::string& robot);

/// raises FileNotFoundError "<name>: expected <what>, got '<path>' (no such file)".
[[noreturn]] void FileNotFound(const std::string& path, const char* name, const char* what);

/// the robot of a `robot` argument: an rmpmarl.Robot, a shipped robot's name or a .urdf path (None: `fallback`);
/// TypeError otherwise.
std::shared_ptr<RobotHandle> RobotOf(const py::handle& robot, const std::string& fallback);

void BindRobot(py::module_& m);
void BindControllers(py::module_& m);
void BindEnvs(py::module_& m);
void BindPolicies(py::module_& m);
void BindScenes(py::module_& m);

}  // namespace rmpmarl::python
