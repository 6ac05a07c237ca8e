// rmpmarl.Controller: the learned agents of a controller file or RMPflow behind C++'s one controller interface
// (control::AccelerationPolicy driven by control::ReactiveController): joint state, target and obstacles in, joint
// accelerations (or the integrated joint commands) out.
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <filesystem>
#include <limits>
#include <optional>

#include "bindings.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/control/cloud_io.h"
#include "rmpmarl/control/cloud_obstacles.h"
#include "rmpmarl/control/learned_controller.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/rmp/rmpflow.h"
#include "rmpmarl/rmp/scene.h"
#include "rmpmarl/control/controller.h"
#include "rmpmarl/planning/plan_follow.h"
#include "rmpmarl/sim/world.h"

namespace rmpmarl::python {
namespace {

namespace fs = std::filesystem;

struct ControllerHandle {
  std::shared_ptr<RobotHandle> robot;
  std::shared_ptr<const sim::WorldModel> world;  // the robot the policy references, and the servo model
  std::unique_ptr<control::ReactiveController> controller;
  control::LearnedController* learned = nullptr;  // owned by controller; null for RMPflow
  const planning::PlanFollowPolicy* follower = nullptr;  // owned by controller; null unless plan_and_react
  rmp::Scene scene;
  int max_obstacles = 0;
  // the point cloud's obstacles (made at the first cloud): the last cloud's stay until a new one or clear_cloud()
  std::unique_ptr<control::CloudObstacles> cloud;
  control::CloudObstacleOptions cloud_options;
  long steps = 0;  // control decisions, the cloud's clock when no cloud_time is given
  Eigen::VectorXd qdd;
  std::string file;
};


void CheckMaxObstacles(int max_obstacles) {
  if (max_obstacles < 0 || max_obstacles > 4096) {
    BadArgument(fmt::format("max_obstacles: expected 0 ... 4096, got {}", max_obstacles));
  }
}

std::shared_ptr<ControllerHandle> Finish(std::shared_ptr<ControllerHandle> h,
                                         std::unique_ptr<control::AccelerationPolicy> policy,
                                         const control::ControllerOptions& options) {
  h->controller = std::make_unique<control::ReactiveController>(h->world->servos(), std::move(policy), options);
  h->scene.obstacles.reserve(h->max_obstacles);
  h->qdd.setZero(h->world->nq());
  return h;
}

// a controller handle not yet finished, with the policy and controller options to finish it with
struct Unfinished {
  std::shared_ptr<ControllerHandle> handle;
  std::unique_ptr<control::AccelerationPolicy> policy;
  control::ControllerOptions options;
};

Unfinished LearnedParts(const std::string& path, const py::handle& robot, int max_obstacles,
                        std::optional<double> floor_height) {
  if (!fs::is_regular_file(path)) FileNotFound(path, "policy_file", "a controller file (.rmpp)");
  CheckMaxObstacles(max_obstacles);
  const control::PolicyFile file = control::LoadPolicyFile(path);
  auto h = std::make_shared<ControllerHandle>();
  h->robot = RobotOf(robot, rl::PolicyTaskConfig(file, path).robot);
  h->world = std::make_shared<const sim::WorldModel>(*h->robot->robot);
  h->max_obstacles = max_obstacles;
  h->file = path;
  control::LearnedControllerOptions options;
  options.max_obstacles = max_obstacles;
  options.name = fs::path(path).stem().string();
  if (floor_height) options.floor_height = *floor_height;
  std::unique_ptr<control::LearnedController> learned = control::MakeLearnedController(h->world->robot(), file, path, options);
  h->learned = learned.get();
  const control::ControllerOptions controller_options = learned->controller_options();
  return {h, std::move(learned), controller_options};
}

Unfinished RmpflowParts(const py::handle& robot, int max_obstacles, const std::optional<std::string>& config) {
  CheckMaxObstacles(max_obstacles);
  if (robot.is_none()) BadArgument("robot: expected an rmpmarl.Robot, a robot name or a .urdf path, got None");
  if (config && !fs::is_regular_file(*config)) FileNotFound(*config, "config", "an RMPflow YAML file");
  auto h = std::make_shared<ControllerHandle>();
  h->robot = RobotOf(robot, "");
  h->world = std::make_shared<const sim::WorldModel>(*h->robot->robot);
  h->max_obstacles = max_obstacles;
  const kinematics::Robot& r = h->world->robot();
  const rmp::RmpflowOptions options = config ? rmp::LoadRmpflowOptions(*config) : rmp::LoadRmpflowOptions(r);
  h->file = config ? *config : rmp::RmpflowConfigPath(r).string();
  return {h, std::make_unique<control::RmpflowAccelerationPolicy>(r, options, max_obstacles), {}};
}

std::shared_ptr<ControllerHandle> LoadController(const std::string& path, const py::handle& robot, int max_obstacles,
                                                 std::optional<double> floor_height) {
  Unfinished u = LearnedParts(path, robot, max_obstacles, floor_height);
  return Finish(u.handle, std::move(u.policy), u.options);
}

std::shared_ptr<ControllerHandle> MakeRmpflow(const py::handle& robot, int max_obstacles,
                                              const std::optional<std::string>& config) {
  Unfinished u = RmpflowParts(robot, max_obstacles, config);
  return Finish(u.handle, std::move(u.policy), u.options);
}

/// the plan follower's state for update()'s info (see its doc).
py::dict PlanInfo(const planning::PlanFollowPolicy& follower) {
  const planning::PlanFollowStats& s = follower.stats();
  py::dict plan;
  plan["status"] = planning::PlanOutcomeName(s.last_outcome);
  plan["in_flight"] = follower.planning();
  plan["following"] = !follower.path().empty();
  plan["attempts"] = s.plans_attempted;
  plan["succeeded"] = s.plans_succeeded;
  plan["planning_ms"] = s.planning_times_s.empty() ? std::numeric_limits<double>::quiet_NaN()
                                                   : 1e3 * s.planning_times_s.back();
  plan["path_length"] = follower.path_length();
  py::dict replans;
  replans["stalled"] = s.replans_stalled;
  replans["blocked"] = s.replans_blocked;
  replans["goal_moved"] = s.replans_moved;
  plan["replans"] = replans;
  return plan;
}

/// fills h.scene from the keyword arguments (ValueError naming the argument; the policy is not called then).
void FillScene(ControllerHandle& h, const py::array& q, const py::handle& target, const py::handle& target_velocity,
               const py::handle& spheres, const py::handle& sphere_velocities, const py::handle& boxes,
               const py::handle& box_velocities, const py::handle& box_rotations, const py::handle& cylinders,
               const py::handle& cylinder_velocities, const py::handle& cylinder_rotations,
               const py::handle& joint_target, const py::handle& joint_target_velocity,
               const py::handle& joint_target_acceleration, const py::handle& cloud,
               const py::handle& cloud_time) {
  rmp::Scene& s = h.scene;
  // a new cloud (base frame, [N, 3]; NaN rows are dropped and counted): its obstacles replace the last cloud's
  if (!cloud.is_none()) {
    const py::array c = CheckedArray(cloud, {.name = "cloud", .shape = {-1, 3}, .finite = false});
    double time = static_cast<double>(h.steps) * h.controller->control_period();
    if (!cloud_time.is_none()) time = cloud_time.cast<double>();
    if (!h.cloud) {
      h.cloud_options.max_obstacles = std::max(1, std::min(h.cloud_options.max_obstacles, h.max_obstacles));
      h.cloud = std::make_unique<control::CloudObstacles>(h.world->robot(), h.cloud_options);
    }
    const Eigen::Map<const Eigen::Matrix3Xd> p_B(static_cast<const double*>(c.data()), 3, c.shape(0));
    h.cloud->UpdateInBaseFrame(p_B, time, AsVector(q));
  } else if (!cloud_time.is_none()) {
    BadArgument("cloud_time: given without cloud");
  }
  const py::array sph = spheres.is_none() ? py::array() : CheckedArray(spheres, {.name = "spheres", .shape = {-1, 4}});
  const py::array box = boxes.is_none() ? py::array() : CheckedArray(boxes, {.name = "boxes", .shape = {-1, 6}});
  const py::array cyl = cylinders.is_none() ? py::array()
                                            : CheckedArray(cylinders, {.name = "cylinders", .shape = {-1, 5}});
  // an absent argument is an empty array (py::array() holds a 0-size array, not a null handle)
  const py::ssize_t ns = sph.ndim() == 2 ? sph.shape(0) : 0, nb = box.ndim() == 2 ? box.shape(0) : 0;
  const py::ssize_t ny = cyl.ndim() == 2 ? cyl.shape(0) : 0;
  const py::ssize_t nc = h.cloud ? h.cloud->num_obstacles() : 0;
  if (ns + nb + ny + nc > h.max_obstacles) {
    BadArgument(fmt::format("spheres, boxes, cylinders, cloud: expected at most max_obstacles = {} obstacles in all, "
                            "got {} + {} + {} + {} (make the controller with a larger max_obstacles)", h.max_obstacles,
                            ns, nb, ny, nc));
  }
  auto optional = [](const py::handle& obj, const char* name, std::vector<py::ssize_t> shape, const char* needs,
                     py::ssize_t count) {
    if (obj.is_none()) return py::array();
    if (count == 0) BadArgument(fmt::format("{}: given without {}", name, needs));
    return CheckedArray(obj, {.name = name, .shape = std::move(shape)});
  };
  const py::array sv = optional(sphere_velocities, "sphere_velocities", {ns, 3}, "spheres", ns);
  const py::array bv = optional(box_velocities, "box_velocities", {nb, 3}, "boxes", nb);
  const py::array br = optional(box_rotations, "box_rotations", {nb, 3, 3}, "boxes", nb);
  const py::array yv = optional(cylinder_velocities, "cylinder_velocities", {ny, 3}, "cylinders", ny);
  const py::array yr = optional(cylinder_rotations, "cylinder_rotations", {ny, 3, 3}, "cylinders", ny);
  const py::array jt = joint_target.is_none()
                           ? py::array()
                           : CheckedArray(joint_target, {.name = "joint_target", .shape = {h.controller->nq()}});
  const py::array jv = joint_target_velocity.is_none()
                           ? py::array()
                           : CheckedArray(joint_target_velocity,
                                          {.name = "joint_target_velocity", .shape = {h.controller->nq()}});
  if (jv.size() > 0 && jt.size() == 0) BadArgument("joint_target_velocity: given without joint_target");
  const py::array ja = joint_target_acceleration.is_none()
                           ? py::array()
                           : CheckedArray(joint_target_acceleration,
                                          {.name = "joint_target_acceleration", .shape = {h.controller->nq()}});
  if (ja.size() > 0 && jv.size() == 0) {
    BadArgument("joint_target_acceleration: given without joint_target_velocity");
  }
  const py::array t = target.is_none() ? py::array() : CheckedArray(target, {.name = "target", .shape = {3}});
  const py::array tv = target_velocity.is_none() ? py::array()
                                                 : CheckedArray(target_velocity, {.name = "target_velocity", .shape = {3}});
  if (tv.size() > 0 && t.size() == 0) BadArgument("target_velocity: given without target");

  // rebuilt at every call in the controller's own buffer (reserved for max_obstacles: no allocation); a call that
  // raises leaves it for the next call to overwrite and steps nothing
  s.obstacles.clear();
  if (h.cloud) h.cloud->FillScene(&s);  // the cloud's clusters first, then the given shapes
  const double* ps = static_cast<const double*>(sph.data());
  const double* pb = static_cast<const double*>(box.data());
  auto vec3 = [](const py::array& a, py::ssize_t i) {
    return a.size() > 0 ? Eigen::Vector3d(static_cast<const double*>(a.data()) + 3 * i) : Eigen::Vector3d::Zero();
  };
  for (py::ssize_t i = 0; i < ns; ++i) {
    s.obstacles.push_back(rmp::Obstacle::MakeSphere(Eigen::Vector3d(ps + 4 * i), ps[4 * i + 3], vec3(sv, i)));
  }
  for (py::ssize_t i = 0; i < nb; ++i) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.translation() = Eigen::Vector3d(pb + 6 * i);
    if (br.size() > 0) {
      X.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
          static_cast<const double*>(br.data()) + 9 * i);
    }
    s.obstacles.push_back(rmp::Obstacle::MakeBox(X, Eigen::Vector3d(pb + 6 * i + 3), vec3(bv, i)));
  }
  const double* py_ = static_cast<const double*>(cyl.data());
  for (py::ssize_t i = 0; i < ny; ++i) {
    Eigen::Isometry3d X = Eigen::Isometry3d::Identity();
    X.translation() = Eigen::Vector3d(py_ + 5 * i);
    if (yr.size() > 0) {
      X.linear() = Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(
          static_cast<const double*>(yr.data()) + 9 * i);
    }
    s.obstacles.push_back(rmp::Obstacle::MakeCylinder(X, py_[5 * i + 3], py_[5 * i + 4], vec3(yv, i)));
  }
  // the joint-space goal: the C-space target of the controllers that pull toward a posture (an empty copy: none)
  if (jt.size() > 0) {
    s.q_T = AsVector(jt);
  } else {
    s.q_T.resize(0);
  }
  // its velocity (a reference moving along the user's own plan), tracked without lag
  if (jv.size() > 0) {
    s.qd_T = AsVector(jv);
  } else {
    s.qd_T.resize(0);
  }
  if (ja.size() > 0) {  // and its acceleration, fed forward
    s.qdd_T = AsVector(ja);
  } else {
    s.qdd_T.resize(0);
  }
  s.has_target = t.size() > 0;
  s.p_WT = s.has_target ? Eigen::Vector3d(static_cast<const double*>(t.data())) : Eigen::Vector3d::Zero();
  s.v_WT = tv.size() > 0 ? Eigen::Vector3d(static_cast<const double*>(tv.data())) : Eigen::Vector3d::Zero();
  rmp::ValidateScene(s, "scene");  // InputError reaches Python as ValueError
}

