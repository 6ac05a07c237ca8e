// rmpmarl._core.VecEnv: the batched C++ engine (rl::VecEnv) over a task's manipulator envs, stepped with the GIL
// released; its batch buffers are exposed as read-only numpy views (rmpmarl/envs.py builds the Gymnasium-style and
// PettingZoo-style environments on it).
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <filesystem>
#include <limits>
#include <optional>

#include "bindings.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/rl/vec_env.h"
#include "rmpmarl/tasks/manipulator_env.h"
#include "rmpmarl/tasks/task_config.h"

namespace rmpmarl::python {
namespace {

namespace fs = std::filesystem;

struct EnvHandle {
  tasks::TaskConfig config;
  std::unique_ptr<rl::VecEnv> env;
  bool needs_reset = true;  // before the first reset, and after a step that raised
  bool seeded = false;
};

std::unique_ptr<EnvHandle> MakeEnv(const std::string& task, int num_envs, const std::optional<std::string>& robot,
                                   const std::optional<std::string>& collision,
                                   const std::optional<std::string>& interface, const std::string& overrides,
                                   int num_threads, std::uint64_t seed, const std::string& autoreset) {
  if (num_envs < 1 || num_envs > 65536) BadArgument(fmt::format("num_envs: expected 1 ... 65536, got {}", num_envs));
  if (num_threads < 1 || num_threads > 1024) {
    BadArgument(fmt::format("num_threads: expected 1 ... 1024, got {}", num_threads));
  }
  if (autoreset != "next-step" && autoreset != "same-step") {
    BadArgument(fmt::format("autoreset: expected 'next-step' or 'same-step', got '{}'", autoreset));
  }
  fs::path path;
  if (task.ends_with(".yaml") || task.ends_with(".yml")) {
    if (!fs::is_regular_file(task)) FileNotFound(task, "task", "a task YAML file");
    path = task;
  } else {
    const std::vector<std::string> names = tasks::TaskNames();
    if (std::find(names.begin(), names.end(), task) == names.end()) {
      BadArgument(fmt::format("task: expected one of {} or a task .yaml, got '{}'", fmt::join(names, ", "), task));
    }
    path = tasks::TaskConfigPath(task);
  }
  auto h = std::make_unique<EnvHandle>();
  h->config = overrides.empty() ? tasks::LoadTaskConfig(path) : tasks::LoadTaskConfig(path, overrides);
  if (robot) {
    if (tasks::IsUrdfPath(*robot) && !fs::is_regular_file(*robot)) FileNotFound(*robot, "robot", "a .urdf file");
    h->config.robot = *robot;
    h->config.collision = collision.value_or("");
  } else if (collision) {
    BadArgument("collision: given without robot (a .urdf path)");
  }
  if (collision && !fs::is_regular_file(*collision)) FileNotFound(*collision, "collision", "a collision YAML file");
  if (interface) h->config.interface = tasks::ParseInterfaceMode(*interface);
  tasks::ValidateTaskConfig(h->config, "make_vec_env");
  py::gil_scoped_release release;  // building the robot variants compiles MuJoCo models
  auto context = tasks::MakeTaskContext(h->config);
  rl::VecEnvOptions options{.num_envs = num_envs, .seed = seed, .num_threads = num_threads,
                            .autoreset = autoreset == "next-step" ? rl::Autoreset::kNextStep : rl::Autoreset::kSameStep};
  h->env = std::make_unique<rl::VecEnv>(tasks::MakeManipulatorEnvFactory(context), options);
  return h;
}

py::dict SpecDict(const EnvHandle& h) {
  const tasks::EnvSpec& s = h.env->spec();
  py::dict d;
  d["task"] = s.task;
  d["robot"] = h.config.robot;
  d["interface"] = std::string(tasks::InterfaceModeName(h.config.interface));
  d["num_envs"] = h.env->num_envs();
  d["num_agents"] = s.num_agents;
  d["local_obs_dim"] = s.local_obs_dim;
  d["local_obs_names"] = s.local_obs_names;
  d["global_state_dim"] = s.global_state_dim;
  d["global_state_names"] = s.global_state_names;
  d["reward_terms"] = s.reward_terms;
  d["discount"] = s.discount;
  d["max_episode_steps"] = s.max_episode_steps;
  d["control_dt"] = s.control_dt;
  py::dict a;
  a["size"] = s.action.size();
  a["num_options"] = s.action.num_options;
  a["option_names"] = s.action.option_names;
  a["num_continuous"] = s.action.num_continuous;
  a["continuous_names"] = s.action.continuous_names;
  a["continuous_offset"] = s.action.continuous_offset();
  a["low"] = s.action.low;
  a["high"] = s.action.high;
  a["has_termination"] = s.action.has_termination;
  d["action"] = a;
  d["autoreset"] = h.env->options().autoreset == rl::Autoreset::kNextStep ? "next-step" : "same-step";
  return d;
}

void RequireReset(const EnvHandle& h) {
  if (h.needs_reset) {
    throw py::value_error("step: the environments need reset() first (before the first step, and after a step that "
                          "raised)");
  }
}

}  // namespace

void BindEnvs(py::module_& m) {
  py::class_<EnvHandle>(m, "VecEnv", R"doc(
The batched C++ engine over N environments of a task (use rmpmarl.make_vec_env, which wraps it in Gymnasium's vector
conventions). The arrays it exposes are read-only numpy views onto its own buffers: they are overwritten by the next
step() or reset() and stay valid while this object lives.)doc")
      .def(py::init(&MakeEnv), py::arg("task"), py::arg("num_envs"), py::arg("robot") = py::none(),
           py::arg("collision") = py::none(), py::arg("interface") = py::none(), py::arg("overrides") = "",
           py::arg("num_threads") = 1, py::arg("seed") = 0, py::arg("autoreset") = "next-step")
      .def_property_readonly("spec", &SpecDict, "the batch layout: sizes, names, action layout, horizon, control_dt")
      .def_property_readonly("task_yaml", [](const EnvHandle& h) { return h.config.source; })
      .def("reset", [](EnvHandle& h, std::optional<std::uint64_t> seed) {
        {
          py::gil_scoped_release release;
          if (seed) {
            h.env->Reset(*seed);
          } else if (!h.seeded) {
            h.env->Reset();
          } else {
            h.env->ResetContinuing();
          }
        }
        h.seeded = true;
        h.needs_reset = false;
      }, py::arg("seed") = py::none(),
           "resets every env: with a seed, env k's RNG is seeded with seed + k; without one, the first reset uses the "
           "construction seed and later ones continue each env's RNG (new episodes)")
      .def("step", [](EnvHandle& h, const py::handle& actions) {
        RequireReset(h);
        const tasks::EnvSpec& s = h.env->spec();
        const py::array a = CheckedArray(actions, {.name = "actions",
                                                   .shape = {h.env->num_envs(), s.num_agents, s.action.size()},
                                                   .float32 = true});
        const float* p = static_cast<const float*>(a.data());
        h.needs_reset = true;  // cleared when the step returns: an exception leaves the batch to be reset
        {
          py::gil_scoped_release release;
          h.env->Step(p);
        }
        h.needs_reset = false;
      }, py::arg("actions"),
           "steps every env with actions float32 [num_envs, num_agents, action_size] (C-contiguous, finite). An env "
           "whose episode ended in the last step is reset instead (next-step autoreset) and ignores its action.")
      .def_property_readonly("obs", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        const tasks::EnvSpec& s = h.env->spec();
        return View(h.env->batch().local_obs.data(), {h.env->num_envs(), s.num_agents, s.local_obs_dim}, self);
      }, "float32 [num_envs, num_agents, local_obs_dim], a read-only view")
      .def_property_readonly("state", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        return View(h.env->batch().global_state.data(), {h.env->num_envs(), h.env->spec().global_state_dim}, self);
      }, "float32 [num_envs, global_state_dim] (the centralised critic's input), a read-only view")
      .def_property_readonly("rewards", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        return View(h.env->batch().reward.data(), {h.env->num_envs()}, self);
      }, "float32 [num_envs]: the team reward (the sum of reward_terms), a read-only view")
      .def_property_readonly("reward_terms", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        return View(h.env->batch().reward_terms.data(),
                    {h.env->num_envs(), static_cast<py::ssize_t>(h.env->spec().reward_terms.size())}, self);
      })
      .def_property_readonly("terminated", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        return View(reinterpret_cast<const bool*>(h.env->batch().terminated.data()), {h.env->num_envs()}, self);
      })
      .def_property_readonly("truncated", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        return View(reinterpret_cast<const bool*>(h.env->batch().truncated.data()), {h.env->num_envs()}, self);
      })
      .def_property_readonly("option_started", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        return View(h.env->batch().option_started.data(), {h.env->num_envs(), h.env->spec().num_agents}, self);
      }, "float32 [num_envs, num_agents]: 1 where the agent's action started a new option (per-joint-rmp)")
      .def_property_readonly("final_obs", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        const tasks::EnvSpec& s = h.env->spec();
        return View(h.env->batch().final_local_obs.data(), {h.env->num_envs(), s.num_agents, s.local_obs_dim}, self);
      }, "same-step autoreset only: the last observation of the envs whose episode ended in this step")
      .def_property_readonly("final_state", [](py::object self) {
        const EnvHandle& h = self.cast<const EnvHandle&>();
        return View(h.env->batch().final_global_state.data(), {h.env->num_envs(), h.env->spec().global_state_dim},
                    self);
      })
      .def("episode_metrics", [](const EnvHandle& h) {
        // per env, for the envs whose episode ended in the last step (mask "ended"); NaN / 0 elsewhere
        const rl::Batch& b = h.env->batch();
        const py::ssize_t n = h.env->num_envs();
        const double nan = std::numeric_limits<double>::quiet_NaN();
        py::array_t<bool> ended(n), success(n), invalid(n), reached(n);
        py::array_t<double> ret(n), tracking(n), settled(n), clearance(n), control_us(n), in_collision(n);
        py::array_t<std::int32_t> length(n), collisions(n);
        for (py::ssize_t k = 0; k < n; ++k) {
          const bool e = b.terminated[k] || b.truncated[k];
          const tasks::EpisodeMetrics& mt = b.metrics[k];
          ended.mutable_at(k) = e;
          success.mutable_at(k) = e && mt.success;
          invalid.mutable_at(k) = e && mt.invalid;
          reached.mutable_at(k) = e && mt.reached;
          ret.mutable_at(k) = e ? mt.episode_return : nan;
          tracking.mutable_at(k) = e ? mt.mean_tracking_error : nan;
          settled.mutable_at(k) = e ? mt.settled_tracking_error : nan;
          clearance.mutable_at(k) = e ? mt.min_clearance : nan;
          control_us.mutable_at(k) = e ? mt.mean_control_us : nan;
          in_collision.mutable_at(k) = e ? mt.time_in_collision : nan;
          length.mutable_at(k) = e ? mt.length : 0;
          collisions.mutable_at(k) = e ? mt.collisions : 0;
        }
        py::dict d;
        d["ended"] = ended;
        d["success"] = success;
        d["invalid"] = invalid;
        d["reached"] = reached;
        d["return"] = ret;
        d["length"] = length;
        d["collisions"] = collisions;
        d["tracking_error"] = tracking;
        d["settled_tracking_error"] = settled;
        d["min_clearance"] = clearance;
        d["time_in_collision"] = in_collision;
        d["control_us"] = control_us;
        return d;
      }, "the metrics of the episodes that ended in the last step, arrays [num_envs] with the mask 'ended'");

  m.def("task_names", &tasks::TaskNames, "the tasks make_vec_env knows (configs/tasks/)");
}

}  // namespace rmpmarl::python
