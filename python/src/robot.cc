// rmpmarl.Robot: a shipped arm or a user's URDF, with forward kinematics and Jacobians as numpy arrays.
#include "bindings.h"

#include <fmt/format.h>
#include <pybind11/stl.h>

#include <filesystem>

#include "rmpmarl/kinematics/forward_kinematics.h"
#include "rmpmarl/setup/robot_setup.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::python {

namespace fs = std::filesystem;

RobotHandle::RobotHandle(kinematics::Robot r)
    : robot(std::make_shared<const kinematics::Robot>(std::move(r))), data(robot->model) {}

void FileNotFound(const std::string& path, const char* name, const char* what) {
  PyErr_SetString(PyExc_FileNotFoundError,
                  fmt::format("{}: expected {}, got '{}' (no such file)", name, what, path).c_str());
  throw py::error_already_set();
}

namespace {

std::shared_ptr<RobotHandle> FromUrdf(const std::string& urdf, const std::optional<std::string>& collision) {
  if (!fs::is_regular_file(urdf)) FileNotFound(urdf, "urdf", "a URDF file");
  if (collision && !fs::is_regular_file(*collision)) FileNotFound(*collision, "collision", "a collision YAML file");
  return std::make_shared<RobotHandle>(setup::LoadOrFitRobot(urdf, collision ? fs::path(*collision) : fs::path()));
}

py::array CheckedQ(const RobotHandle& r, const py::handle& q) {
  return CheckedArray(q, {.name = "q", .shape = {r.robot->model.nq()}});
}

int LinkArgument(const RobotHandle& r, const py::handle& link) {
  const kinematics::Model& m = r.robot->model;
  if (py::isinstance<py::str>(link)) return m.LinkIndex(link.cast<std::string>());
  if (py::isinstance<py::int_>(link)) {
    const int k = link.cast<int>();
    if (k < 0 || k >= m.num_links()) {
      BadArgument(fmt::format("link: expected an index in [0, {}) or a link name, got {}", m.num_links(), k));
    }
    return k;
  }
  BadArgument(fmt::format("link: expected a link name or index, got {}",
                          std::string(py::str(py::type::of(link).attr("__name__")))));
}

py::array_t<double> Pose(const Eigen::Isometry3d& X) { return MatrixToNumpy(Eigen::MatrixXd(X.matrix())); }

// `capsules` placed at q: rows [a_x, a_y, a_z, b_x, b_y, b_z, radius]
py::array_t<double> WorldCapsules(RobotHandle& r, const py::handle& q,
                                  const std::vector<kinematics::LinkCapsule>& capsules) {
  const py::array qa = CheckedQ(r, q);
  kinematics::CalcForwardKinematics(r.robot->model, AsVector(qa), &r.data);
  py::array_t<double> out({static_cast<py::ssize_t>(capsules.size()), py::ssize_t{7}});
  auto o = out.mutable_unchecked<2>();
  for (size_t c = 0; c < capsules.size(); ++c) {
    const math::Capsule w = kinematics::WorldCapsule(capsules[c], r.data);
    for (int i = 0; i < 3; ++i) {
      o(c, i) = w.p_WA[i];
      o(c, 3 + i) = w.p_WB[i];
    }
    o(c, 6) = w.radius;
  }
  return out;
}

}  // namespace

std::shared_ptr<RobotHandle> LoadRobotArgument(const std::string& robot) {
  if (tasks::IsUrdfPath(robot)) return FromUrdf(robot, std::nullopt);
  if (robot == "planar2") return std::make_shared<RobotHandle>(kinematics::MakePlanar2());
  return std::make_shared<RobotHandle>(kinematics::LoadShippedRobot(robot));
}