/// a copy of the learned agents' per-joint rows [nq, size / nq]; None for RMPflow (values == nullptr).
py::object PerJoint(const ControllerHandle& h, const std::vector<float>* values) {
  if (values == nullptr) return py::none();
  const py::ssize_t n = h.controller->nq();
  py::array_t<float> a({n, static_cast<py::ssize_t>(values->size()) / n});
  std::copy(values->begin(), values->end(), a.mutable_data());
  return py::object(a);
}

#define RMPMARL_SCENE_ARGS                                                                                  \
  py::kw_only(), py::arg("target") = py::none(), py::arg("target_velocity") = py::none(),                 \
      py::arg("spheres") = py::none(), py::arg("sphere_velocities") = py::none(), py::arg("boxes") = py::none(), \
      py::arg("box_velocities") = py::none(), py::arg("box_rotations") = py::none(), py::arg("cylinders") = py::none(), \
      py::arg("cylinder_velocities") = py::none(), py::arg("cylinder_rotations") = py::none(),                      \
      py::arg("joint_target") = py::none(), py::arg("joint_target_velocity") = py::none(),                      \
      py::arg("joint_target_acceleration") = py::none(), py::arg("cloud") = py::none(),                          \
      py::arg("cloud_time") = py::none()

constexpr const char* kSceneDoc = R"doc(
The scene (keyword-only, float64): target [3] (None: no target this step, the controller holds the end effector),
target_velocity [3]; spheres [K, 4] rows (x, y, z, radius) with sphere_velocities [K, 3]; boxes [K, 6] rows
(centre x, y, z, half sizes x, y, z) with box_velocities [K, 3] and box_rotations [K, 3, 3] (default identity);
cylinders [K, 5] rows (centre x, y, z, radius, half length) with cylinder_velocities [K, 3] and cylinder_rotations
[K, 3, 3] (default identity; the axis is the rotation's third column). All in the robot's base frame, metres and m/s; at
most max_obstacles obstacles in all. joint_target [nq]: a joint-space goal, the posture RMPflow's C-space target (and
the learned layer's) pulls toward instead of the home posture; give the end effector at it as the target too;
joint_target_velocity [nq]: its velocity, for a joint_target that moves along a plan (damped relative to it, so it is
tracked without lag); joint_target_acceleration [nq]: its acceleration, where the plan speeds up or slows down (fed
forward, so the arm does not trail it).
cloud [N, 3]: a sensor's point cloud in the base frame (rows with NaN are dropped), taken at cloud_time [s] (default:
the controller's own clock). It is cropped, downsampled to voxels, cleared of the robot's own points, clustered into
point-set obstacles and tracked for their velocities (docs/perception.md); its obstacles stay until the next cloud or
clear_cloud(). Give a cloud when the sensor has a new frame, not at every step.)doc";

}  // namespace

