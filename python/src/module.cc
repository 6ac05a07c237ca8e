// rmpmarl._core: the compiled half of the Python package (python/rmpmarl/ is the other).
#include <pybind11/pybind11.h>

#include "bindings.h"
#include "rmpmarl/common/error.h"
#include "rmpmarl/kinematics/robot.h"

namespace py = pybind11;

PYBIND11_MODULE(_core, m) {
  m.doc() = "rmpmarl's C++ core: robots, controllers, the batched environments and the policy runtime";
  // bad input from C++ (a file's key, an out-of-range option) reaches Python as ValueError with its message
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const rmpmarl::InputError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    }
  });
  rmpmarl::python::BindRobot(m);
  rmpmarl::python::BindControllers(m);
  rmpmarl::python::BindEnvs(m);
  rmpmarl::python::BindPolicies(m);
  rmpmarl::python::BindScenes(m);
  m.def("models_directory", [] { return rmpmarl::kinematics::ModelsDirectory().string(); },
        "the shipped models (robots, policies); RMPMARL_MODELS_DIR overrides it");
}
