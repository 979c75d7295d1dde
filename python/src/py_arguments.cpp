// The argument helpers of the roofgs module (internal_py_arguments.h).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cmath>
#include <cstdio>

#include "internal_py_arguments.h"
#include "internal_py_errors.h"

namespace rgs::python {

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

py::type_error type_error(const char* fn, const char* name, const std::string& what, py::handle value) {
  return py::type_error(std::string(fn) + "(): " + name + " must be " + what + ", got " +
                        Py_TYPE(value.ptr())->tp_name);
}

py::value_error value_error(const char* fn, const char* name, const std::string& rule, const std::string& got) {
  return py::value_error(std::string(fn) + "(): " + name + " must be " + rule + ", got " + got.substr(0, 40));
}

double float_arg(py::handle value, const char* fn, const char* name, NumberRule rule) {
  if (PyBool_Check(value.ptr()) || !PyNumber_Check(value.ptr())) throw type_error(fn, name, "a number", value);
  double v = PyFloat_AsDouble(value.ptr());
  std::string got = number_text(v);
  if (v == -1.0 && PyErr_Occurred()) {
    const bool overflow = PyErr_ExceptionMatches(PyExc_OverflowError);  // an int beyond the double range
    PyErr_Clear();
    if (!overflow) throw type_error(fn, name, "a number", value);
    v = kInf;
    got = py::repr(value);
  }
  const bool high_enough = rule.above ? v > rule.lo : v >= rule.lo;
  if (std::isfinite(v) && high_enough && v <= rule.hi) return v;
  std::string text = "a finite number";
  if (rule.lo > -kInf && rule.hi < kInf) {
    text += " in " + number_text(rule.lo) + ".." + number_text(rule.hi);
  } else if (rule.lo > -kInf) {
    text += (rule.above ? " > " : " >= ") + number_text(rule.lo);
  }
  throw value_error(fn, name, text, got);
}

std::string str_arg(py::handle value, const char* fn, const char* name) {
  return cast_arg<std::string>(value, fn, name, "a str");
}

std::filesystem::path path_arg(py::handle value, const char* fn, const char* name) {
  return cast_arg<std::filesystem::path>(value, fn, name, "a str or os.PathLike");
}

std::vector<double> matrix(py::handle value, size_t rows, size_t cols, const char* fn, const char* name) {
  const auto a = py::array_t<double, py::array::c_style | py::array::forcecast>::ensure(value);
  if (!a || value.is_none()) throw type_error(fn, name, "an array of numbers", value);
  const std::string shape = std::to_string(rows) + (cols == 1 ? "" : "x" + std::to_string(cols)) + " finite numbers";
  const size_t n = size_t(a.size());
  if (n != rows * cols) throw value_error(fn, name, shape, std::to_string(n) + (n == 1 ? " number" : " numbers"));
  const std::vector<double> m(a.data(), a.data() + a.size());
  for (double v : m) {
    if (!std::isfinite(v)) throw value_error(fn, name, shape, number_text(v));
  }
  return m;
}

converter::SceneReadOptions read_options(const py::object& spz_frame) {
  converter::SceneReadOptions options;
  auto parse = [](const py::handle& value) {
    const std::optional<converter::SpzFrame> frame = converter::parse_spz_frame(py::str(value).cast<std::string>());
    if (!frame || !py::isinstance<py::str>(value)) {
      raise(Status(StatusCode::kInvalidArgument,
                   "spz_frame must be 'rub' or 'as-stored', or a mapping of SPZ paths to one of them"));
    }
    return *frame;
  };
  if (py::isinstance<py::dict>(spz_frame)) {
    const py::object fspath = py::module_::import("os").attr("fspath");
    for (const auto& [path, value] : spz_frame.cast<py::dict>()) {
      options.spz_frame_by_path[fspath(path).cast<std::string>()] = parse(value);
    }
  } else {
    options.spz_frame = parse(spz_frame);
  }
  return options;
}

api::Device resolve_device(const std::string& name) {
  std::string why;
  if (name == "auto") {
    if (api::cuda_available(&why)) return api::Device::kCuda;
    // Once per process (Python's default filter would show it once per calling line), in plain words: CUDA's
    // own reason stays in roofgs.cuda_status().
    static bool warned = false;  // under the GIL
    if (!warned) {
      warned = true;
      const char* note = "roofgs: no usable CUDA device: rendering on the CPU reference (roofgs.cuda_status() says why)";
      if (PyErr_WarnEx(PyExc_RuntimeWarning, note, 1) != 0) throw py::error_already_set();
    }
    return api::Device::kCpu;
  }
  const api::Device device = unwrap(api::parse_device(name));
  if (device == api::Device::kCuda && !api::cuda_available(&why)) {
    raise(Status(StatusCode::kUnsupportedFeature,
                 "device='" + name + "': no usable CUDA device (" + why +
                     "); load with device='cpu', or device='auto' to use CUDA only where a device answers"));
  }
  return device;
}

}  // namespace rgs::python
