#include "arrays.h"

#include <fmt/format.h>
#include <fmt/ranges.h>

#include <cmath>

namespace rmpmarl::python {

void BadArgument(const std::string& message) { throw py::value_error(message); }

std::string Describe(const py::array& a) {
  std::vector<py::ssize_t> shape(a.shape(), a.shape() + a.ndim());
  return fmt::format("{}[{}]", std::string(py::str(a.dtype())), fmt::join(shape, ", "));
}

namespace {

std::string ShapeText(const std::vector<py::ssize_t>& shape) {
  std::vector<std::string> parts;
  for (py::ssize_t s : shape) parts.push_back(s < 0 ? "any" : std::to_string(s));
  return fmt::format("[{}]", fmt::join(parts, ", "));
}

template <typename T>
bool AllFinite(const py::array& a) {
  const T* p = static_cast<const T*>(a.data());
  for (py::ssize_t i = 0; i < a.size(); ++i) {
    if (!std::isfinite(p[i])) return false;
  }
  return true;
}

}  // namespace

py::array CheckedArray(const py::handle& obj, const ArraySpec& spec) {
  const char* dtype = spec.float32 ? "float32" : "float64";
  const std::string expected = fmt::format("{}{}", dtype, ShapeText(spec.shape));
  py::array a;
  if (py::isinstance<py::array>(obj)) {
    a = py::reinterpret_borrow<py::array>(obj);
    const bool right_dtype = spec.float32 ? a.dtype().is(py::dtype::of<float>()) : a.dtype().is(py::dtype::of<double>());
    if (!right_dtype) {
      BadArgument(fmt::format("{}: expected a {} array, got {} (convert with .astype(np.{}))", spec.name, expected,
                              Describe(a), dtype));
    }
    if (!(a.flags() & py::array::c_style)) {
      BadArgument(fmt::format("{}: expected a C-contiguous array, got a strided view {} (use np.ascontiguousarray)",
                              spec.name, Describe(a)));
    }
  } else if (py::isinstance<py::sequence>(obj) && !py::isinstance<py::str>(obj)) {
    try {
      a = spec.float32 ? py::array(py::array_t<float, py::array::c_style | py::array::forcecast>::ensure(obj))
                       : py::array(py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(obj));
    } catch (const py::error_already_set&) {
      a = py::array();
    }
    if (!a) BadArgument(fmt::format("{}: expected {} (numbers), got a sequence that is not numeric", spec.name, expected));
  } else {
    BadArgument(fmt::format("{}: expected a {} array, got {}", spec.name, expected,
                            std::string(py::str(py::type::of(obj).attr("__name__")))));
  }
  bool shape_ok = a.ndim() == static_cast<py::ssize_t>(spec.shape.size());
  for (size_t i = 0; shape_ok && i < spec.shape.size(); ++i) {
    shape_ok = spec.shape[i] < 0 || a.shape(static_cast<py::ssize_t>(i)) == spec.shape[i];
  }
  if (!shape_ok) BadArgument(fmt::format("{}: expected shape {}, got {}", spec.name, expected, Describe(a)));
  if (spec.finite && !(spec.float32 ? AllFinite<float>(a) : AllFinite<double>(a))) {
    BadArgument(fmt::format("{}: expected finite values, got NaN or infinity in {}", spec.name, Describe(a)));
  }
  return a;
}

py::array_t<double> MatrixToNumpy(const Eigen::Ref<const Eigen::MatrixXd>& m) {
  py::array_t<double> a({m.rows(), m.cols()});
  auto r = a.mutable_unchecked<2>();
  for (Eigen::Index i = 0; i < m.rows(); ++i) {
    for (Eigen::Index j = 0; j < m.cols(); ++j) r(i, j) = m(i, j);
  }
  return a;
}

py::array_t<double> VectorToNumpy(const Eigen::Ref<const Eigen::VectorXd>& v) {
  py::array_t<double> a(v.size());
  std::copy(v.data(), v.data() + v.size(), a.mutable_data());
  return a;
}

}  // namespace rmpmarl::python