std::shared_ptr<RobotHandle> RobotOf(const py::handle& robot, const std::string& fallback) {
  if (robot.is_none()) return LoadRobotArgument(fallback);
  if (py::isinstance<RobotHandle>(robot)) return robot.cast<std::shared_ptr<RobotHandle>>();
  if (py::isinstance<py::str>(robot)) return LoadRobotArgument(robot.cast<std::string>());
  BadArgument(fmt::format("robot: expected an rmpmarl.Robot, a robot name or a .urdf path, got {}",
                          std::string(py::str(py::type::of(robot).attr("__name__")))));
}

void BindControllerMakers(py::module_& m);

void BindControllers(py::module_& m) {
  py::class_<ControllerHandle, std::shared_ptr<ControllerHandle>>(m, "Controller", R"doc(
A reactive controller: the learned per-joint agents of a controller file (rmpmarl.load_controller) or RMPflow
(rmpmarl.rmpflow), the same interface as C++'s control::AccelerationPolicy inside a control::ReactiveController.

accelerations(q, qd, ...) returns the policy's joint accelerations q̈ at (q, q̇); update(q, qd, ...) runs one whole
control step at control_rate (the decision on the measured state, `substeps` integration substeps of the commanded
state) and returns the commanded joint positions and velocities for a position/velocity interface. Call reset(q, qd)
at the start of every run. Not thread-safe: one controller per thread.)doc")
      .def_property_readonly("name", [](const ControllerHandle& h) { return h.controller->policy().name(); })
      .def_property_readonly("nq", [](const ControllerHandle& h) { return h.controller->nq(); })
      .def_property_readonly("robot", [](const ControllerHandle& h) { return h.robot; })
      .def_property_readonly("file", [](const ControllerHandle& h) { return h.file; },
                             "the controller file (learned) or the RMPflow YAML it was made from")
      .def_property_readonly("learned", [](const ControllerHandle& h) { return h.learned != nullptr; })
      .def_property_readonly("max_obstacles", [](const ControllerHandle& h) { return h.max_obstacles; })
      .def_property_readonly("control_rate", [](const ControllerHandle& h) { return 1.0 / h.controller->control_period(); },
                             "[Hz] the rate update() is meant to be called at (the learned agents' training rate)")
      .def_property_readonly("substeps", [](const ControllerHandle& h) { return h.controller->substeps(); })
      .def("reset", [](ControllerHandle& h, const py::handle& q, const py::handle& qd) {
        const int n = h.controller->nq();
        const py::array qa = CheckedArray(q, {.name = "q", .shape = {n}});
        py::array qda = qd.is_none() ? py::array(py::array_t<double>(n)) : CheckedArray(qd, {.name = "qd", .shape = {n}});
        if (qd.is_none()) std::fill_n(static_cast<double*>(qda.mutable_data()), n, 0.0);
        h.controller->Reset(AsVector(qa), AsVector(qda));
      }, py::arg("q"), py::arg("qd") = py::none(), "starts a run at the measured state (q̇ default 0)")
      .def("accelerations", [](ControllerHandle& h, const py::handle& q, const py::handle& qd, const py::handle& target,
                               const py::handle& target_velocity, const py::handle& spheres,
                               const py::handle& sphere_velocities, const py::handle& boxes,
                               const py::handle& box_velocities, const py::handle& box_rotations,
                               const py::handle& cylinders, const py::handle& cylinder_velocities,
                               const py::handle& cylinder_rotations, const py::handle& joint_target,
                               const py::handle& joint_target_velocity, const py::handle& joint_target_acceleration,
                               const py::handle& cloud,
                               const py::handle& cloud_time, bool decide) {
        const int n = h.controller->nq();
        const py::array qa = CheckedArray(q, {.name = "q", .shape = {n}});
        const py::array qda = CheckedArray(qd, {.name = "qd", .shape = {n}});
        FillScene(h, qa, target, target_velocity, spheres, sphere_velocities, boxes, box_velocities, box_rotations,
                  cylinders, cylinder_velocities, cylinder_rotations, joint_target, joint_target_velocity,
                  joint_target_acceleration, cloud,
                  cloud_time);
        if (decide) ++h.steps;
        {
          py::gil_scoped_release release;
          control::AccelerationPolicy& policy = h.controller->policy();
          if (decide) policy.BeginControlStep(AsVector(qa), AsVector(qda), h.scene);
          policy.Evaluate(AsVector(qa), AsVector(qda), h.scene, h.qdd);
        }
        return VectorToNumpy(h.qdd);
      }, py::arg("q"), py::arg("qd"), RMPMARL_SCENE_ARGS, py::arg("decide") = true,
           (std::string("q̈ [nq] at (q, q̇). decide=True: the learned agents first decide on this state (once per control "
                        "period); False: the basic layer with the last decision (integration substeps). RMPflow "
                        "ignores it. A non-finite q̈ is returned as it is (the C++ controller catches it).") +
            kSceneDoc).c_str())
      .def("update", [](ControllerHandle& h, const py::handle& q, const py::handle& qd, const py::handle& target,
                        const py::handle& target_velocity, const py::handle& spheres,
                        const py::handle& sphere_velocities, const py::handle& boxes, const py::handle& box_velocities,
                        const py::handle& box_rotations, const py::handle& cylinders,
                        const py::handle& cylinder_velocities, const py::handle& cylinder_rotations,
                        const py::handle& joint_target, const py::handle& joint_target_velocity,
                        const py::handle& joint_target_acceleration, const py::handle& cloud,
                        const py::handle& cloud_time) {
        const int n = h.controller->nq();
        const py::array qa = CheckedArray(q, {.name = "q", .shape = {n}});
        const py::array qda = CheckedArray(qd, {.name = "qd", .shape = {n}});
        FillScene(h, qa, target, target_velocity, spheres, sphere_velocities, boxes, box_velocities, box_rotations,
                  cylinders, cylinder_velocities, cylinder_rotations, joint_target, joint_target_velocity,
                  joint_target_acceleration, cloud,
                  cloud_time);
        ++h.steps;
        control::ControlStepResult r;
        {
          py::gil_scoped_release release;
          r = h.controller->Update(AsVector(qa), AsVector(qda), h.scene);
        }
        py::dict info;
        info["finite"] = r.finite;
        info["resynced"] = r.resynced;
        info["position_clamps"] = r.position_clamps;
        info["velocity_clamps"] = r.velocity_clamps;
        info["compute_us"] = r.compute_us;
        info["qdd_cmd"] = VectorToNumpy(h.controller->qdd_cmd());
        if (h.follower != nullptr) info["plan"] = PlanInfo(*h.follower);
        return py::make_tuple(VectorToNumpy(h.controller->q_cmd()), VectorToNumpy(h.controller->qd_cmd()), info);
      }, py::arg("q"), py::arg("qd"), RMPMARL_SCENE_ARGS,
           (std::string("one control step: returns (q_cmd [nq], qd_cmd [nq], info). A non-finite q̈ holds position "
                        "(info['finite'] False); info['qdd_cmd'] is the commanded acceleration over the period (for a "
                        "torque or inverse-dynamics feed-forward). plan_and_react adds info['plan']: 'status' of the "
                        "last attempt ('not yet', 'planned', 'no goal configuration', 'goal in collision', 'no path "
                        "within the budget'), 'following' (a path is being followed; False: the reactive layer goes "
                        "for the goal alone), 'in_flight' (a plan is running beside the loop), 'attempts', 'succeeded', "
                        "'planning_ms' (the last finished attempt; NaN: none), "
                        "'path_length' (of the path followed, joint space [rad or m]; 0: none) and 'replans' "
                        "(stalled, blocked, goal moved).") + kSceneDoc).c_str())
      .def("clear_cloud", [](ControllerHandle& h) {
        if (h.cloud) h.cloud->Reset();
      }, "forgets the last cloud's obstacles and tracks")
      .def("set_cloud_options", [](ControllerHandle& h, double voxel_size, double self_filter_margin,
                                   double point_margin, int min_cluster_voxels, int max_obstacles,
                                   const py::handle& workspace) {
        control::CloudObstacleOptions o = h.cloud_options;
        o.voxel_size = voxel_size;
        o.self_filter_margin = self_filter_margin;
        o.point_margin = point_margin;
        o.min_cluster_voxels = min_cluster_voxels;
        o.max_obstacles = max_obstacles;
        if (!workspace.is_none()) {
          const py::array w = CheckedArray(workspace, {.name = "workspace", .shape = {2, 3}});
          const double* d = static_cast<const double*>(w.data());
          o.workspace = Eigen::AlignedBox3d(Eigen::Vector3d(d), Eigen::Vector3d(d + 3));
        }
        control::ValidateCloudObstacleOptions(o);
        if (max_obstacles > h.max_obstacles) {
          BadArgument(fmt::format("max_obstacles: expected at most the controller's max_obstacles = {}, got {}",
                                  h.max_obstacles, max_obstacles));
        }
        h.cloud_options = o;
        h.cloud.reset();
      }, py::kw_only(), py::arg("voxel_size") = 0.02, py::arg("self_filter_margin") = 0.01,
         py::arg("point_margin") = control::CloudObstacleOptions{}.point_margin, py::arg("min_cluster_voxels") = 2, py::arg("max_obstacles") = 8,
         py::arg("workspace") = py::none(),
         "how clouds become obstacles: voxel size [m], the self filter's margin [m], the margin added to each "
         "point's radius (half a voxel) [m], the smallest cluster [voxels], "
         "obstacle slots for the cloud, workspace [[xmin, ymin, zmin], [xmax, ymax, zmax]] in the world frame (default: "
         "everything within the arm's reach of its base, above and below it; cloud_stats says what was cropped). "
         "Forgets the last cloud.")
      .def_property_readonly("cloud_stats", [](const ControllerHandle& h) {
        py::dict d;
        if (!h.cloud) return d;
        const control::CloudUpdateStats& s = h.cloud->stats();
        d["input_points"] = s.input_points;
        d["nonfinite_points"] = s.nonfinite_points;
        d["outside_points"] = s.outside_points;
        d["robot_voxels"] = s.robot_voxels;
        d["voxels"] = s.voxels;
        d["clusters"] = s.clusters;
        d["merged_clusters"] = s.merged_clusters;
        const Eigen::AlignedBox3d& w = h.cloud->workspace();
        d["workspace"] = py::make_tuple(VectorToNumpy(w.min()), VectorToNumpy(w.max()));
        return d;
      }, "what the last cloud became: points in, dropped as non-finite or outside the workspace crop (the box, "
         "world frame), voxels, the robot's own voxels, clusters; {} before the first cloud")
      .def_property_readonly("cloud_points", [](const ControllerHandle& h) {
        py::array_t<double> a({h.cloud ? static_cast<py::ssize_t>(h.cloud->points().cols()) : 0, py::ssize_t{3}});
        if (h.cloud && h.cloud->points().cols() > 0) {
          std::copy_n(h.cloud->points().data(), h.cloud->points().size(), a.mutable_data());
        }
        return a;
      }, "the last cloud's kept points [M, 3] in the world frame (voxel centroids off the robot), a copy")
      .def_property_readonly("cloud_obstacles", [](const ControllerHandle& h) {
        py::list out;
        if (!h.cloud) return out;
        for (const control::CloudCluster& c : h.cloud->clusters()) {
          py::dict d;
          d["centroid"] = VectorToNumpy(Eigen::VectorXd(c.centroid_W));
          d["velocity"] = VectorToNumpy(Eigen::VectorXd(c.v_WO));
          d["voxels"] = c.voxels;
          d["track"] = c.track;
          out.append(d);
        }
        return out;
      }, "the last cloud's obstacles: dicts of centroid [3], tracked velocity [3] (world frame), voxels, track id")
      .def_property_readonly("observations", [](const ControllerHandle& h) {
        return PerJoint(h, h.learned ? &h.learned->observations() : nullptr);
      }, "learned: the agents' local observations of the last decision [nq, obs_dim] (a copy); None for RMPflow")
      .def_property_readonly("actions", [](const ControllerHandle& h) {
        return PerJoint(h, h.learned ? &h.learned->actions() : nullptr);
      }, "learned: the agents' actions [nq, action_size] (a copy), each row from the last decision that read that agent's "
         "action (the network runs only then: with held parameters most control steps read none); None for RMPflow")
      .def("__repr__", [](const ControllerHandle& h) {
        return fmt::format("Controller('{}' on {}, {} Hz)", h.controller->policy().name(), h.robot->robot->name,
                           1.0 / h.controller->control_period());
      });
  BindControllerMakers(m);
}

