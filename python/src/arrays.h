#pragma once
// Checks at the Python boundary: every array a user hands in is checked for type, dtype, layout, shape and finite
// values before any C++ state changes, and a failure raises ValueError naming the argument with the expected and the
// received value.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <Eigen/Core>
#include <string>
#include <vector>

namespace rmpmarl::python {

namespace py = pybind11;

/// the ValueError a bad argument raises.
[[noreturn]] void BadArgument(const std::string& message);

/// "float64[7]", "int64[3, 2]": a received array's dtype and shape for messages.
std::string Describe(const py::array& a);

/// Options of CheckedArray.
struct ArraySpec {
  const char* name;               ///< the argument's name in messages ("q", "actions")
  std::vector<py::ssize_t> shape;  ///< expected shape; -1: any length on that axis
  bool float32 = false;           ///< dtype float32 (else float64)
  bool finite = true;             ///< every value finite
};

/// `obj` as a C-contiguous array of the spec's dtype and shape. A Python sequence of numbers is converted; a numpy
/// array must already have the dtype and be C-contiguous (no silent copies of a user's buffers). Raises ValueError.
py::array CheckedArray(const py::handle& obj, const ArraySpec& spec);

/// a checked float64 vector of `size` entries as an Eigen map (valid while the returned array lives).
inline Eigen::Map<const Eigen::VectorXd> AsVector(const py::array& a) {
  return {static_cast<const double*>(a.data()), static_cast<Eigen::Index>(a.size())};
}

/// a read-only numpy view of `count` floats at `data` with `shape`, kept alive by `owner` (the C++ object whose
/// buffer it is): numpy's base object holds a reference to it.
template <typename T>
py::array View(const T* data, std::vector<py::ssize_t> shape, const py::handle& owner) {
  py::array_t<T> a(shape, data, owner);
  py::detail::array_proxy(a.ptr())->flags &= ~py::detail::npy_api::NPY_ARRAY_WRITEABLE_;
  return a;
}

/// a float64 numpy array copied from an Eigen matrix (row-major order in the array).
py::array_t<double> MatrixToNumpy(const Eigen::Ref<const Eigen::MatrixXd>& m);
py::array_t<double> VectorToNumpy(const Eigen::Ref<const Eigen::VectorXd>& v);

}  // namespace rmpmarl::python