void BindRobot(py::module_& m) {
  py::class_<RobotHandle, std::shared_ptr<RobotHandle>>(m, "Robot", R"doc(
A manipulator: its kinematic model (from a URDF), collision capsules and end effector.

Robot("panda") loads a shipped arm (rmpmarl.shipped_robots()); Robot("path/to/arm.urdf") or Robot.from_urdf(...) a
user's URDF with its collision YAML beside it, else capsules fitted in memory (as `rmpmarl setup-robot` does).
Arrays in and out are float64; joint vectors have nq entries (mimic joints follow their leader and have none).
The kinematics methods share one work buffer: use one Robot per thread.)doc")
      .def(py::init(&LoadRobotArgument), py::arg("name"),
           "a shipped robot by name, 'planar2' (the two-link pre-training arm) or a path to a .urdf")
      .def_static("from_urdf", &FromUrdf, py::arg("urdf"), py::arg("collision") = py::none(),
                  "a user's URDF; collision: its collision YAML (default: <stem>.collision.yaml or collision.yaml "
                  "beside the URDF, else capsules fitted in memory)")
      .def_property_readonly("name", [](const RobotHandle& r) { return r.robot->name; })
      .def_property_readonly("nq", [](const RobotHandle& r) { return r.robot->model.nq(); }, "joint coordinates")
      .def_property_readonly("joint_names", [](const RobotHandle& r) {
        std::vector<std::string> names;
        for (int i = 0; i < r.robot->model.nq(); ++i) names.push_back(r.robot->model.dof_name(i));
        return names;
      })
      .def_property_readonly("link_names", [](const RobotHandle& r) {
        std::vector<std::string> names;
        for (const kinematics::Link& l : r.robot->model.links()) names.push_back(l.name);
        return names;
      })
      .def_property_readonly("lower_limits", [](const RobotHandle& r) { return VectorToNumpy(r.robot->model.LowerLimits()); },
                             "joint position lower limits [rad or m] (-inf for continuous joints)")
      .def_property_readonly("upper_limits", [](const RobotHandle& r) { return VectorToNumpy(r.robot->model.UpperLimits()); })
      .def_property_readonly("velocity_limits",
                             [](const RobotHandle& r) { return VectorToNumpy(r.robot->model.VelocityLimits()); },
                             "|q̇| bounds from the URDF [rad/s or m/s]")
      .def_property_readonly("end_effector_link",
                             [](const RobotHandle& r) { return r.robot->model.link(r.robot->end_effector.link).name; })
      .def_property_readonly("urdf_path", [](const RobotHandle& r) { return r.robot->urdf_path.string(); })
      .def_property_readonly("num_capsules", [](const RobotHandle& r) { return r.robot->capsules.size(); })
      .def("link_index", [](const RobotHandle& r, const std::string& name) { return r.robot->model.LinkIndex(name); },
           py::arg("name"), "the index of the link called `name` (ValueError listing the links when absent)")
      .def("forward_kinematics", [](RobotHandle& r, const py::handle& q) {
        const py::array qa = CheckedQ(r, q);
        kinematics::CalcForwardKinematics(r.robot->model, AsVector(qa), &r.data);
        const int L = r.robot->model.num_links();
        py::array_t<double> out({L, 4, 4});
        auto o = out.mutable_unchecked<3>();
        for (int k = 0; k < L; ++k) {
          const Eigen::Matrix4d X = r.data.X_WL[k].matrix();
          for (int i = 0; i < 4; ++i) {
            for (int j = 0; j < 4; ++j) o(k, i, j) = X(i, j);
          }
        }
        return out;
      }, py::arg("q"), "poses X_WL of every link frame in the world, shape [num_links, 4, 4]")
      .def("end_effector_pose", [](RobotHandle& r, const py::handle& q) {
        const py::array qa = CheckedQ(r, q);
        kinematics::CalcForwardKinematics(r.robot->model, AsVector(qa), &r.data);
        return Pose(r.data.X_WL[r.robot->end_effector.link] * r.robot->end_effector.X_LE);
      }, py::arg("q"), "X_WE, shape [4, 4]")
      .def("end_effector_position", [](RobotHandle& r, const py::handle& q) {
        const py::array qa = CheckedQ(r, q);
        kinematics::CalcForwardKinematics(r.robot->model, AsVector(qa), &r.data);
        const auto& ee = r.robot->end_effector;
        return VectorToNumpy(Eigen::VectorXd(kinematics::CalcPointPosition(r.data, ee.link, ee.X_LE.translation())));
      }, py::arg("q"), "p_WE, shape [3]")
      .def("end_effector_jacobian", [](RobotHandle& r, const py::handle& q) {
        const py::array qa = CheckedQ(r, q);
        const kinematics::Model& model = r.robot->model;
        kinematics::CalcForwardKinematics(model, AsVector(qa), &r.data);
        Eigen::Matrix3Xd J(3, model.nq());
        const auto& ee = r.robot->end_effector;
        kinematics::CalcPointJacobian(model, r.data, ee.link, ee.X_LE.translation(), J);
        return MatrixToNumpy(Eigen::MatrixXd(J));
      }, py::arg("q"), "position Jacobian J_WE (ṗ_WE = J_WE q̇), shape [3, nq]")
      .def("point_jacobian", [](RobotHandle& r, const py::handle& q, const py::handle& link, const py::handle& p_LP) {
        const py::array qa = CheckedQ(r, q);
        const int k = LinkArgument(r, link);
        const py::array pa = CheckedArray(p_LP, {.name = "p_LP", .shape = {3}});
        const kinematics::Model& model = r.robot->model;
        kinematics::CalcForwardKinematics(model, AsVector(qa), &r.data);
        Eigen::Matrix3Xd J(3, model.nq());
        kinematics::CalcPointJacobian(model, r.data, k, Eigen::Vector3d(AsVector(pa)), J);
        return MatrixToNumpy(Eigen::MatrixXd(J));
      }, py::arg("q"), py::arg("link"), py::arg("p_LP"),
           "position Jacobian of point p_LP fixed on `link` (name or index), shape [3, nq]")
      .def("capsules", [](RobotHandle& r, const py::handle& q) { return WorldCapsules(r, q, r.robot->capsules); },
           py::arg("q"),
           "the collision capsules in the world (what obstacles, the floor, the RMPs and the agents see): rows "
           "[a_x, a_y, a_z, b_x, b_y, b_z, radius]")
      .def("self_collision_capsules",
           [](RobotHandle& r, const py::handle& q) { return WorldCapsules(r, q, r.robot->self_collision_capsules()); },
           py::arg("q"),
           "the capsules checked for self-collision in the world, rows as capsules(q): the collision YAML's "
           "self_collision_capsules, or the capsules themselves when it has none")
      .def("__repr__", [](const RobotHandle& r) {
        return fmt::format("Robot('{}', nq={}, capsules={})", r.robot->name, r.robot->model.nq(),
                           r.robot->capsules.size());
      });

  m.def("shipped_robots", &kinematics::ShippedRobotNames, "the shipped arms' names (models/robots/)");
}

}  // namespace rmpmarl::python