// plan, then react: RRT-Connect's joint path followed by RMPflow ("rmpflow") or a controller file's learned agents
std::shared_ptr<ControllerHandle> MakePlanAndReact(const py::handle& robot, const std::string& layer,
                                                   int max_obstacles, double planning_budget, int planning_iterations,
                                                   double safety_margin, std::uint64_t seed,
                                                   std::optional<double> floor_height, bool plan_beside_loop) {
  CheckMaxObstacles(max_obstacles);
  if (floor_height && !std::isfinite(*floor_height)) {
    BadArgument(fmt::format("floor_height: expected a finite height [m] or None, got {}", *floor_height));
  }
  if (layer != "rmpflow" && !fs::is_regular_file(layer)) {
    FileNotFound(layer, "layer", "'rmpflow' or a controller file (.rmpp)");
  }
  // the layer, put behind the plan follower before its controller is made
  Unfinished u = layer == "rmpflow" ? RmpflowParts(robot, max_obstacles, std::nullopt)
                                    : LearnedParts(layer, robot, max_obstacles, std::nullopt);
  planning::PlanFollowOptions plan;
  plan.planner.planning_time_budget = planning_budget;
  plan.planner.planning_iterations = planning_iterations;
  plan.planner.safety_margin = safety_margin;
  plan.planner.seed = seed;
  // the planner keeps the arm above a floor only when the user puts one there (a cell has its own surfaces, and a
  // box below the base would otherwise make every goal beside it unplannable)
  plan.planner.check_floor = floor_height.has_value();
  plan.planner.floor_height = floor_height.value_or(0.0);
  plan.plan_beside_loop = plan_beside_loop;
  auto follower = planning::MakePlanFollower(u.handle->world->robot(), std::move(u.policy), u.options, plan);
  u.handle->follower = follower.get();
  u.handle->file = layer;
  return Finish(u.handle, std::move(follower), u.options);
}

