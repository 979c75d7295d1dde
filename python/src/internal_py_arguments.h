// Arguments of the roofgs module. The public functions take their numbers, strings and paths as the caller
// passed them (Arg) and convert them with the helpers below, so that a wrong type (TypeError) or value
// (ValueError) names the function, the argument and the rule ("audit(): threshold must be a finite number in
// -1000..1000, got nan") where pybind11 would list the whole signature.
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <array>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "rgs/api/roofgs.h"
#include "rgs/converter/scene_reader.h"

namespace py = pybind11;

namespace rgs::python {

/// An argument as the caller passed it; help() shows it as `Name::name`.
template <typename Name>
struct Arg {
  py::object value;
  operator py::handle() const { return value; }  // NOLINT(google-explicit-constructor): the helpers take a handle
};
// clang-format off
struct IntName { static constexpr auto name = py::detail::const_name("int"); };
struct FloatName { static constexpr auto name = py::detail::const_name("float"); };
struct StrName { static constexpr auto name = py::detail::const_name("str"); };
struct PathName { static constexpr auto name = py::detail::const_name("os.PathLike"); };
struct StrListName { static constexpr auto name = py::detail::const_name("List[str]"); };
struct PointName { static constexpr auto name = py::detail::const_name("List[float[3]]"); };
// clang-format on
using IntArg = Arg<IntName>;
using FloatArg = Arg<FloatName>;
using StrArg = Arg<StrName>;
using PathArg = Arg<PathName>;
using StrListArg = Arg<StrListName>;
using PointArg = Arg<PointName>;

}  // namespace rgs::python

namespace pybind11::detail {
/// Takes any object as an Arg: the function's body converts it.
template <typename Name>
struct type_caster<rgs::python::Arg<Name>> {
  PYBIND11_TYPE_CASTER(rgs::python::Arg<Name>, Name::name);
  bool load(handle src, bool) {
    value.value = reinterpret_borrow<object>(src);
    return true;
  }
  static handle cast(const rgs::python::Arg<Name>& arg, return_value_policy, handle) { return arg.value.inc_ref(); }
};
}  // namespace pybind11::detail

namespace rgs::python {

/// Largest image side a camera takes (runtime::validate_camera), and the highest CUDA device ordinal the tools
/// take (--device).
inline constexpr uint32_t kMaxImageSide = 32768;
inline constexpr int kMaxCudaDevice = 1023;
inline constexpr double kInf = std::numeric_limits<double>::infinity();

/// `v` as text, "%.9g".
std::string number_text(double v);

/// TypeError "fn(): name must be <what>, got <type of value>".
py::type_error type_error(const char* fn, const char* name, const std::string& what, py::handle value);

/// ValueError "fn(): name must be <rule>, got <got>".
py::value_error value_error(const char* fn, const char* name, const std::string& rule, const std::string& got);

/// Integer argument `name` of `fn` in [lo, hi]: a Python int or anything with __index__ (NumPy's integers), not a
/// bool.
template <typename T>
T int_arg(py::handle value, const char* fn, const char* name, T lo = std::numeric_limits<T>::min(),
          T hi = std::numeric_limits<T>::max()) {
  if (PyBool_Check(value.ptr()) || !PyIndex_Check(value.ptr())) throw type_error(fn, name, "an int", value);
  const auto index = py::reinterpret_steal<py::object>(PyNumber_Index(value.ptr()));
  if (!index) throw py::error_already_set();
  const py::int_ low(lo), high(hi);
  const int below = PyObject_RichCompareBool(index.ptr(), low.ptr(), Py_LT);
  const int above = PyObject_RichCompareBool(index.ptr(), high.ptr(), Py_GT);
  if (below < 0 || above < 0) throw py::error_already_set();
  if (below || above) {
    throw value_error(fn, name, "an integer in " + std::to_string(lo) + ".." + std::to_string(hi), py::repr(index));
  }
  return index.cast<T>();
}

/// int_arg of an argument that may be None (nullopt).
template <typename T, typename Name>
std::optional<T> int_arg(const std::optional<Arg<Name>>& value, const char* fn, const char* name,
                         T lo = std::numeric_limits<T>::min(), T hi = std::numeric_limits<T>::max()) {
  if (!value) return std::nullopt;
  return int_arg<T>(*value, fn, name, lo, hi);
}

/// The values a number argument takes: finite, from lo to hi, lo itself excluded when `above`.
struct NumberRule {
  double lo = -kInf, hi = kInf;
  bool above = false;
};
inline constexpr NumberRule kFinite{}, kPositive{0.0, kInf, true};

/// Number argument `name` of `fn` (int, float or anything with __float__, not a bool) that follows `rule`.
double float_arg(py::handle value, const char* fn, const char* name, NumberRule rule = kFinite);

/// Argument `name` of `fn` converted to T by pybind11 (strings, paths, lists of them, bools); TypeError saying
/// it must be `what` when it cannot be.
template <typename T>
T cast_arg(py::handle value, const char* fn, const char* name, const char* what) {
  try {
    return value.cast<T>();
  } catch (const py::cast_error&) {
    throw type_error(fn, name, what, value);
  }
}

/// cast_arg of a str.
std::string str_arg(py::handle value, const char* fn, const char* name);

/// cast_arg of a path: a str or os.PathLike.
std::filesystem::path path_arg(py::handle value, const char* fn, const char* name);

/// M[row][col] of a numpy-like rows × cols matrix of finite numbers (cols 1: a vector).
std::vector<double> matrix(py::handle value, size_t rows, size_t cols, const char* fn, const char* name);

/// matrix() as an array, row-major.
template <size_t Rows, size_t Cols = 1>
std::array<double, Rows * Cols> arr(py::handle value, const char* fn, const char* name) {
  const auto v = matrix(value, Rows, Cols, fn, name);
  std::array<double, Rows * Cols> out{};
  for (size_t i = 0; i < out.size(); ++i) out[i] = v[i];
  return out;
}

/// converter::SceneReadOptions from the keyword arguments every reading function takes. `spz_frame`: "rub" or
/// "as-stored" for every SPZ file, or a mapping {path: frame} for those files (the others "rub"), as rgs-convert's
/// repeated --spz-frame FILE=FRAME.
converter::SceneReadOptions read_options(const py::object& spz_frame);

/// The device `name` asks for: "auto" is CUDA when a device answers, else the CPU (with a warning);
/// "cuda" without a device raises an error that names the alternatives.
api::Device resolve_device(const std::string& name);

}  // namespace rgs::python
