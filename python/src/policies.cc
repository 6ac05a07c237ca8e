// rmpmarl.Policy: a controller file's actor through the torch-free runtime (control::PolicyRuntime), acting on a batch of
// local observations; its card, task and provenance.
#include <fmt/format.h>
#include <pybind11/stl.h>

#include <filesystem>

#include "bindings.h"
#include "rmpmarl/control/policy_file.h"
#include "rmpmarl/rl/policy_task.h"
#include "rmpmarl/control/policy_runtime.h"

namespace rmpmarl::python {
namespace {

namespace fs = std::filesystem;

struct PolicyHandle {
  std::string path;
  control::PolicyFile file;
  std::unique_ptr<control::PolicyRuntime> runtime;  // sized for the largest batch seen
};

std::unique_ptr<PolicyHandle> LoadPolicy(const std::string& path) {
  if (!fs::is_regular_file(path)) FileNotFound(path, "policy_file", "a controller file (.rmpp)");
  auto h = std::make_unique<PolicyHandle>();
  h->path = path;
  h->file = control::LoadPolicyFile(path);
  h->runtime = std::make_unique<control::PolicyRuntime>(h->file.weights, 16);
  return h;
}

/// rows of `obs` (float32 [B, obs_dim]) through the runtime in chunks of its capacity into `out` (B × width).
template <typename F>
py::array_t<float> Batched(PolicyHandle& h, const py::handle& obs, int width, F&& f) {
  const control::PolicyWeights& w = h.file.weights;
  const py::array a = CheckedArray(obs, {.name = "obs", .shape = {-1, w.obs_dim}, .float32 = true});
  const py::ssize_t rows = a.shape(0);
  py::array_t<float> out({rows, static_cast<py::ssize_t>(width)});
  const float* in = static_cast<const float*>(a.data());
  float* o = out.mutable_data();
  {
    py::gil_scoped_release release;
    const int chunk = h.runtime->max_agents();
    for (py::ssize_t r = 0; r < rows; r += chunk) {
      const int n = static_cast<int>(std::min<py::ssize_t>(chunk, rows - r));
      f(*h.runtime, in + r * w.obs_dim, n, o + r * width);
    }
  }
  return out;
}

}  // namespace

void BindPolicies(py::module_& m) {
  py::class_<PolicyHandle>(m, "Policy", R"doc(
The actor of a controller file (.rmpp), evaluated without libtorch: deterministic actions for a batch of local
observations, in the environments' action layout (option index as a float, continuous values, termination flag).
Not thread-safe: one Policy per thread.)doc")
      .def(py::init(&LoadPolicy), py::arg("policy_file"))
      .def_property_readonly("path", [](const PolicyHandle& h) { return h.path; })
      .def_property_readonly("obs_dim", [](const PolicyHandle& h) { return h.file.weights.obs_dim; })
      .def_property_readonly("action_size", [](const PolicyHandle& h) { return h.file.weights.action_size(); })
      .def_property_readonly("head_size", [](const PolicyHandle& h) { return h.file.weights.head_size(); })
      .def_property_readonly("num_options", [](const PolicyHandle& h) { return h.file.weights.num_options; })
      .def_property_readonly("task_yaml", [](const PolicyHandle& h) { return h.file.task_yaml; },
                             "the task the controller runs on (YAML; '' when the file carries none)")
      .def_property_readonly("provenance_yaml", [](const PolicyHandle& h) { return h.file.provenance_yaml; })
      .def_property_readonly("card", [](const PolicyHandle& h) { return rl::PolicyCard(h.file, h.path); },
                             "the card `rmpmarl policy show` prints")
      .def("act", [](PolicyHandle& h, const py::handle& obs) {
        return Batched(h, obs, h.file.weights.action_size(),
                       [](control::PolicyRuntime& r, const float* o, int n, float* out) { r.Act(o, n, out); });
      }, py::arg("obs"), "deterministic actions float32 [B, action_size] for observations float32 [B, obs_dim]")
      .def("head", [](PolicyHandle& h, const py::handle& obs) {
        return Batched(h, obs, h.file.weights.head_size(),
                       [](control::PolicyRuntime& r, const float* o, int n, float* out) { r.EvaluateHead(o, n, out); });
      }, py::arg("obs"), "the network's raw outputs [B, head_size]: option logits, means, termination logit")
      .def("__repr__", [](const PolicyHandle& h) {
        return fmt::format("Policy('{}', obs_dim={}, action_size={})", h.path, h.file.weights.obs_dim,
                           h.file.weights.action_size());
      });
}

}  // namespace rmpmarl::python