// the functions that make controllers (and read the clouds they take)
void BindControllerMakers(py::module_& m) {
  m.def("load_controller", &LoadController, py::arg("policy_file"), py::arg("robot") = py::none(),
        py::arg("max_obstacles") = 16, py::arg("floor_height") = py::none(),
        "the learned controller of a controller file (.rmpp) on `robot` (an rmpmarl.Robot, a name or a .urdf path; "
        "default: the robot the file was trained on). floor_height: a floor plane z = h the agents see (default none, "
        "as in training).");
  m.def("read_point_cloud", [](const std::string& path) {
    const control::PointCloudFile f = control::ReadPointCloud(path);
    py::array_t<double> a({static_cast<py::ssize_t>(f.points.cols()), py::ssize_t{3}});
    if (f.points.size() > 0) std::copy_n(f.points.data(), f.points.size(), a.mutable_data());
    return a;
  }, py::arg("path"), "the points [N, 3] of a .ply or .pcd file (ascii or binary; PCD also binary_compressed), in the "
                      "file's frame and units; points with NaN are dropped");
  m.def("rmpflow", &MakeRmpflow, py::arg("robot"), py::arg("max_obstacles") = 16, py::arg("config") = py::none(),
        "RMPflow on `robot` with its configs/rmpflow settings (or `config`, an RMPflow YAML)");
  m.def("plan_and_react", &MakePlanAndReact, py::arg("robot"), py::arg("layer") = "rmpflow",
        py::arg("max_obstacles") = 16, py::arg("planning_budget") = 1.0, py::arg("planning_iterations") = 0,
        py::arg("safety_margin") = 0.01, py::arg("seed") = 0, py::arg("floor_height") = py::none(),
        py::arg("plan_beside_loop") = false,
        "plan, then react (docs/benchmarks.md): a global joint path (RRT-Connect on the capsule model, shortcut) to "
        "the scene's joint_target (or an IK solution of its target), followed by the reactive layer — 'rmpflow' or a "
        "controller file's learned agents — which dodges what moves; replans when progress stalls or the path is "
        "blocked. planning_budget [s] and planning_iterations (0: no cap) end a search; safety_margin [m] is the "
        "planner's clearance. floor_height: a floor plane z = h [m] the planner keeps the arm above (default none: "
        "only the scene's obstacles, as benchmark mbm plans; give the table's height when the arm stands on one). "
        "plan_beside_loop: plans run on a worker thread, so no update() waits for one (the layer goes for the scene's "
        "goal, or keeps to the old path, until the plan is ready; runs are then not reproducible); False: the update() "
        "that plans returns after the plan. update()'s info['plan'] says whether a path is followed and why not, and "
        "'in_flight' whether a plan is running beside the loop. The same Controller interface as "
        "rmpflow() and load_controller().");
}

}  // namespace rmpmarl::python
