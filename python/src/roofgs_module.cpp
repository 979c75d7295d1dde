// Python bindings of the RoofGS front door (rgs/api). Errors become roofgs.Error (a RuntimeError) carrying
// .code (the StatusCode number) and .code_name ("kIoError", ...); an argument of the wrong type or outside its
// rule raises TypeError or ValueError naming the function and the argument (Arguments below). GPU images
// implement the DLPack protocol (__dlpack__, __dlpack_device__), so torch.from_dlpack() shares their memory
// without a copy.
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <unistd.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "rgs/api/device_gaussians.h"
#include "rgs/api/roofgs.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/audit/audit_scene.h"
#include "rgs/api/camera.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/format/archive.h"
#include "rgs/format/reader.h"
#include "rgs/kernels/shared/spherical_harmonics.h"
#if RGS_WITH_VIEWER
#include "rgs/view/server.h"
#endif

namespace py = pybind11;
using namespace rgs;

namespace {

// ---------------------------------------------------------------------------------------------------------
// Errors

struct StatusError {
  Status status;
};

PyObject* g_error_type = nullptr;

[[noreturn]] void raise(const Status& status) { throw StatusError{status}; }

template <typename T>
T unwrap(Result<T> result) {
  if (!result.ok()) raise(result.status());
  return std::move(result).value();
}

void check(const Status& status) {
  if (!status.ok()) raise(status);
}

// ---------------------------------------------------------------------------------------------------------
// Arguments. The public functions take their numbers, strings and paths as the caller passed them (Arg) and
// convert them with the helpers below, so that a wrong type (TypeError) or value (ValueError) names the
// function, the argument and the rule ("audit(): threshold must be a finite number in -1000..1000, got nan")
// where pybind11 would list the whole signature.

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

}  // namespace

namespace pybind11::detail {
/// Takes any object as an Arg: the function's body converts it.
template <typename Name>
struct type_caster<Arg<Name>> {
  PYBIND11_TYPE_CASTER(Arg<Name>, Name::name);
  bool load(handle src, bool) {
    value.value = reinterpret_borrow<object>(src);
    return true;
  }
  static handle cast(const Arg<Name>& arg, return_value_policy, handle) { return arg.value.inc_ref(); }
};
}  // namespace pybind11::detail

namespace {

/// Largest image side a camera takes (runtime::validate_camera), and the highest CUDA device ordinal the tools
/// take (--device).
constexpr uint32_t kMaxImageSide = 32768;
constexpr int kMaxCudaDevice = 1023;
constexpr double kInf = std::numeric_limits<double>::infinity();

std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.9g", v);
  return text;
}

/// TypeError "fn(): name must be <what>, got <type of value>".
py::type_error type_error(const char* fn, const char* name, const std::string& what, py::handle value) {
  return py::type_error(std::string(fn) + "(): " + name + " must be " + what + ", got " +
                        Py_TYPE(value.ptr())->tp_name);
}

/// ValueError "fn(): name must be <rule>, got <got>".
py::value_error value_error(const char* fn, const char* name, const std::string& rule, const std::string& got) {
  return py::value_error(std::string(fn) + "(): " + name + " must be " + rule + ", got " + got.substr(0, 40));
}

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
constexpr NumberRule kFinite{}, kPositive{0.0, kInf, true};

/// Number argument `name` of `fn` (int, float or anything with __float__, not a bool) that follows `rule`.
double float_arg(py::handle value, const char* fn, const char* name, NumberRule rule = kFinite) {
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

std::string str_arg(py::handle value, const char* fn, const char* name) {
  return cast_arg<std::string>(value, fn, name, "a str");
}

std::filesystem::path path_arg(py::handle value, const char* fn, const char* name) {
  return cast_arg<std::filesystem::path>(value, fn, name, "a str or os.PathLike");
}

/// M[row][col] of a numpy-like rows × cols matrix of finite numbers (cols 1: a vector).
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

/// matrix() as an array, row-major.
template <size_t Rows, size_t Cols = 1>
std::array<double, Rows * Cols> arr(py::handle value, const char* fn, const char* name) {
  const auto v = matrix(value, Rows, Cols, fn, name);
  std::array<double, Rows * Cols> out{};
  for (size_t i = 0; i < out.size(); ++i) out[i] = v[i];
  return out;
}

api::Mat4ColumnMajor gl_matrix(py::handle value, const char* fn, const char* name) {
  const auto m = matrix(value, 4, 4, fn, name);
  api::Mat4ColumnMajor out{};
  for (size_t r = 0; r < 4; ++r) {
    for (size_t c = 0; c < 4; ++c) out[4 * c + r] = float(m[4 * r + c]);
  }
  return out;
}

/// The arguments every camera_from_* function of `fn` takes after its matrices: the image size and the options.
struct CameraArgs {
  uint32_t width = 0, height = 0;
  api::CameraOptions options;
};

CameraArgs camera_args(const char* fn, py::handle width, py::handle height, py::handle near_plane, py::handle name) {
  CameraArgs a;
  a.width = int_arg<uint32_t>(width, fn, "width", 1, kMaxImageSide);
  a.height = int_arg<uint32_t>(height, fn, "height", 1, kMaxImageSide);
  a.options.near_plane = float(float_arg(near_plane, fn, "near_plane", kPositive));
  a.options.name = str_arg(name, fn, "name");
  return a;
}

// ---------------------------------------------------------------------------------------------------------
// DLPack (the ABI-stable structs of the DLPack specification, v0.8)

enum DLDeviceType : int32_t { kDLCPU = 1, kDLCUDA = 2 };
struct DLDevice {
  DLDeviceType device_type;
  int32_t device_id;
};
struct DLDataType {
  uint8_t code;  // 0 int, 1 uint, 2 float
  uint8_t bits;
  uint16_t lanes;
};
struct DLTensor {
  void* data;
  DLDevice device;
  int32_t ndim;
  DLDataType dtype;
  int64_t* shape;
  int64_t* strides;
  uint64_t byte_offset;
};
struct DLManagedTensor {
  DLTensor dl_tensor;
  void* manager_ctx;
  void (*deleter)(DLManagedTensor* self);
};

/// A rendered image shared by the Python objects that view it (colour and depth planes).
using SharedImage = std::shared_ptr<api::Image>;

/// One plane of a library image: colour [H, W, 4] or depth [H, W].
struct ImagePlane {
  SharedImage image;
  bool depth = false;

  std::vector<int64_t> shape() const {
    if (depth) return {int64_t(image->height()), int64_t(image->width())};
    return {int64_t(image->height()), int64_t(image->width()), 4};
  }
  DLDataType dtype() const {
    if (depth) return {2, 32, 1};
    switch (image->format()) {
      case api::PixelFormat::kRgba32f: return {2, 32, 1};
      case api::PixelFormat::kRgba16f: return {2, 16, 1};
      case api::PixelFormat::kRgba8: return {1, 8, 1};
    }
    return {2, 32, 1};
  }
  std::string dtype_name() const {
    const DLDataType t = dtype();
    return t.code == 1 ? "uint8" : t.bits == 16 ? "float16" : "float32";
  }
  void* data() const { return depth ? static_cast<void*>(image->depth()) : image->color(); }
};

struct DLContext {
  SharedImage image;
  std::vector<int64_t> shape;
  DLManagedTensor tensor{};
};

void delete_managed(DLManagedTensor* self) { delete static_cast<DLContext*>(self->manager_ctx); }

void capsule_destructor(PyObject* capsule) {
  // Only a capsule nobody consumed still carries the name "dltensor" (consumers rename it).
  if (PyCapsule_IsValid(capsule, "dltensor")) {
    auto* managed = static_cast<DLManagedTensor*>(PyCapsule_GetPointer(capsule, "dltensor"));
    if (managed != nullptr && managed->deleter != nullptr) managed->deleter(managed);
  }
}

py::object plane_dlpack(const ImagePlane& plane, py::object stream) {
  if (plane.image->device() == api::Device::kCuda) {
    // DLPack: None means the legacy default stream (1); -1 asks for no synchronization.
    const int64_t s = stream.is_none() ? 1 : int_arg<int64_t>(stream, "__dlpack__", "stream");
    if (s != -1) check(plane.image->make_stream_wait(reinterpret_cast<api::Stream>(static_cast<uintptr_t>(s))));
  }
  auto* ctx = new DLContext;
  ctx->image = plane.image;
  ctx->shape = plane.shape();
  DLTensor& t = ctx->tensor.dl_tensor;
  t.data = plane.data();
  t.device = {plane.image->device() == api::Device::kCuda ? kDLCUDA : kDLCPU,
              plane.image->device() == api::Device::kCuda ? plane.image->cuda_device() : 0};
  t.ndim = int32_t(ctx->shape.size());
  t.dtype = plane.dtype();
  t.shape = ctx->shape.data();
  t.strides = nullptr;  // compact row-major
  t.byte_offset = 0;
  ctx->tensor.manager_ctx = ctx;
  ctx->tensor.deleter = delete_managed;
  PyObject* capsule = PyCapsule_New(&ctx->tensor, "dltensor", capsule_destructor);
  if (capsule == nullptr) {
    delete ctx;
    throw py::error_already_set();
  }
  return py::reinterpret_steal<py::object>(capsule);
}

py::array plane_numpy(const ImagePlane& plane) {
  std::vector<py::ssize_t> shape;
  for (int64_t d : plane.shape()) shape.push_back(py::ssize_t(d));
  py::array out;
  const DLDataType t = plane.dtype();
  if (t.code == 1) {
    out = py::array_t<uint8_t>(shape);
  } else if (t.bits == 16) {
    out = py::array(py::dtype("float16"), shape);
  } else {
    out = py::array_t<float>(shape);
  }
  if (plane.depth) {
    std::vector<uint8_t> scratch(size_t(plane.image->width()) * plane.image->height() *
                                 api::bytes_per_pixel(plane.image->format()));
    check(plane.image->copy_to_host(scratch.data(), static_cast<float*>(out.mutable_data())));
  } else {
    check(plane.image->copy_to_host(out.mutable_data(), nullptr));
  }
  return out;
}

// ---------------------------------------------------------------------------------------------------------
// Scenes

py::dict error_stats(const converter::ErrorStats& e) {
  py::dict d;
  d["max"] = e.max;
  d["rms"] = e.rms;
  d["samples"] = e.samples;
  return d;
}

py::dict attribute_errors(const converter::AttributeErrors& e) {
  py::dict d;
  d["position"] = error_stats(e.position);
  d["rotation_deg"] = error_stats(e.rotation_deg);
  d["scale_relative"] = error_stats(e.scale_relative);
  d["opacity"] = error_stats(e.opacity);
  py::list sh;
  for (const auto& s : e.sh) sh.append(error_stats(s));
  d["sh_by_degree"] = sh;
  return d;
}

py::dict scene_info(const api::SceneInfo& info) {
  py::dict d;
  d["path"] = info.path;
  d["device"] = api::device_name(info.device);
  d["gaussians"] = info.gaussians;
  d["sh_degree"] = info.sh_degree;
  d["antialiased"] = info.antialiased;
  d["source_is_rgs"] = info.source_is_rgs;
  d["file_bytes"] = info.file_bytes;
  d["has_compact"] = info.has_compact;
  d["has_fp32"] = info.has_fp32;
  d["memory_bytes"] = info.memory_bytes;
  d["runtime_section_bytes"] = info.runtime_section_bytes;
  d["sphere_center"] = std::vector<float>(info.bounds.sphere_center, info.bounds.sphere_center + 3);
  d["sphere_radius"] = info.bounds.sphere_radius;
  d["notes"] = info.notes;
  d["description"] = info.description;
  py::dict lod;
  lod["active"] = info.lod.active;
  lod["chunks"] = info.lod.chunks;
  lod["levels"] = info.lod.levels;
  lod["stored_gaussians"] = info.lod.stored_gaussians;
  lod["splat_budget"] = info.lod.settings.splat_budget;
  lod["pixel_error"] = info.lod.settings.pixel_error;
  lod["memory_budget"] = info.lod.settings.memory_budget;
  lod["stream_bytes_per_frame"] = info.lod.settings.stream_bytes_per_frame;
  lod["pool_bytes"] = info.lod.pool_bytes;
  d["lod"] = lod;
  return d;
}

/// A frame's counts (api::FrameStats) as a dict; "lod" holds the level-of-detail counts (zeros for other scenes).
py::dict frame_stats_dict(const api::FrameStats& stats) {
  py::dict d;
  d["gaussians"] = stats.gaussians;
  d["pairs"] = stats.pairs;
  d["tile_groups"] = stats.tile_groups;
  py::dict lod;
  lod["splats"] = stats.lod.splats;
  lod["chunks_drawn"] = stats.lod.chunks_drawn;
  lod["chunks_culled"] = stats.lod.chunks_culled;
  lod["chunks_coarsened"] = stats.lod.chunks_coarsened;
  lod["chunks_not_resident"] = stats.lod.chunks_not_resident;
  lod["ranges_streamed"] = stats.lod.ranges_streamed;
  lod["bytes_streamed"] = stats.lod.bytes_streamed;
  lod["bytes_resident"] = stats.lod.bytes_resident;
  d["lod"] = lod;
  return d;
}

/// converter::SceneReadOptions from the keyword arguments every reading function takes. `spz_frame`: "rub" or
/// "as-stored" for every SPZ file, or a mapping {path: frame} for those files (the others "rub"), as rgs-convert's
/// repeated --spz-frame FILE=FRAME.
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

// ---------------------------------------------------------------------------------------------------------
// Gaussians from arrays

/// A C-contiguous float32 copy of `obj` (a NumPy array, or anything with __array__: a CPU torch tensor). A
/// CUDA tensor is copied to the host first (`.cpu()`): the host path, and the small per-view arrays (viewmats,
/// Ks, backgrounds) of the device path.
py::array_t<float> float_array(const py::object& obj, const char* what) {
  py::object source = obj;
  if (py::hasattr(obj, "__dlpack_device__")) {
    const auto device = obj.attr("__dlpack_device__")().cast<std::pair<int, int>>();
    if (device.first != kDLCPU && py::hasattr(obj, "cpu")) source = obj.attr("cpu")();
  }
  if (py::hasattr(source, "detach")) source = source.attr("detach")();
  // array_t::ensure() would clear the conversion's error: a MemoryError (an array too large to copy) must
  // reach the caller as such, not as "not an array of numbers".
  try {
    return py::array_t<float, py::array::c_style | py::array::forcecast>(source);
  } catch (py::error_already_set& e) {
    if (e.matches(PyExc_MemoryError)) throw;
  }
  raise(Status(StatusCode::kInvalidArgument, std::string(what) + ": not an array of numbers"));
}

/// Checks that `shape` is [n, cols...] (n taken from the first array when *n is 0).
void check_dims(const std::vector<int64_t>& shape, const char* what, size_t* n, const std::vector<int64_t>& cols) {
  const std::string want = [&] {
    std::string t = "[N";
    for (int64_t c : cols) t += ", " + std::to_string(c);
    return t + "]";
  }();
  bool ok = shape.size() == cols.size() + 1;
  for (size_t d = 0; ok && d < cols.size(); ++d) ok = shape[d + 1] == cols[d];
  if (ok && *n == 0) *n = size_t(shape[0]);
  ok = ok && size_t(shape[0]) == *n;
  if (!ok) raise(Status(StatusCode::kInvalidArgument, std::string(what) + ": expected shape " + want + " with N = " +
                                                          std::to_string(*n)));
}

std::vector<int64_t> shape_of(const py::array& a) {
  std::vector<int64_t> shape;
  for (py::ssize_t d = 0; d < a.ndim(); ++d) shape.push_back(int64_t(a.shape(d)));
  return shape;
}

/// check_dims of a NumPy array.
void check_shape(const py::array_t<float>& a, const char* what, size_t* n, const std::vector<int64_t>& cols) {
  check_dims(shape_of(a), what, n, cols);
}

/// The SH degree of [N, K, 3] SH coefficients (K = 1, 4, 9 or 16).
uint32_t sh_degree_of(const std::vector<int64_t>& shape) {
  const int64_t k = shape.size() == 3 ? shape[1] : 0;
  uint32_t d = 0;
  while (d < 3 && format::sh_coefficient_count(d) < uint64_t(k)) ++d;
  if (k <= 0 || format::sh_coefficient_count(d) != uint64_t(k)) {
    raise(Status(StatusCode::kInvalidArgument, "sh: expected shape [N, K, 3] with K = 1, 4, 9 or 16"));
  }
  return d;
}

/// The SH coefficients of `colors`: [N, K, 3] SH (K = 1, 4, 9 or 16) or, when `rgb`, [N, 3] colours turned
/// into the DC term that renders them, (c - 0.5) / C0 (3DGS: colour = C0·f_dc + 0.5).
std::vector<float> sh_values(const py::array_t<float>& colors, size_t n, bool rgb, uint32_t* degree) {
  if (rgb) {
    size_t m = n;
    check_shape(colors, "colors", &m, {3});
    *degree = 0;
    std::vector<float> sh(colors.data(), colors.data() + colors.size());
    for (float& v : sh) v = (v - 0.5f) / kernels::kShC0;
    return sh;
  }
  const uint32_t d = sh_degree_of(shape_of(colors));
  size_t m = n;
  check_shape(colors, "sh", &m, {int64_t(format::sh_coefficient_count(d)), 3});
  *degree = d;
  return std::vector<float>(colors.data(), colors.data() + colors.size());
}

/// format::GaussianCloud from arrays in its activated layout: means [N, 3], quats [N, 4] (w, x, y, z),
/// linear scales [N, 3], opacities [N] in [0, 1], SH [N, K, 3] (or RGB [N, 3] when `rgb`).
format::GaussianCloud cloud_from_arrays(const py::object& means, const py::object& quats, const py::object& scales,
                                        const py::object& opacities, const py::object& colors, bool rgb) {
  const auto m = float_array(means, "means"), q = float_array(quats, "quats"), s = float_array(scales, "scales");
  auto o = float_array(opacities, "opacities");
  size_t n = 0;
  check_shape(m, "means", &n, {3});
  check_shape(q, "quats", &n, {4});
  check_shape(s, "scales", &n, {3});
  if (o.ndim() == 2) o = o.reshape({py::ssize_t(o.shape(0) * o.shape(1))});
  check_shape(o, "opacities", &n, {});
  format::GaussianCloud cloud;
  cloud.sh = sh_values(float_array(colors, rgb ? "colors" : "sh"), n, rgb, &cloud.sh_degree);
  cloud.means.assign(m.data(), m.data() + m.size());
  cloud.rotations.assign(q.data(), q.data() + q.size());
  cloud.scales.assign(s.data(), s.data() + s.size());
  cloud.opacities.assign(o.data(), o.data() + o.size());
  return cloud;
}

// ---------------------------------------------------------------------------------------------------------
// Gaussians in CUDA memory (DLPack in, no host copy)

/// The CUDA device of an array that says it lives on one (DLPack's __dlpack_device__), else nullopt.
std::optional<int> cuda_device_of(const py::object& obj) {
  if (!py::hasattr(obj, "__dlpack_device__")) return std::nullopt;
  const auto device = obj.attr("__dlpack_device__")().cast<std::pair<int, int>>();
  if (device.first != kDLCUDA) return std::nullopt;
  return device.second;
}

/// The CUDA device the five Gaussian arrays live on, nullopt when they are all host arrays; ValueError when
/// they are split between the host and a device, or between devices.
std::optional<int> arrays_cuda_device(const std::array<const py::object*, 5>& arrays) {
  std::optional<int> device;
  size_t on_host = 0;
  for (const py::object* obj : arrays) {
    const std::optional<int> d = cuda_device_of(*obj);
    if (!d) {
      ++on_host;
    } else if (device && *device != *d) {
      throw py::value_error("the Gaussian arrays are on CUDA devices " + std::to_string(*device) + " and " +
                            std::to_string(*d) + "; put them on one device");
    } else {
      device = d;
    }
  }
  if (device && on_host != 0) {
    throw py::value_error("the Gaussian arrays are partly on CUDA device " + std::to_string(*device) +
                          " and partly in host memory; put them all on one side");
  }
  return device;
}

bool is_torch_tensor(const py::object& obj) {
  const py::dict modules = py::module_::import("sys").attr("modules");
  if (!modules.contains("torch")) return false;
  return py::isinstance(obj, modules["torch"].attr("Tensor"));
}

py::module_ import_torch() {
  try {
    return py::module_::import("torch");
  } catch (py::error_already_set&) {
    throw py::import_error("roofgs: the outputs of CUDA arrays are torch tensors, and torch cannot be imported; "
                           "install PyTorch or pass NumPy arrays");
  }
}

/// torch's current stream on CUDA device `device` (its handle; 0 is the legacy default stream).
int64_t torch_stream(const py::module_& torch, int device) {
  return torch.attr("cuda").attr("current_stream")(device).attr("cuda_stream").cast<int64_t>();
}

/// Makes CUDA device `device` current for the lifetime of the guard (torch.cuda.device), restoring the previous
/// one after.
class TorchDeviceGuard {
 public:
  TorchDeviceGuard(const py::module_& torch, int device) : guard_(torch.attr("cuda").attr("device")(device)) {
    guard_.attr("__enter__")();
  }
  ~TorchDeviceGuard() {
    try {
      guard_.attr("__exit__")(py::none(), py::none(), py::none());
    } catch (py::error_already_set& e) {
      e.discard_as_unraisable("roofgs: restoring the CUDA device");
    }
  }
  TorchDeviceGuard(const TorchDeviceGuard&) = delete;
  TorchDeviceGuard& operator=(const TorchDeviceGuard&) = delete;

 private:
  py::object guard_;
};

void release_managed(DLManagedTensor* managed) {
  if (managed != nullptr && managed->deleter != nullptr) managed->deleter(managed);
}

/// A float32 array in CUDA memory borrowed through DLPack for the duration of one call: a torch tensor
/// (detached, and made float32 and contiguous on its device when it is not), or any producer's array already
/// float32 and C-contiguous. The producer's work is ordered before `stream` (DLPack's stream argument).
class DeviceArray {
 public:
  DeviceArray(const py::object& obj, const char* what, int device, int64_t stream) {
    py::object source = obj;
    if (py::hasattr(source, "detach")) source = source.attr("detach")();
    if (is_torch_tensor(source)) source = source.attr("float")().attr("contiguous")();  // no-ops when already so
    if (!py::hasattr(source, "__dlpack__")) throw py::type_error(std::string(what) + ": not a DLPack array");
    // DLPack numbers the legacy default stream 1 (0 is not allowed for CUDA).
    py::object capsule = source.attr("__dlpack__")(py::arg("stream") = stream == 0 ? 1 : stream);
    if (!PyCapsule_IsValid(capsule.ptr(), "dltensor")) {
      throw py::type_error(std::string(what) + ": __dlpack__ returned no DLPack capsule");
    }
    auto* managed = static_cast<DLManagedTensor*>(PyCapsule_GetPointer(capsule.ptr(), "dltensor"));
    if (managed == nullptr || PyCapsule_SetName(capsule.ptr(), "used_dltensor") != 0) throw py::error_already_set();
    managed_.reset(managed);  // consumed: the deleter is ours to call now, not the capsule's
    const DLTensor& t = managed_->dl_tensor;
    if (t.device.device_type != kDLCUDA || t.device.device_id != device) {
      throw py::value_error(std::string(what) + ": not on CUDA device " + std::to_string(device));
    }
    if (t.dtype.code != 2 || t.dtype.bits != 32 || t.dtype.lanes != 1) {
      throw py::value_error(std::string(what) + ": a CUDA array must be float32 (torch tensors are converted)");
    }
    shape_.assign(t.shape, t.shape + t.ndim);
    if (t.strides != nullptr) {
      int64_t expected = 1;
      for (int32_t d = t.ndim - 1; d >= 0; --d) {
        if (shape_[size_t(d)] != 1 && t.strides[d] != expected) {
          throw py::value_error(std::string(what) + ": a CUDA array must be C-contiguous (torch tensors are made so)");
        }
        expected *= shape_[size_t(d)];
      }
    }
    data_ = reinterpret_cast<const float*>(static_cast<const char*>(t.data) + t.byte_offset);
  }

  const float* data() const { return data_; }
  const std::vector<int64_t>& shape() const { return shape_; }

 private:
  std::unique_ptr<DLManagedTensor, void (*)(DLManagedTensor*)> managed_{nullptr, release_managed};
  std::vector<int64_t> shape_;
  const float* data_ = nullptr;
};

/// The five Gaussian arrays of a call borrowed from CUDA memory, as api::DeviceGaussians: the shapes and SH
/// rules of the host path (cloud_from_arrays, reduce_sh_degree: colours [N, K, 3] rendered at
/// min(sh_degree, degree of K), or RGB [N, 3] when `rgb`).
class DeviceGaussiansArrays {
 public:
  DeviceGaussiansArrays(const py::object& means, const py::object& quats, const py::object& scales,
                        const py::object& opacities, const py::object& colors, bool rgb,
                        std::optional<uint32_t> sh_degree, int device, int64_t stream)
      : means_(means, "means", device, stream),
        quats_(quats, "quats", device, stream),
        scales_(scales, "scales", device, stream),
        opacities_(opacities, "opacities", device, stream),
        colors_(colors, rgb ? "colors" : "sh", device, stream) {
    size_t n = 0;
    check_dims(means_.shape(), "means", &n, {3});
    check_dims(quats_.shape(), "quats", &n, {4});
    check_dims(scales_.shape(), "scales", &n, {3});
    std::vector<int64_t> opacity_shape = opacities_.shape();
    if (opacity_shape.size() == 2 && opacity_shape[1] == 1) opacity_shape.pop_back();
    check_dims(opacity_shape, "opacities", &n, {});
    uint32_t degree = 0;
    if (rgb) {
      size_t m = n;
      check_dims(colors_.shape(), "colors", &m, {3});
    } else {
      degree = sh_degree_of(colors_.shape());
      size_t m = n;
      check_dims(colors_.shape(), "sh", &m, {int64_t(format::sh_coefficient_count(degree)), 3});
      g_.sh_coefficients = format::sh_coefficient_count(degree);
      if (sh_degree) {
        if (*sh_degree > 3) {
          raise(Status(StatusCode::kInvalidArgument,
                       "SH degree " + std::to_string(*sh_degree) + " is above 3, the highest a cloud holds"));
        }
        degree = std::min(degree, *sh_degree);
      }
    }
    g_.means = means_.data();
    g_.quats = quats_.data();
    g_.scales = scales_.data();
    g_.opacities = opacities_.data();
    g_.colors = colors_.data();
    g_.count = n;
    g_.sh_degree = degree;
    g_.rgb = rgb;
  }

  const api::DeviceGaussians& gaussians() const { return g_; }

 private:
  DeviceArray means_, quats_, scales_, opacities_, colors_;
  api::DeviceGaussians g_;
};

/// What identifies the Gaussian arrays of a rasterization() call for the upload cache: each tensor itself
/// (weakly referenced: the cache keeps no tensor alive), its version counter (torch's _version, bumped by
/// every in-place change through the tensor or its views), data pointer, shape, strides and dtype, and how
/// its colours are read.
struct ArraysKey {
  std::vector<py::weakref> tensors;
  std::vector<int64_t> versions, pointers;
  std::vector<std::vector<int64_t>> shapes, strides;
  std::vector<std::string> dtypes;
  bool rgb = false;
  std::optional<uint32_t> sh_degree;

  /// Equal arrays: the same live tensors, unchanged. Needs the GIL.
  bool matches(const ArraysKey& other) const {
    if (tensors.size() != other.tensors.size()) return false;
    for (size_t i = 0; i < tensors.size(); ++i) {
      const py::object a = tensors[i](), b = other.tensors[i]();
      if (a.is_none() || !a.is(b)) return false;
    }
    return versions == other.versions && pointers == other.pointers && shapes == other.shapes &&
           strides == other.strides && dtypes == other.dtypes && rgb == other.rgb && sh_degree == other.sh_degree;
  }
};

/// The cache key of five torch tensors; nullopt when any is not a torch tensor (other arrays are never cached).
std::optional<ArraysKey> arrays_key(const std::array<const py::object*, 5>& arrays, bool rgb,
                                    std::optional<uint32_t> sh_degree) {
  ArraysKey key;
  key.rgb = rgb;
  key.sh_degree = sh_degree;
  for (const py::object* obj : arrays) {
    if (!is_torch_tensor(*obj)) return std::nullopt;
    key.tensors.emplace_back(*obj);
    key.versions.push_back(obj->attr("_version").cast<int64_t>());
    key.pointers.push_back(obj->attr("data_ptr")().cast<int64_t>());
    key.shapes.push_back(obj->attr("shape").cast<std::vector<int64_t>>());
    key.strides.push_back(obj->attr("stride")().cast<std::vector<int64_t>>());
    key.dtypes.push_back(py::str(obj->attr("dtype")));
  }
  return key;
}

/// The `edits` argument of convert() or save() (`fn`): a sequence of (name, value) pairs of str in rgs-convert's
/// spelling, parsed by converter::parse_edit_action (("filter-nan",) or ("filter-nan", "") for the flag).
/// TypeError for other types; ValueError "fn(): edits[i]: <the parser's message>".
std::vector<converter::EditAction> edits_arg(py::handle value, const char* fn) {
  const char* pairs = "a sequence of (name, value) pairs of str";
  if (py::isinstance<py::str>(value) || !py::isinstance<py::sequence>(value)) {
    throw type_error(fn, "edits", pairs, value);
  }
  std::vector<converter::EditAction> edits;
  for (const py::handle item : value) {
    const std::string where = "edits[" + std::to_string(edits.size()) + "]";
    if (py::isinstance<py::str>(item) || !py::isinstance<py::sequence>(item)) {
      throw type_error(fn, where.c_str(), "a (name, value) pair of str", item);
    }
    const auto pair = py::reinterpret_borrow<py::sequence>(item);
    if (pair.size() != 1 && pair.size() != 2) {
      throw value_error(fn, where.c_str(), "a (name, value) pair", py::repr(item).cast<std::string>());
    }
    const std::string name = str_arg(pair[0], fn, where.c_str());
    const std::string text = pair.size() == 2 ? str_arg(pair[1], fn, where.c_str()) : std::string();
    auto edit = converter::parse_edit_action(name, text);
    if (!edit.ok()) throw py::value_error(std::string(fn) + "(): " + where + ": " + edit.status().message());
    edits.push_back(std::move(edit).value());
  }
  return edits;
}

/// ConvertOptions from the keyword arguments of convert() or save() (`fn`) that are not the target's (the
/// defaults are ConvertOptions's own).
api::ConvertOptions convert_options(const char* fn, const py::kwargs& kwargs) {
  if (kwargs.contains("lod_chunk") && !kwargs.contains("lod_levels")) {
    throw py::value_error(std::string(fn) + "(): lod_chunk requires lod_levels, as rgs-convert's --lod-chunk does");
  }
  api::ConvertOptions o;
  o.converter_name = "roofgs python";
  py::object spz_frame = py::str("rub");
  for (const auto& [key_obj, value] : kwargs) {
    const std::string key = py::str(key_obj);
    if (key == "to") {
      if (!value.is_none()) o.to = unwrap(api::parse_output_format(str_arg(value, fn, "to")));
    } else if (key == "scale_encoding") {
      const std::string e = str_arg(value, fn, "scale_encoding");
      if (e != "log" && e != "linear") raise(Status(StatusCode::kInvalidArgument, "scale_encoding must be 'linear' or 'log'"));
      o.scale_encoding = e == "log" ? format::ScaleEncoding::kLog : format::ScaleEncoding::kLinear;
    } else if (key == "profile") {
      const std::string p = str_arg(value, fn, "profile");
      if (p != "archive" && p != "runtime") raise(Status(StatusCode::kInvalidArgument, "profile must be 'runtime' or 'archive'"));
      o.profile = p == "archive" ? format::StorageProfile::kArchive : format::StorageProfile::kRuntime;
    } else if (key == "sh_clip_percentile") {
      o.sh_clip_percentile = float(float_arg(value, fn, "sh_clip_percentile", {0.001, 100.0}));
    } else if (key == "sh_dc_bits") {
      o.sh_dc_bits = int_arg<uint32_t>(value, fn, "sh_dc_bits", 8, 16);
      if (o.sh_dc_bits != 8 && o.sh_dc_bits != 16) throw value_error(fn, "sh_dc_bits", "8 or 16", py::repr(value));
    } else if (key == "zstd") {
      o.zstd_sections = cast_arg<std::vector<std::string>>(value, fn, "zstd", "a sequence of str");
    } else if (key == "zstd_level") {
      o.zstd_level = int_arg<int>(value, fn, "zstd_level", 1, 22);
    } else if (key == "position_error") {
      o.archive.position_error = float_arg(value, fn, "position_error", {1e-9, 0.5});
    } else if (key == "sh_degree") {
      if (!value.is_none()) o.sh_degree = int_arg<uint32_t>(value, fn, "sh_degree", 0, 3);
    } else if (key == "lod") {
      if (!value.is_none()) o.read.lod = int_arg<uint32_t>(value, fn, "lod", 0, 63);
    } else if (key == "lod_levels") {
      if (py::isinstance<py::str>(value)) {
        if (value.cast<std::string>() != "auto") {
          throw value_error(fn, "lod_levels", "'auto' or an integer in 1..16", py::repr(value));
        }
        o.lod_levels = 0;
      } else if (!value.is_none()) {
        if (PyBool_Check(value.ptr()) || !PyIndex_Check(value.ptr())) {
          throw type_error(fn, "lod_levels", "'auto' or an int", value);
        }
        o.lod_levels = int_arg<uint32_t>(value, fn, "lod_levels", 1, 16);
      }
    } else if (key == "lod_chunk") {
      o.lod_chunk_gaussians = int_arg<uint32_t>(value, fn, "lod_chunk", 1, uint32_t{1} << 30);
    } else if (key == "memory_limit") {
      o.memory_limit = int_arg<uint64_t>(value, fn, "memory_limit");
    } else if (key == "max_gaussians") {
      o.read.max_gaussians = int_arg<uint64_t>(value, fn, "max_gaussians", 1);
    } else if (key == "max_decompression_ratio") {
      o.read.max_decompression_ratio = int_arg<uint32_t>(value, fn, "max_decompression_ratio", 1, 32768);
    } else if (key == "spz_frame") {
      if (!value.is_none()) spz_frame = py::reinterpret_borrow<py::object>(value);
    } else if (key == "antialiased") {
      o.read.antialiased = cast_arg<bool>(value, fn, "antialiased", "a bool");
    } else if (key == "sanitize") {
      o.sanitize = cast_arg<bool>(value, fn, "sanitize", "a bool");
    } else if (key == "allow_empty") {
      o.allow_empty = cast_arg<bool>(value, fn, "allow_empty", "a bool");
    } else if (key == "edits") {
      if (!value.is_none()) o.edits = edits_arg(value, fn);
    } else {
      const py::object accepted = py::module_::import("roofgs").attr("_keyword_options")(fn);
      throw py::type_error("unexpected keyword argument '" + key + "'; the options are " +
                           py::str(", ").attr("join")(accepted).cast<std::string>());
    }
  }
  const converter::SceneReadOptions read = read_options(spz_frame);
  o.read.spz_frame = read.spz_frame;
  o.read.spz_frame_by_path = read.spz_frame_by_path;
  return o;
}

/// The device `name` asks for: "auto" is CUDA when a device answers, else the CPU (with a warning);
/// "cuda" without a device raises an error that names the alternatives.
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

/// The CUDA device whose memory holds the Gaussian arrays when they are to be read there: all five on one
/// device, `device` not "cpu", and for "auto" a build and host with CUDA (else they go through host memory, as
/// "auto" then renders on the CPU). "cuda" without a usable device raises resolve_device's error.
std::optional<int> device_arrays_device(const std::array<const py::object*, 5>& arrays, const std::string& device) {
  if (device == "cpu") return std::nullopt;
  const std::optional<int> cuda = arrays_cuda_device(arrays);
  if (!cuda) return std::nullopt;
  if (device != "auto") {
    resolve_device(device);
  } else if (!api::cuda_available()) {
    return std::nullopt;
  }
  return cuda;
}

/// A scene and the renderer Python uses for it (created on first render; calls serialized by a mutex), and the
/// counts of the last frame rendered through it.
struct PyScene {
  api::Scene scene;
  int cuda_device = 0;  // the device of a CUDA scene
  std::unique_ptr<api::Renderer> renderer;
  std::mutex mutex;
  std::optional<api::FrameStats> last_stats;  // guarded by mutex

  explicit PyScene(api::Scene s, int device = 0) : scene(std::move(s)), cuda_device(device) {}

  py::object render(const api::Camera& camera_in, const StrArg& preset, const std::optional<IntArg>& width_arg,
                    const std::optional<IntArg>& height_arg, const PointArg& background, const StrArg& format,
                    bool depth, const py::object& stream, const IntArg& scratch_budget) {
    const std::optional<uint32_t> width = int_arg<uint32_t>(width_arg, "render", "width", 1, kMaxImageSide);
    const std::optional<uint32_t> height = int_arg<uint32_t>(height_arg, "render", "height", 1, kMaxImageSide);
    const std::array<double, 3> rgb = arr<3>(background, "render", "background");
    api::RenderSettings settings;
    settings.preset = unwrap(api::parse_preset(str_arg(preset, "render", "preset")));
    settings.background = {float(rgb[0]), float(rgb[1]), float(rgb[2])};
    settings.gpu_scratch_budget = int_arg<uint64_t>(scratch_budget, "render", "scratch_budget");
    const api::PixelFormat pixel_format = unwrap(api::parse_pixel_format(str_arg(format, "render", "format")));
    const api::Stream s = stream.is_none() ? nullptr
                                           : reinterpret_cast<api::Stream>(static_cast<uintptr_t>(
                                                 int_arg<int64_t>(stream, "render", "stream")));
    api::Camera camera = camera_in;
    if (width || height) {
      // One side alone keeps the camera's aspect ratio (as rgs-render --width does).
      const double aspect = double(camera.height) / double(camera.width);
      const uint32_t w = width ? *width : uint32_t(std::max(1.0, std::round(double(*height) / aspect)));
      const uint32_t h = height ? *height : uint32_t(std::max(1.0, std::round(double(*width) * aspect)));
      if (w != camera.width || h != camera.height) camera = runtime::resize_camera(camera, w, h);
    }
    Result<api::Image> image = Status(StatusCode::kInvalidArgument, "not rendered");
    {
      py::gil_scoped_release release;
      std::lock_guard<std::mutex> lock(mutex);
      if (!renderer) {
        auto created = api::Renderer::create(scene.device(), cuda_device);
        if (!created.ok()) {
          image = created.status();
        } else {
          renderer = std::make_unique<api::Renderer>(std::move(created).value());
        }
      }
      if (renderer) image = renderer->render_image(scene, camera, settings, pixel_format, depth, s);
      if (image.ok()) last_stats = image->frame_stats();
    }
    auto shared = std::make_shared<api::Image>(unwrap(std::move(image)));
    ImagePlane colour{shared, false};
    if (scene.device() == api::Device::kCpu) {
      py::array rgba = plane_numpy(colour);
      if (!depth) return rgba;
      return py::make_tuple(rgba, plane_numpy(ImagePlane{shared, true}));
    }
    if (!depth) return py::cast(colour);
    return py::make_tuple(py::cast(colour), py::cast(ImagePlane{shared, true}));
  }
};

/// The views of a rasterization() call: gsplat's viewmats [C, 4, 4] and Ks [C, 3, 3] as cameras, and their
/// backgrounds [C, 3] (black when none).
struct GsplatViews {
  std::vector<api::Camera> cameras;
  std::vector<std::array<float, 3>> backgrounds;
};

GsplatViews gsplat_views(const py::object& viewmats, const py::object& Ks, const py::object& backgrounds,
                         uint32_t width, uint32_t height, float near_plane) {
  const auto views = float_array(viewmats, "viewmats"), intrinsics = float_array(Ks, "Ks");
  size_t count = 0;
  check_shape(views, "viewmats", &count, {4, 4});
  check_shape(intrinsics, "Ks", &count, {3, 3});
  GsplatViews out;
  out.backgrounds.assign(count, {0.f, 0.f, 0.f});
  if (!backgrounds.is_none()) {
    const auto b = float_array(backgrounds, "backgrounds");
    check_shape(b, "backgrounds", &count, {3});
    for (size_t c = 0; c < count; ++c) out.backgrounds[c] = {b.data()[c * 3], b.data()[c * 3 + 1], b.data()[c * 3 + 2]};
  }
  api::CameraOptions camera_options;
  camera_options.near_plane = near_plane;
  for (size_t c = 0; c < count; ++c) {
    const float* v = views.data() + c * 16;
    const float* k = intrinsics.data() + c * 9;
    // gsplat's K puts pixel centres at half-integers (corner origin); camera_from_opencv's at integers.
    const std::array<double, 9> K{k[0], k[1], k[2] - 0.5, k[3], k[4], k[5] - 0.5, k[6], k[7], k[8]};
    const std::array<double, 9> R{v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]};
    const std::array<double, 3> t{v[3], v[7], v[11]};
    out.cameras.push_back(unwrap(api::camera_from_opencv(K, R, t, width, height, camera_options)));
  }
  return out;
}

/// rasterization()'s meta dict: the preset, the size, and the (tile, Gaussian) pairs of each view.
py::dict gsplat_meta(const std::string& preset, uint32_t width, uint32_t height, const std::vector<uint64_t>& pairs) {
  py::dict meta;
  meta["preset"] = preset;
  meta["width"] = width;
  meta["height"] = height;
  meta["n_cameras"] = pairs.size();
  meta["pairs"] = pairs;
  return meta;
}

/// The renderer, scratch frame and last upload of rasterization() on one CUDA device, shared by the calls
/// (serialized by the mutex, which is only waited for without the GIL).
struct CudaRasterizer {
  std::mutex mutex;
  std::optional<api::Renderer> renderer;
  std::optional<api::Image> frame;  // rgba32f (+ depth) of the last size: rendered into, then split
  std::optional<api::Scene> scene;  // the last upload
  std::optional<ArraysKey> key;     // its tensors, when they can be recognized again
  std::optional<int64_t> stream;    // the stream of the last call
};

CudaRasterizer& cuda_rasterizer(int device) {
  // Never destroyed: its Python references and device memory must not be released after the interpreter and
  // the CUDA runtime have shut down.
  static auto* states = new std::map<int, std::unique_ptr<CudaRasterizer>>();
  std::unique_ptr<CudaRasterizer>& state = (*states)[device];  // under the GIL
  if (!state) state = std::make_unique<CudaRasterizer>();
  return *state;
}

/// rasterization() on Gaussians in CUDA memory: uploaded on the device (or taken from the cache), rendered
/// view by view into a scratch frame and split into torch tensors on torch's current stream.
py::tuple rasterization_cuda(int device, const std::array<const py::object*, 5>& arrays, bool rgb,
                             std::optional<uint32_t> sh_degree, bool antialiased, const GsplatViews& views, uint32_t width,
                             uint32_t height, bool rgb_out, api::DepthOutput depth, const std::string& preset,
                             bool cache) {
  const py::module_ torch = import_torch();
  api::RenderSettings settings;
  settings.preset = unwrap(api::parse_preset(preset));
  const TorchDeviceGuard guard(torch, device);
  CudaRasterizer& state = cuda_rasterizer(device);
  std::unique_lock<std::mutex> lock(state.mutex, std::defer_lock);
  {
    py::gil_scoped_release release;
    lock.lock();
  }
  const int64_t stream = torch_stream(torch, device);
  // The scratch frame and the renderer's buffers were last used on another stream: let that work finish.
  if (state.stream && *state.stream != stream) torch.attr("cuda").attr("synchronize")(device);
  state.stream = stream;
  const api::Stream s = reinterpret_cast<api::Stream>(static_cast<uintptr_t>(stream));

  std::optional<ArraysKey> key = cache ? arrays_key(arrays, rgb, sh_degree) : std::nullopt;
  const bool upload = !key || !state.key || !state.scene || !key->matches(*state.key) ||
                      state.scene->info().antialiased != antialiased;
  if (upload) {
    state.scene.reset();  // frees the last upload before the next one
    state.key.reset();
    const DeviceGaussiansArrays borrowed(*arrays[0], *arrays[1], *arrays[2], *arrays[3], *arrays[4], rgb,
                                         sh_degree, device, stream);
    api::DeviceLoadOptions options;
    options.cuda_device = device;
    options.stream = s;
    options.antialiased = antialiased;
    Result<api::Scene> scene = Status(StatusCode::kInvalidArgument, "not loaded");
    {
      py::gil_scoped_release release;
      scene = api::load_device_gaussians(borrowed.gaussians(), options);
    }
    state.scene.emplace(unwrap(std::move(scene)));
    state.key = std::move(key);
  }

  const size_t cameras = views.cameras.size();
  const size_t pixels = size_t(width) * height;
  const int64_t channels = (rgb_out ? 3 : 0) + (depth != api::DepthOutput::kNone ? 1 : 0);
  const py::object options = py::dict(py::arg("dtype") = torch.attr("float32"),
                                      py::arg("device") = torch.attr("device")("cuda", device));
  const auto empty = [&](int64_t c) {
    return torch.attr("empty")(py::make_tuple(cameras, height, width, c), **options);
  };
  py::object out_colors = empty(channels), out_alphas = empty(1);
  float* colors = reinterpret_cast<float*>(out_colors.attr("data_ptr")().cast<uintptr_t>());
  float* alphas = reinterpret_cast<float*>(out_alphas.attr("data_ptr")().cast<uintptr_t>());
  std::vector<uint64_t> pairs;
  Status status;
  {
    py::gil_scoped_release release;
    auto run = [&]() -> Status {
      if (!state.renderer) {
        RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(api::Device::kCuda, device));
        state.renderer.emplace(std::move(renderer));
      }
      const bool with_depth = depth != api::DepthOutput::kNone;
      for (size_t c = 0; c < cameras; ++c) {
        settings.background = views.backgrounds[c];
        const api::Camera& camera = views.cameras[c];
        api::FrameStats stats;
        if (state.frame && state.frame->width() == width && state.frame->height() == height &&
            (state.frame->depth() != nullptr) == with_depth) {
          RGS_ASSIGN_OR_RETURN(stats, state.renderer->render(*state.scene, camera, settings, state.frame->target(), s));
        } else {
          state.frame.reset();
          RGS_ASSIGN_OR_RETURN(api::Image frame, state.renderer->render_image(*state.scene, camera, settings,
                                                                              api::PixelFormat::kRgba32f,
                                                                              with_depth, s));
          stats = frame.frame_stats();
          state.frame.emplace(std::move(frame));
        }
        api::PlanarTarget target;
        target.colors = colors + c * pixels * size_t(channels);
        target.rgb = rgb_out;
        target.depth = depth;
        target.alphas = alphas + c * pixels;
        RGS_RETURN_IF_ERROR(api::write_planar(*state.frame, target, s));
        pairs.push_back(stats.pairs);
      }
      return Status();
    };
    status = run();
    // An upload nothing can recognize again is not kept (freeing it waits for the frames that read it).
    if (!state.key) state.scene.reset();
  }
  check(status);
  py::dict meta = gsplat_meta(preset, width, height, pairs);
  meta["uploaded"] = upload;  // false: the Gaussians of the last call were rendered again
  return py::make_tuple(out_colors, out_alphas, meta);
}

/// gsplat's rasterization() for inference on one batch element (the Python rasterization() below checks
/// gsplat's options, loops over leading batch dimensions and returns the caller's array type).
py::tuple rasterization(const py::object& means, const py::object& quats, const py::object& scales,
                        const py::object& opacities, const py::object& colors, const py::object& viewmats,
                        const py::object& Ks, const IntArg& width_arg, const IntArg& height_arg,
                        const FloatArg& near_plane_arg, const std::optional<IntArg>& sh_degree_arg,
                        const py::object& backgrounds, const StrArg& render_mode_arg, bool antialiased,
                        const StrArg& preset_arg, const StrArg& device_arg, bool cache) {
  const char* fn = "rasterization";
  const uint32_t width = int_arg<uint32_t>(width_arg, fn, "width", 1, kMaxImageSide);
  const uint32_t height = int_arg<uint32_t>(height_arg, fn, "height", 1, kMaxImageSide);
  const float near_plane = float(float_arg(near_plane_arg, fn, "near_plane", kPositive));
  const std::optional<uint32_t> sh_degree = int_arg<uint32_t>(sh_degree_arg, fn, "sh_degree");
  const std::string render_mode = str_arg(render_mode_arg, fn, "render_mode");
  const std::string preset = str_arg(preset_arg, fn, "preset"), device = str_arg(device_arg, fn, "device");
  const bool rgb_out = render_mode.rfind("RGB", 0) == 0;
  const std::string depth_mode = rgb_out ? (render_mode.size() > 3 ? render_mode.substr(4) : "") : render_mode;
  if ((rgb_out && render_mode.size() > 3 && render_mode[3] != '+') || (depth_mode != "" && depth_mode != "D" &&
                                                                       depth_mode != "ED")) {
    throw value_error(fn, "render_mode", "RGB, D, ED, RGB+D or RGB+ED", py::repr(render_mode_arg));
  }
  const GsplatViews views = gsplat_views(viewmats, Ks, backgrounds, width, height, near_plane);
  const std::array<const py::object*, 5> arrays{&means, &quats, &scales, &opacities, &colors};
  if (const std::optional<int> cuda = device_arrays_device(arrays, device)) {
    const api::DepthOutput depth = depth_mode.empty()  ? api::DepthOutput::kNone
                                   : depth_mode == "D" ? api::DepthOutput::kAccumulated
                                                       : api::DepthOutput::kExpected;
    return rasterization_cuda(*cuda, arrays, !sh_degree, sh_degree, antialiased, views, width, height, rgb_out, depth,
                              preset, cache);
  }
  format::GaussianCloud cloud = cloud_from_arrays(means, quats, scales, opacities, colors, !sh_degree);
  if (sh_degree) check(converter::reduce_sh_degree(&cloud, *sh_degree));
  cloud.antialiased = antialiased;
  api::LoadOptions load;
  load.device = resolve_device(device);
  api::RenderSettings settings;
  settings.preset = unwrap(api::parse_preset(preset));
  const size_t cameras = views.cameras.size();
  const size_t pixels = size_t(width) * height;
  py::array_t<float> out_colors({py::ssize_t(cameras), py::ssize_t(height), py::ssize_t(width),
                                 py::ssize_t(rgb_out ? 3 : 0) + (depth_mode.empty() ? 0 : 1)});
  py::array_t<float> out_alphas({py::ssize_t(cameras), py::ssize_t(height), py::ssize_t(width), py::ssize_t(1)});
  std::vector<uint64_t> pairs;
  Status status;
  {
    py::gil_scoped_release release;
    std::vector<float> rgba(pixels * 4), depth(pixels);
    float* colors_out = out_colors.mutable_data();
    float* alphas_out = out_alphas.mutable_data();
    const size_t channels = size_t(out_colors.shape(3));
    auto run = [&]() -> Status {
      RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::scene_from_cloud(std::move(cloud), "arrays"));
      RGS_ASSIGN_OR_RETURN(api::Scene scene, api::load_cloud(std::move(input.cloud), input.bounds, "arrays", load));
      RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(scene.device(), 0));
      for (size_t c = 0; c < cameras; ++c) {
        settings.background = views.backgrounds[c];
        RGS_ASSIGN_OR_RETURN(api::Image image, renderer.render_image(scene, views.cameras[c], settings,
                                                                      api::PixelFormat::kRgba32f, !depth_mode.empty()));
        RGS_RETURN_IF_ERROR(image.copy_to_host(rgba.data(), depth_mode.empty() ? nullptr : depth.data()));
        for (size_t i = 0; i < pixels; ++i) {
          float* px = colors_out + (c * pixels + i) * channels;
          const float alpha = rgba[i * 4 + 3];
          if (rgb_out) std::copy(&rgba[i * 4], &rgba[i * 4 + 3], px);
          if (!depth_mode.empty()) px[channels - 1] = depth_mode == "D" ? depth[i] * alpha : depth[i];
          alphas_out[c * pixels + i] = alpha;
        }
        pairs.push_back(image.frame_stats().pairs);
      }
      return Status();
    };
    status = run();
  }
  check(status);
  return py::make_tuple(out_colors, out_alphas, gsplat_meta(preset, width, height, pairs));
}

}  // namespace

/// convert() and save() (`fn`, which their errors name): the options of rgs-convert in `kwargs` (by the
/// snake_case of their long options; None never passed), written by `write` (api::convert, api::convert_cloud);
/// with target_psnr / target_bytes the conversion fits the archive profile to them (ConvertOptions::target).
/// Returns the report's dict: rgs-convert --json's (api::convert_report_json) for `src` converted into `dst`.
py::dict convert_with_options(const char* fn, py::kwargs kwargs, const std::string& src, const std::string& dst,
                              const std::function<Result<api::ConvertReport>(const api::ConvertOptions&)>& write) {
  // The target and its views (api::ConvertTarget); the rest are ConvertOptions.
  api::ConvertTarget target;
  auto take = [&](const char* key) -> std::optional<py::object> {
    if (!kwargs.contains(key)) return std::nullopt;
    py::object value = kwargs[key];
    PyDict_DelItemString(kwargs.ptr(), key);
    if (value.is_none()) return std::nullopt;
    return value;
  };
  constexpr uint32_t kMaxCount = 100000, kMaxEvery = 2147483647;
  const char* path_name = std::string(fn) == "save" ? "camera_path" : "path";  // save()'s `path` is its output
  api::CameraChoice& views = target.views;
  if (auto v = take("target_psnr")) target.psnr_db = float_arg(*v, fn, "target_psnr", {1.0, 200.0});
  if (auto v = take("target_bytes")) target.bytes = int_arg<uint64_t>(*v, fn, "target_bytes", 1);
  if (auto v = take("cameras")) views.cameras_path = path_arg(*v, fn, "cameras").string();
  if (auto v = take("every")) views.every = int_arg<uint32_t>(*v, fn, "every", 1, kMaxEvery);
  if (auto v = take("limit")) views.limit = int_arg<uint32_t>(*v, fn, "limit", 1, kMaxEvery);
  if (auto v = take("orbit")) views.orbit = int_arg<uint32_t>(*v, fn, "orbit", 1, kMaxCount);
  if (auto v = take(path_name)) views.path = int_arg<uint32_t>(*v, fn, path_name, 1, kMaxCount);
  if (auto v = take("fly")) views.fly = int_arg<uint32_t>(*v, fn, "fly", 1, kMaxCount);
  if (auto v = take("width")) views.width = int_arg<uint32_t>(*v, fn, "width", 11, kMaxImageSide);
  if (auto v = take("height")) views.height = int_arg<uint32_t>(*v, fn, "height", 11, kMaxImageSide);
  api::ConvertOptions options = convert_options(fn, kwargs);
  if (target.active()) target.device = api::cuda_available() ? api::Device::kCuda : api::Device::kCpu;
  options.target = std::move(target);
  Result<api::ConvertReport> r = Status(StatusCode::kInvalidArgument, "not converted");
  {
    py::gil_scoped_release release;
    r = write(options);
  }
  const std::string report = api::convert_report_json(unwrap(std::move(r)), src, dst, options);
  return py::module_::import("json").attr("loads")(report);
}

#if RGS_WITH_VIEWER
/// roofgs.view()'s handle: a running rgs-view server (view/PROTOCOL.md) in this process.
struct PyViewServer {
  std::optional<view::Server> server;
  std::string url;
  uint32_t height = 600;  // of the notebook's iframe

  void stop() {
    py::gil_scoped_release release;  // joins the server's threads, none of which calls Python
    if (server) server->stop();
  }
};

/// A scene argument of roofgs.view(): a roofgs.Scene as loaded, or a path loaded for the viewer on `device`
/// (every preset it can render: view::load_view_scene).
api::Scene view_scene(const py::object& scene_or_path, const std::string& device, int cuda_device) {
  if (py::isinstance<PyScene>(scene_or_path)) return scene_or_path.cast<PyScene&>().scene;
  api::LoadOptions options;
  options.device = resolve_device(device);
  options.cuda_device = cuda_device;
  const std::string path = scene_or_path.cast<std::filesystem::path>().string();
  py::gil_scoped_release release;
  return unwrap(view::load_view_scene(path, options));
}
#endif

PYBIND11_MODULE(roofgs, m) {
  m.doc() =
      "RoofGS: load scenes (.rgs, 3DGS PLY, PlayCanvas compressed PLY, SOG meta.json/.sog/folder, streamed SOG "
      "lod-meta.json, SPZ, .splat, glTF/GLB), render them with presets on the GPU or the CPU reference, convert "
      "and audit them";
  m.def(
      "cuda_status",
      [] {
        std::string why;
        const bool available = api::cuda_available(&why);
        return py::dict(py::arg("built_with_cuda") = bool(RGS_HAS_CUDA), py::arg("available") = available,
                        py::arg("reason") = available ? std::string() : why);
      },
      "Whether CUDA renders here: a dict of built_with_cuda, available (a device answers) and reason (why not, "
      "as CUDA says it; empty when available)");
  m.attr("__version__") = RGS_VERSION_STRING;
  m.attr("built_with_cuda") = bool(RGS_HAS_CUDA);
  m.attr("has_cuda") = api::cuda_available();

  static py::exception<StatusError> error_type(m, "Error", PyExc_RuntimeError);
  g_error_type = error_type.ptr();
  error_type.doc() = "A RoofGS operation failed; .code is the StatusCode number, .code_name its name";
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const StatusError& e) {
      const std::string message = e.status.to_string();
      PyObject* exc = PyObject_CallFunction(g_error_type, "s", message.c_str());
      if (exc == nullptr) return;
      PyObject_SetAttrString(exc, "code", py::int_(int(e.status.code())).ptr());
      PyObject_SetAttrString(exc, "code_name", py::str(status_code_name(e.status.code())).ptr());
      PyObject_SetAttrString(exc, "message", py::str(e.status.message()).ptr());
      PyErr_SetObject(g_error_type, exc);
      Py_DECREF(exc);
    }
  });

  py::class_<api::Camera>(m, "Camera", "Pinhole camera, COLMAP frame (x right, y down, z forward)")
      .def_property_readonly(
          "rotation",
          [](const api::Camera& c) {
            py::array_t<float> r({3, 3});
            std::copy(c.rotation.begin(), c.rotation.end(), r.mutable_data());
            return r;
          },
          "world-to-camera R [3, 3]")
      .def_property_readonly(
          "translation",
          [](const api::Camera& c) { return std::vector<float>(c.translation.begin(), c.translation.end()); })
      .def_readonly("fx", &api::Camera::fx)
      .def_readonly("fy", &api::Camera::fy)
      .def_readonly("cx", &api::Camera::cx)
      .def_readonly("cy", &api::Camera::cy)
      .def_readonly("width", &api::Camera::width)
      .def_readonly("height", &api::Camera::height)
      .def_readonly("near_plane", &api::Camera::near_plane)
      .def_readonly("name", &api::Camera::name)
      .def(
          "project",
          [](const api::Camera& c, const PointArg& point) {
            const std::array<double, 3> p = arr<3>(point, "project", "point");
            double q[3];
            for (int r = 0; r < 3; ++r) {
              q[r] = c.translation[size_t(r)];
              for (int k = 0; k < 3; ++k) q[r] += double(c.rotation[size_t(3 * r + k)]) * p[size_t(k)];
            }
            return std::make_tuple(c.fx * q[0] / q[2] + c.cx - 0.5, c.fy * q[1] / q[2] + c.cy - 0.5, q[2]);
          },
          py::arg("point"),
          "Pixel (x, y) with pixel centres at integers, and view depth z, of `point` (x, y, z in world units); "
          "z <= 0 is behind the camera")
      .def("resized",
           [](const api::Camera& c, const IntArg& width, const IntArg& height) {
             return runtime::resize_camera(c, int_arg<uint32_t>(width, "resized", "width", 1, kMaxImageSide),
                                           int_arg<uint32_t>(height, "resized", "height", 1, kMaxImageSide));
           },
           py::arg("width"), py::arg("height"), "The same view at width x height (field of view kept)")
      .def("__repr__", [](const api::Camera& c) {
        return "<roofgs.Camera " + std::to_string(c.width) + "x" + std::to_string(c.height) + " fx=" +
               std::to_string(c.fx) + " '" + c.name + "'>";
      });

  m.def("camera_from_inria",
        [](py::object rotation_c2w, py::object position, const FloatArg& fx, const FloatArg& fy, const IntArg& width,
           const IntArg& height, const FloatArg& near_plane, const StrArg& name) {
          const char* fn = "camera_from_inria";
          const CameraArgs a = camera_args(fn, width, height, near_plane, name);
          return unwrap(api::camera_from_inria(arr<3, 3>(rotation_c2w, fn, "rotation_c2w"),
                                               arr<3>(position, fn, "position"), float_arg(fx, fn, "fx", kPositive),
                                               float_arg(fy, fn, "fy", kPositive), a.width, a.height, a.options));
        },
        py::arg("rotation_c2w"), py::arg("position"), py::arg("fx"), py::arg("fy"), py::arg("width"),
        py::arg("height"), py::arg("near_plane") = 0.2f, py::arg("name") = "",
        "INRIA cameras.json entry: camera-to-world rotation [3, 3], camera centre, focal lengths in pixels");
  m.def("camera_from_colmap",
        [](py::object qvec, py::object tvec, const FloatArg& fx, const FloatArg& fy, const FloatArg& cx,
           const FloatArg& cy, const IntArg& width, const IntArg& height, const FloatArg& near_plane,
           const StrArg& name) {
          const char* fn = "camera_from_colmap";
          const CameraArgs a = camera_args(fn, width, height, near_plane, name);
          return unwrap(api::camera_from_colmap(arr<4>(qvec, fn, "qvec"), arr<3>(tvec, fn, "tvec"),
                                                float_arg(fx, fn, "fx", kPositive), float_arg(fy, fn, "fy", kPositive),
                                                float_arg(cx, fn, "cx"), float_arg(cy, fn, "cy"), a.width, a.height,
                                                a.options));
        },
        py::arg("qvec"), py::arg("tvec"), py::arg("fx"), py::arg("fy"), py::arg("cx"), py::arg("cy"),
        py::arg("width"), py::arg("height"), py::arg("near_plane") = 0.2f, py::arg("name") = "",
        "COLMAP: world-to-camera quaternion (w, x, y, z), translation, PINHOLE intrinsics (origin at the corner)");
  m.def("camera_from_opencv",
        [](py::object K, py::object R, py::object t, const IntArg& width, const IntArg& height,
           const FloatArg& near_plane, const StrArg& name) {
          const char* fn = "camera_from_opencv";
          const CameraArgs a = camera_args(fn, width, height, near_plane, name);
          return unwrap(api::camera_from_opencv(arr<3, 3>(K, fn, "K"), arr<3, 3>(R, fn, "R"), arr<3>(t, fn, "t"),
                                                a.width, a.height, a.options));
        },
        py::arg("K"), py::arg("R"), py::arg("t"), py::arg("width"), py::arg("height"), py::arg("near_plane") = 0.2f,
        py::arg("name") = "", "OpenCV: K [3, 3], world-to-camera R [3, 3] and t; pixel centres at integers");
  m.def("camera_from_opengl",
        [](py::object view, py::object projection, const IntArg& width, const IntArg& height,
           const FloatArg& near_plane, const StrArg& name) {
          const char* fn = "camera_from_opengl";
          const CameraArgs a = camera_args(fn, width, height, near_plane, name);
          return unwrap(api::camera_from_opengl(gl_matrix(view, fn, "view"), gl_matrix(projection, fn, "projection"),
                                                a.width, a.height, a.options));
        },
        py::arg("view"), py::arg("projection"), py::arg("width"), py::arg("height"), py::arg("near_plane") = 0.2f,
        py::arg("name") = "",
        "OpenGL view and projection matrices, 4x4 indexed [row, column] as written in math (M @ p); "
        "np.array(glm_matrix).T for a column-major GLM/pyglm matrix");
  m.def("camera_from_vulkan",
        [](py::object view, py::object projection, const IntArg& width, const IntArg& height,
           const FloatArg& near_plane, const StrArg& name) {
          const char* fn = "camera_from_vulkan";
          const CameraArgs a = camera_args(fn, width, height, near_plane, name);
          return unwrap(api::camera_from_vulkan(gl_matrix(view, fn, "view"), gl_matrix(projection, fn, "projection"),
                                                a.width, a.height, a.options));
        },
        py::arg("view"), py::arg("projection"), py::arg("width"), py::arg("height"), py::arg("near_plane") = 0.2f,
        py::arg("name") = "", "Vulkan (clip y down) view and projection matrices, [row, column]");
  m.def("load_cameras",
        [](const PathArg& path) {
          return unwrap(runtime::load_inria_cameras(path_arg(path, "load_cameras", "path").string()));
        },
        py::arg("path"),
        "Cameras of an INRIA 3DGS cameras.json");

  py::class_<ImagePlane>(m, "DeviceImage",
                         "A rendered image plane in GPU memory; supports DLPack (torch.from_dlpack) without a copy")
      .def_property_readonly("shape", [](const ImagePlane& p) { return p.shape(); })
      .def_property_readonly("dtype", &ImagePlane::dtype_name)
      .def_property_readonly("device", [](const ImagePlane& p) { return api::device_name(p.image->device()); })
      .def_property_readonly("data_ptr", [](const ImagePlane& p) { return reinterpret_cast<uintptr_t>(p.data()); })
      .def("__dlpack__", [](const ImagePlane& p, py::object stream, py::kwargs) { return plane_dlpack(p, stream); },
           py::arg("stream") = py::none())
      .def("__dlpack_device__",
           [](const ImagePlane& p) {
             const bool cuda = p.image->device() == api::Device::kCuda;
             return py::make_tuple(int(cuda ? kDLCUDA : kDLCPU), cuda ? p.image->cuda_device() : 0);
           })
      .def("synchronize", [](const ImagePlane& p) { check(p.image->synchronize()); },
           "Wait until the render that writes this plane has finished (its stream synchronized); numpy() and "
           "__array__ wait by themselves. roofgs.Error kCudaError naming the call if the render failed")
      .def("numpy", &plane_numpy, "Copy to a NumPy array (waits for the render)")
      .def("__array__", [](const ImagePlane& p, py::args, py::kwargs) { return plane_numpy(p); },
           "NumPy's protocol: np.asarray(image), PIL.Image.fromarray(image) of an rgba8 image")
      .def("__repr__", [](const ImagePlane& p) {
        const std::vector<int64_t> shape = p.shape();
        std::string dims;
        for (int64_t d : shape) dims += (dims.empty() ? "" : ", ") + std::to_string(d);
        return "<roofgs.DeviceImage [" + dims + "] " + p.dtype_name() + " on " + api::device_name(p.image->device()) +
               ">";
      });

  py::class_<PyScene>(m, "Scene", "A loaded scene (immutable; share it freely)")
      .def_property_readonly("info", [](const PyScene& s) { return scene_info(s.scene.info()); })
      .def_property_readonly("device", [](const PyScene& s) { return api::device_name(s.scene.device()); })
      .def_property_readonly(
          "frame_stats",
          [](PyScene& s) -> py::object {
            std::optional<api::FrameStats> stats;
            {
              std::lock_guard<std::mutex> lock(s.mutex);
              stats = s.last_stats;
            }
            if (!stats) return py::none();
            return frame_stats_dict(*stats);
          },
          "Counts of the last frame render() drew of this scene (None before the first): gaussians (input "
          "Gaussians), pairs ((tile, Gaussian) pairs sorted), tile_groups (CUDA: passes over groups of tile rows), "
          "and lod, the level-of-detail counts (zeros unless info['lod']['active']): splats (Gaussians drawn), "
          "chunks_drawn, chunks_culled, chunks_coarsened (coarser than pixel_error, for splat_budget), "
          "chunks_not_resident (CUDA: drawn coarser while the wanted level streams in), ranges_streamed and "
          "bytes_streamed (CUDA: requested this frame), bytes_resident (bytes of the levels held)")
      .def("__len__", [](const PyScene& s) { return s.scene.size(); })
      .def("__repr__", [](const PyScene& s) {
        const api::SceneInfo& info = s.scene.info();
        return "<roofgs.Scene " + std::to_string(info.gaussians) + " Gaussians, SH degree " +
               std::to_string(info.sh_degree) + ", " + info.description + ", on " + api::device_name(info.device) +
               ">";
      })
      .def_static(
          "from_arrays",
          [](const py::object& means, const py::object& quats, const py::object& scales, const py::object& opacities,
             const py::object& sh, const StrArg& device_arg, bool sanitize, const StrArg& name_arg) {
            const std::string device = str_arg(device_arg, "from_arrays", "device");
            const std::string name = str_arg(name_arg, "from_arrays", "name");
            const std::array<const py::object*, 5> arrays{&means, &quats, &scales, &opacities, &sh};
            if (const std::optional<int> cuda = device_arrays_device(arrays, device)) {
              // On the device: no Gaussian passes through host memory.
              std::optional<py::module_> torch;
              std::optional<TorchDeviceGuard> guard;
              if (is_torch_tensor(means)) {
                torch = import_torch();
                guard.emplace(*torch, *cuda);
              }
              const int64_t stream = torch ? torch_stream(*torch, *cuda) : 0;
              const DeviceGaussiansArrays borrowed(means, quats, scales, opacities, sh, false, std::nullopt, *cuda,
                                                   stream);
              api::DeviceLoadOptions options;
              options.cuda_device = *cuda;
              options.invalid_policy =
                  sanitize ? converter::InvalidPolicy::kSanitize : converter::InvalidPolicy::kReject;
              options.name = name;
              options.stream = reinterpret_cast<api::Stream>(static_cast<uintptr_t>(stream));
              Result<api::Scene> scene = Status(StatusCode::kInvalidArgument, "not loaded");
              {
                py::gil_scoped_release release;
                scene = api::load_device_gaussians(borrowed.gaussians(), options);
              }
              return std::make_unique<PyScene>(unwrap(std::move(scene)), *cuda);
            }
            format::GaussianCloud cloud = cloud_from_arrays(means, quats, scales, opacities, sh, false);
            api::LoadOptions options;
            options.device = resolve_device(device);
            converter::SceneReadOptions read;
            read.invalid_policy = sanitize ? converter::InvalidPolicy::kSanitize : converter::InvalidPolicy::kReject;
            Result<api::Scene> scene = Status(StatusCode::kInvalidArgument, "not loaded");
            {
              py::gil_scoped_release release;
              auto input = converter::scene_from_cloud(std::move(cloud), name, read);
              if (!input.ok()) {
                scene = input.status();
              } else {
                scene = api::load_cloud(std::move(input->cloud), input->bounds, name, options);
              }
            }
            return std::make_unique<PyScene>(unwrap(std::move(scene)));
          },
          py::arg("means"), py::arg("quats"), py::arg("scales"), py::arg("opacities"), py::arg("sh"), py::kw_only(),
          py::arg("device") = "auto", py::arg("sanitize") = false, py::arg("name") = "arrays",
          "A scene of Gaussians held in arrays (save()'s layout and value rules), on `device` ('auto', 'cpu', "
          "'cuda'); renders with every preset (the GPU reads its FP32 arrays). CUDA arrays (torch tensors or "
          "any DLPack producer's float32 C-contiguous arrays) are copied and checked on their device, with no "
          "host copy, unless device='cpu'")
      .def("arrays",
           [](const PyScene& s) {
             const format::GaussianCloud* cloud = s.scene.cloud();
             if (cloud == nullptr) {
               raise(Status(StatusCode::kInvalidArgument,
                            "arrays(): the Gaussians of a CUDA scene stay on the device; load with device='cpu'"));
             }
             const auto n = py::ssize_t(cloud->size());
             const auto k = py::ssize_t(cloud->sh_coefficients());
             const auto copy = [](const std::vector<float>& v, std::vector<py::ssize_t> shape) {
               py::array_t<float> a(shape);
               std::copy(v.begin(), v.end(), a.mutable_data());
               return a;
             };
             return py::make_tuple(copy(cloud->means, {n, 3}), copy(cloud->rotations, {n, 4}),
                                   copy(cloud->scales, {n, 3}), copy(cloud->opacities, {n}),
                                   copy(cloud->sh, {n, k, 3}));
           },
           "The Gaussians of a CPU scene as from_arrays() takes them: (means [N, 3], quats [N, 4], scales [N, 3] "
           "linear, opacities [N], sh [N, K, 3]), float32 NumPy copies of what the CPU reference renders")
      .def("orbit_cameras",
           [](const PyScene& s, const IntArg& count, const IntArg& width, const IntArg& height) {
             const char* fn = "orbit_cameras";
             return unwrap(runtime::orbit_cameras(s.scene.info().bounds,
                                                  int_arg<uint32_t>(count, fn, "count", 1, 100000),
                                                  int_arg<uint32_t>(width, fn, "width", 1, kMaxImageSide),
                                                  int_arg<uint32_t>(height, fn, "height", 1, kMaxImageSide)));
           },
           py::arg("count"), py::arg("width") = 1920, py::arg("height") = 1080,
           "A ring of cameras around the scene's bounding sphere")
      .def("render", &PyScene::render, py::arg("camera"), py::arg("preset") = "fastest",
           py::arg("width") = py::none(), py::arg("height") = py::none(),
           py::arg("background") = std::array<float, 3>{0.f, 0.f, 0.f}, py::arg("format") = "rgba32f",
           py::arg("depth") = false, py::arg("stream") = py::none(), py::arg("scratch_budget") = 0,
           "Render from `camera` (resized to width x height if given). CPU: a NumPy array [H, W, 4]; CUDA: a "
           "DeviceImage (DLPack). depth=True returns (rgba, depth). `stream`: a CUDA stream handle (int, e.g. "
           "torch.cuda.current_stream().cuda_stream); the render is enqueued on it. `scratch_budget`: CUDA, bytes "
           "of renderer scratch memory at most (0: none); frames with more pairs render in groups of tile rows "
           "with the same image");

#if RGS_WITH_VIEWER
  py::class_<PyViewServer>(m, "ViewServer",
                           "A running rgs-view server (roofgs.view()): .url, .stop(); shows the page inline in a "
                           "notebook")
      .def_property_readonly("url", [](const PyViewServer& v) { return v.url; })
      .def_property_readonly("port", [](const PyViewServer& v) { return v.server ? v.server->port() : 0; })
      .def_property_readonly("token", [](const PyViewServer& v) { return v.server ? v.server->token() : ""; })
      .def_property_readonly("clients", [](const PyViewServer& v) { return v.server ? v.server->clients() : 0u; })
      .def("stop", &PyViewServer::stop, "Closes every connection and the port, and joins the server's threads")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](PyViewServer& v, py::args) { v.stop(); })
      .def("_repr_html_",
           [](const PyViewServer& v) {
             return "<iframe src=\"" + v.url + "\" width=\"100%\" height=\"" + std::to_string(v.height) +
                    "\" style=\"border:0\" allow=\"fullscreen\"></iframe>";
           })
      .def("__repr__", [](const PyViewServer& v) { return "<roofgs.ViewServer " + v.url + ">"; });
  m.def("view",
        [](const py::object& scene, const py::object& scene2, const std::string& device, const std::string& host,
           const IntArg& port_arg, const std::string& token, const std::string& preset, const std::string& cameras,
           const IntArg& max_clients_arg, const IntArg& cuda_device_arg, const IntArg& height_arg) {
          const auto port = int_arg<uint16_t>(port_arg, "view", "port");
          const auto max_clients = int_arg<uint32_t>(max_clients_arg, "view", "max_clients", 1, 64);
          const int cuda_device = int_arg<int>(cuda_device_arg, "view", "cuda_device", 0, kMaxCudaDevice);
          const auto height = int_arg<uint32_t>(height_arg, "view", "height", 1, kMaxImageSide);
          std::vector<api::Scene> scenes = {view_scene(scene, device, cuda_device)};
          if (!scene2.is_none()) {
            // A path loads on the first scene's device.
            scenes.push_back(view_scene(scene2, api::device_name(scenes.front().device()), cuda_device));
          }
          view::ServerOptions options;
          options.host = host;
          options.port = port;
          options.token = token;
          options.preset = unwrap(api::parse_preset(preset));
          options.max_clients = max_clients;
          options.cuda_device = cuda_device;
          if (!cameras.empty()) options.cameras = unwrap(api::read_inria_cameras(cameras));
          auto handle = std::make_unique<PyViewServer>();
          {
            py::gil_scoped_release release;
            handle->server.emplace(unwrap(view::Server::start(std::move(scenes), options)));
          }
          handle->url = handle->server->url();
          handle->height = height;
          return handle;
        },
        py::arg("scene"), py::arg("scene2") = py::none(), py::arg("device") = "auto", py::arg("host") = "127.0.0.1",
        py::arg("port") = 0, py::arg("token") = "", py::arg("preset") = "fastest", py::arg("cameras") = "",
        py::arg("max_clients") = 8, py::arg("cuda_device") = 0, py::arg("height") = 600,
        "Starts the rgs-view server (docs/VIEWER.md) in this process for `scene` (a roofgs.Scene or a path; with "
        "`scene2`, the compare mode) and returns a ViewServer: open .url in a browser, or display it in a "
        "notebook (an inline iframe); .stop() ends it. port 0 picks a free port; a host other than 127.0.0.1 "
        "requires the URL's token (random unless `token` is given). Paths load on `device` with every preset "
        "they can render; `cameras` is an INRIA cameras.json whose cameras the page offers");
#endif
  m.def("load",
        [](const PathArg& path, const StrArg& device, const StrListArg& presets, bool quantize_other_formats,
           const IntArg& cuda_device, const py::object& spz_frame, bool lod, const IntArg& splat_budget,
           const FloatArg& pixel_error, const IntArg& memory_budget, const IntArg& stream_bytes, bool antialiased) {
          const char* fn = "load";
          api::LoadOptions options;
          options.cuda_device = int_arg<int>(cuda_device, fn, "cuda_device", 0, kMaxCudaDevice);
          options.lod.splat_budget = int_arg<uint64_t>(splat_budget, fn, "splat_budget");
          options.lod.pixel_error = float(float_arg(pixel_error, fn, "pixel_error", {0.0, 1000.0}));
          options.lod.memory_budget = int_arg<uint64_t>(memory_budget, fn, "memory_budget");
          options.lod.stream_bytes_per_frame = int_arg<uint64_t>(stream_bytes, fn, "stream_bytes", 1);
          options.presets.clear();
          for (const std::string& p : cast_arg<std::vector<std::string>>(presets, fn, "presets", "a sequence of str")) {
            options.presets.push_back(unwrap(api::parse_preset(p)));
          }
          const std::string file = path_arg(path, fn, "path").string();
          options.read_options = read_options(spz_frame);
          options.read_options.antialiased = antialiased;
          options.device = resolve_device(str_arg(device, fn, "device"));
          options.quantize_other_formats = quantize_other_formats;
          options.lod.enabled = lod;
          Result<api::Scene> scene = Status(StatusCode::kInvalidArgument, "not loaded");
          {
            py::gil_scoped_release release;
            scene = api::load(file, options);
          }
          return std::make_unique<PyScene>(unwrap(std::move(scene)));
        },
        py::arg("path"), py::arg("device") = "auto", py::arg("presets") = std::vector<std::string>{"fastest"},
        py::arg("quantize_other_formats") = true, py::arg("cuda_device") = 0, py::arg("spz_frame") = "rub",
        py::kw_only(), py::arg("lod") = true, py::arg("splat_budget") = api::LodSettings{}.splat_budget,
        py::arg("pixel_error") = api::LodSettings{}.pixel_error, py::arg("memory_budget") = uint64_t{0},
        py::arg("stream_bytes") = api::LodSettings{}.stream_bytes_per_frame, py::arg("antialiased") = false,
        "Load a scene in any format (.rgs, 3DGS PLY, compressed PLY, SOG, SPZ, glTF/GLB, .splat) onto device "
        "'cuda', 'cpu' or 'auto' (CUDA when a device answers, else the CPU, said once); the GPU copy holds only "
        "what `presets` read. spz_frame: the axes of an SPZ file, 'rub' "
        "(Niantic's convention) or 'as-stored' (splat-transform's), or a dict {path: frame} for those files (the "
        "others 'rub'); a frame the file declares is always used; info['notes'] says which was assumed. "
        "antialiased=True: the scene was trained with the 2D Mip filter (rgs-convert --antialiased), for formats "
        "that cannot say so; a .rgs or SPZ file that says so needs nothing. "
        "A level-of-detail .rgs (rgs-convert --lod-levels auto; docs/LOD.md) renders, with lod=True, each frame's "
        "selection of levels: at most splat_budget Gaussians (0: no limit), levels whose projected error is at "
        "most pixel_error pixels where the budget allows; on CUDA streamed into memory_budget bytes of device "
        "memory (0: a pool that holds every level; the renderer's scratch is bounded by render()'s "
        "scratch_budget), reading and uploading at most stream_bytes a frame (> 0: the bound on how long a frame "
        "waits for the file; levels that do not fit come in later frames), on the CPU with every level in host "
        "memory. lod=False renders its full detail. Files without levels ignore these (info['notes'] says so "
        "for values other than the defaults); info['lod'] tells, frame_stats['lod'] counts each frame. "
        "ValueError for pixel_error outside 0..1000 or not finite, stream_bytes 0 or cuda_device outside 0..1023; "
        "roofgs.Error kInvalidArgument for a level-of-detail CUDA scene with a preset reading FP32 (faithful); "
        "kLimitExceeded for a memory_budget below the frame arrays and the coarsest levels");

  m.def("_convert",
        [](const PathArg& src, const PathArg& dst, py::kwargs kwargs) {
          const std::string from = path_arg(src, "convert", "src").string();
          const std::string to = path_arg(dst, "convert", "dst").string();
          return convert_with_options("convert", std::move(kwargs), from, to, [&](const api::ConvertOptions& o) {
            return api::convert(from, to, o);
          });
        },
        py::arg("src"), py::arg("dst"), "convert()'s implementation: the options given, by name");
  m.def("_save",
        [](const PathArg& path, const py::object& means, const py::object& quats, const py::object& scales,
           const py::object& opacities, const py::object& sh, py::kwargs kwargs) {
          const std::string dst = path_arg(path, "save", "path").string();
          format::GaussianCloud cloud = cloud_from_arrays(means, quats, scales, opacities, sh, false);
          return convert_with_options("save", std::move(kwargs), "arrays", dst, [&](const api::ConvertOptions& o) {
            return api::convert_cloud(std::move(cloud), "arrays", dst, o);
          });
        },
        py::arg("path"), py::arg("means"), py::arg("quats"), py::arg("scales"), py::arg("opacities"), py::arg("sh"),
        "save()'s implementation: the options given, by name");
  // convert() and save() take every option of rgs-convert by the snake_case of its long option (test_roofgs.py
  // compares them with rgs-convert --help), as Python functions whose signature inspect can read.
  py::dict scope = m.attr("__dict__");
  py::exec(R"(
def convert(src, dst, *, to=None, sh_degree=None, scale_encoding=None, sh_clip_percentile=None, sh_dc_bits=None,
            zstd=None, profile=None, position_error=None, target_psnr=None, target_bytes=None, cameras=None,
            every=None, limit=None, orbit=None, path=None, fly=None, width=None, height=None, zstd_level=None,
            sanitize=False, allow_empty=False, lod=None, lod_levels=None, lod_chunk=None, memory_limit=None,
            max_gaussians=None, max_decompression_ratio=None, spz_frame=None, antialiased=False, edits=None,
            **unexpected):
    _refuse_unexpected("convert", unexpected)
    options = {k: v for k, v in locals().items() if k not in ("src", "dst", "unexpected") and v is not None}
    return _convert(src, dst, **options)

def _keyword_options(name):
    """The keyword options of convert() or save(), from their signatures (the one list of them)."""
    import inspect
    parameters = inspect.signature(globals()[name]).parameters.values()
    return [p.name for p in parameters if p.kind == p.KEYWORD_ONLY]

def _refuse_unexpected(name, unexpected):
    if unexpected:
        raise TypeError(name + "() got an unexpected keyword argument " + repr(next(iter(unexpected))) +
                        "; the options are " + ", ".join(_keyword_options(name)))

def save(path, means, quats, scales, opacities, sh, *, to=None, sh_degree=None, scale_encoding=None,
         sh_clip_percentile=None, sh_dc_bits=None, zstd=None, profile=None, position_error=None, target_psnr=None,
         target_bytes=None, cameras=None, every=None, limit=None, orbit=None, camera_path=None, fly=None,
         width=None, height=None, zstd_level=None, sanitize=False, allow_empty=False, lod=None, lod_levels=None,
         lod_chunk=None, memory_limit=None, max_gaussians=None, max_decompression_ratio=None, spz_frame=None,
         antialiased=False, edits=None,
         **unexpected):
    _refuse_unexpected("save", unexpected)
    options = {k: v for k, v in locals().items()
               if k not in ("path", "means", "quats", "scales", "opacities", "sh", "unexpected") and v is not None}
    return _save(path, means, quats, scales, opacities, sh, **options)
)", scope);
  m.attr("convert").attr("__doc__") = py::str(
        "Convert a scene in any format into dst: .rgs, .ply, .spz, .glb or .sog (or a SOG folder's meta.json), as `to` or "
        "dst's extension says "
        "(what rgs-convert does, same options). Returns rgs-convert --json's report as a dict (api::"
        "convert_report_json): input and output (path, bytes, format, ..., notes), gaussians, sh_degree, hygiene "
        "(dropped_gaussians, ...), and errors (per attribute, SH per degree) for a .rgs output. "
        "target_psnr (dB) or target_bytes: rate control of the archive profile (api::ConvertOptions::target, as "
        "rgs-convert --target-psnr / --target-bytes) on the views of cameras (an INRIA cameras.json, every K-th) "
        "an orbit or a path, at width x height; with none of these, the scene's own cameras.json of the 3DGS output "
        "layout beside it, else views guessed from its content; the dict "
        "then has rate_control: target, psnr_mean_db, "
        "psnr_min_db, search_psnr_db, settings (position_error, rotation_bits, rotation_step, scale_bits, "
        "scale_step, opacity_bits, opacity_step, opacity_floor, sh_step_multipliers), views, width, height, "
        "backend, device, encodings, renders, seconds (of which encode_seconds encoding the candidates and "
        "render_seconds loading and rendering them). memory_limit: most bytes of memory the conversion may use "
        "(int; 0 or None: half the physical memory); an input whose estimated peak when read whole is above it "
        "is built out of core when it is a binary PLY converted with lod_levels (the same bytes), else raises "
        "roofgs.Error kLimitExceeded before it is read (api::ConvertOptions::memory_limit). edits: the scene's edits "
        "in the order they act, each a (name, value) pair in rgs-convert's spelling: [('rotate', '0,0,90'), "
        "('filter', 'opacity gt 0.1'), ('crop-box', '-1,-1,-1,1,1,1'), ('filter-nan', '')]; the names are "
        "translate (x,y,z scene units), rotate (x,y,z Euler degrees, extrinsic x then y then z, or a unit quaternion "
        "w,x,y,z; the SH colour turns too), scale (s > 0), filter-nan, filter ('NAME OP VALUE'), crop-box, "
        "crop-box-outside (minx,miny,minz,maxx,maxy,maxz), crop-sphere, crop-sphere-outside (cx,cy,cz,r) "
        "(api::ConvertOptions::edits, converter::parse_edit_action); a bad one raises ValueError naming edits[i] "
        "and the rule. rgs-convert's --translate, --rotate, --scale, --filter-nan, --filter, --crop-box, "
        "--crop-sphere and their -outside forms are this one keyword, since their order matters");
  m.attr("save").attr("__doc__") = py::str(
        "Write Gaussians held in arrays to `path` in any output format (.rgs, .ply, .spz, .glb, .sog or a SOG "
        "folder's meta.json), with convert()'s "
        "keyword options. means [N, 3], quats [N, 4] (w, x, y, z; normalized here), scales [N, 3] linear "
        "(exp of the PLY's log scales), opacities [N] in [0, 1] (sigmoid of the PLY's logits), sh [N, K, 3] "
        "(K = 1, 4, 9, 16; PLY f_dc then f_rest reordered coefficient-major); float32 or convertible. The value "
        "rules of a file apply (sanitize=True drops what they reject). Returns convert()'s dict. The arrays are "
        "already in memory: memory_limit is accepted and not checked. edits: as convert()'s, on the arrays");
  m.def("_rasterization", &rasterization, py::arg("means"), py::arg("quats"), py::arg("scales"),
        py::arg("opacities"), py::arg("colors"), py::arg("viewmats"), py::arg("Ks"), py::arg("width"),
        py::arg("height"), py::kw_only(), py::arg("near_plane"), py::arg("sh_degree"), py::arg("backgrounds"),
        py::arg("render_mode"), py::arg("antialiased"), py::arg("preset"), py::arg("device"), py::arg("cache"),
        "rasterization()'s implementation: one batch element, gsplat's options already checked");
  // rasterization() takes gsplat's signature as it is (every option, positional or by name, so a gsplat call
  // runs unchanged); its defaults are the one list of what is accepted. Options that change only how gsplat
  // computes (memory layout, channel chunks, sort) take any value; the others only their default.
  py::exec(R"py(
def rasterization(means, quats, scales, opacities, colors, viewmats, Ks, width, height, near_plane=0.01,
                  far_plane=1e10, radius_clip=0.0, eps2d=0.3, sh_degree=None, packed=True, tile_size=16,
                  backgrounds=None, render_mode="RGB", sparse_grad=False, absgrad=False, rasterize_mode="classic",
                  channel_chunk=32, distributed=False, camera_model="pinhole", segmented=False, covars=None,
                  with_ut=False, with_eval3d=False, radial_coeffs=None, tangential_coeffs=None,
                  thin_prism_coeffs=None, ftheta_coeffs=None, rolling_shutter=None, viewmats_rs=None, *,
                  preset="fastest", device="auto", cache=True):
    _check_gsplat_options(locals())
    lead = tuple(_numpy().shape(means)[:-2])  # nested lists too (any array-like the renderer converts)
    one = lambda b: _rasterization(*b[:7], width, height, near_plane=near_plane, sh_degree=sh_degree,
                                   backgrounds=b[7], render_mode=render_mode,
                                   antialiased=rasterize_mode == "antialiased", preset=preset, device=device,
                                   cache=cache)
    arrays = [means, quats, scales, opacities, colors, viewmats, Ks, backgrounds]
    if not lead:
        out_colors, out_alphas, meta = one(arrays)
        return _as_caller_array(out_colors, means), _as_caller_array(out_alphas, means), meta
    # gsplat's leading batch dimensions [..., N, 3] / [..., C, 4, 4]: one render per batch element.
    import math
    count = math.prod(lead)
    tails = {"means": 2, "quats": 2, "scales": 2, "opacities": 1, "colors": 3 if sh_degree is not None else 2,
             "viewmats": 3, "Ks": 3, "backgrounds": 2}
    flat = []
    for (name, tail), a in zip(tails.items(), arrays):
        if a is None:
            flat.append(None)
            continue
        if not hasattr(a, "reshape"):
            a = _numpy().asarray(a, dtype=_numpy().float32)
        if tuple(a.shape[:-tail]) != lead or len(a.shape) != len(lead) + tail:
            raise ValueError(name + ": expected the leading batch dimensions " + str(list(lead)) + " of means, "
                             "then " + str(tail) + " dimensions; got shape " + str(list(a.shape)))
        flat.append(a.reshape((count,) + tuple(a.shape[len(lead):])))
    results = [one([a if a is None else a[b] for a in flat]) for b in range(count)]
    meta = dict(results[0][2])
    meta["batch_dims"] = list(lead)
    meta["n_cameras"] = sum(r[2]["n_cameras"] for r in results)
    meta["pairs"] = [p for r in results for p in r[2]["pairs"]]
    if "uploaded" in meta:
        meta["uploaded"] = any(r[2]["uploaded"] for r in results)
    def stacked(i):
        parts = [r[i] for r in results]
        torch = _torch_of(parts[0])
        whole = torch.stack(parts) if torch is not None else _numpy().stack(parts)
        return _as_caller_array(whole.reshape(lead + tuple(whole.shape[1:])), means)
    return stacked(0), stacked(1), meta

def _numpy():
    import numpy
    return numpy

def _torch_of(array):
    """torch when `array` is a torch tensor (torch already imported by the caller), else None."""
    import sys
    torch = sys.modules.get("torch")
    return torch if torch is not None and isinstance(array, torch.Tensor) else None

def _as_caller_array(out, like):
    """`out` as the array type of `like`: a host NumPy result becomes a torch CPU tensor for torch inputs."""
    torch = _torch_of(like)
    if torch is not None and _torch_of(out) is None:
        return torch.from_numpy(out)
    return out

# Options that change only how gsplat computes, never the image: any value is taken.
_GSPLAT_ANY_VALUE = ("packed", "channel_chunk", "segmented")

def _check_gsplat_options(given):
    import inspect
    import numbers
    for name, p in inspect.signature(rasterization).parameters.items():
        if p.default is inspect.Parameter.empty or p.kind == p.KEYWORD_ONLY or name in _GSPLAT_ANY_VALUE:
            continue
        if name in ("near_plane", "sh_degree", "backgrounds", "render_mode"):
            continue  # rendered as gsplat does
        if name == "rasterize_mode" and given[name] in ("classic", "antialiased"):
            continue  # antialiased: opacities scaled by the 2D filter's compensation, as gsplat does
        value = given[name]
        if p.default is None:
            ok = value is None or (name == "rolling_shutter" and getattr(value, "name", None) == "GLOBAL")
        elif isinstance(p.default, bool):
            ok = isinstance(value, (bool, int)) and bool(value) == p.default
        elif isinstance(p.default, str):
            ok = value == p.default
        else:
            ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and (
                value == p.default or (name == "far_plane" and value >= p.default))
        if not ok:
            shown = repr(value)[:40] if isinstance(value, (numbers.Real, str)) else "<" + type(value).__name__ + ">"
            raise ValueError("roofgs.rasterization renders gsplat's classic pinhole inference without gradients; "
                             + name + "=" + shown + " is not supported (only " + name + "="
                             + repr(p.default) + ", gsplat's default" + (", or more" if name == "far_plane" else "")
                             + ")")
)py", scope);
  m.attr("rasterization").attr("__doc__") = py::str(
        "gsplat.rasterization's call for inference: swap the import to render trained Gaussians with RoofGS.\n"
        "means [..., N, 3]; quats [..., N, 4] (w, x, y, z, normalized here); scales [..., N, 3] activated "
        "(linear); opacities [..., N] activated, in [0, 1]; colors [..., N, K, 3] SH with sh_degree given (its "
        "first (sh_degree+1)^2 coefficients are used), else [..., N, 3] RGB; viewmats [..., C, 4, 4] "
        "world-to-camera (OpenCV axes: x right, y down, z forward); Ks [..., C, 3, 3] pixel intrinsics with "
        "gsplat's pixel centres at half-integers; width, height in pixels; near_plane: Gaussians nearer are "
        "culled; backgrounds [..., C, 3]; render_mode RGB, D, ED, RGB+D or RGB+ED (ED: expected depth, D: "
        "accumulated = ED x alpha). Leading batch dimensions (gsplat's `...`, the same on every array) are "
        "rendered one batch element after the other and kept on the outputs.\n"
        "Outputs: colors [..., C, H, W, 3 or 4], alphas [..., C, H, W, 1] (float32) in the caller's array type, "
        "and meta. NumPy arrays in: NumPy out. torch CPU tensors in: torch CPU tensors out. CUDA arrays (torch "
        "tensors; any DLPack producer's float32 C-contiguous arrays): the Gaussians are copied and checked on "
        "their device (no host copy) unless device='cpu', rendered on torch's current stream, and the outputs "
        "are torch CUDA tensors on that device. With cache=True the upload of the last torch tensors is reused "
        "while they are the same tensors with the same version counter (in-place changes bump it; writes "
        "through .data or raw pointers do not: pass cache=False then); meta['uploaded'] says whether the call "
        "uploaded. meta: preset, width, height, n_cameras (images rendered), pairs per image, batch_dims with "
        "batch dimensions. rasterize_mode 'antialiased' scales each opacity by the 2D filter's compensation "
        "sqrt(det Σ2 / det(Σ2 + 0.3 I)), as gsplat does (a scene trained with Mip-Splatting's filter). Every other "
        "gsplat option is accepted at its default value; packed, channel_chunk "
        "and segmented (how gsplat computes, not what) at any value; a non-default value of the others "
        "(gradients, other camera models, far plane below 1e10, radius clip, eps2d, tile "
        "size, covariances, distortion, rolling shutter, distributed) raises ValueError naming the option");
  m.def("audit",
        [](const PathArg& source_arg, const py::object& candidates_in, std::optional<std::vector<api::Camera>> cameras,
           const std::optional<IntArg>& orbit_arg, const IntArg& width_arg, const IntArg& height_arg,
           const StrArg& device, const py::object& spz_frame, const FloatArg& threshold_arg) {
          const char* fn = "audit";  // the rules of rgs-audit's options
          const std::optional<uint32_t> orbit = int_arg<uint32_t>(orbit_arg, fn, "orbit", 1, 100000);
          const uint32_t width = int_arg<uint32_t>(width_arg, fn, "width", 11, kMaxImageSide);
          const uint32_t height = int_arg<uint32_t>(height_arg, fn, "height", 11, kMaxImageSide);
          const double threshold = float_arg(threshold_arg, fn, "threshold", {-1000.0, 1000.0});
          const std::filesystem::path source = path_arg(source_arg, fn, "source");
          // One path (str or os.PathLike) or a sequence of them.
          const bool one = py::isinstance<py::str>(candidates_in) || py::isinstance<py::bytes>(candidates_in) ||
                           py::hasattr(candidates_in, "__fspath__");
          const std::vector<std::filesystem::path> candidates =
              one ? std::vector<std::filesystem::path>{path_arg(candidates_in, fn, "candidates")}
                  : cast_arg<std::vector<std::filesystem::path>>(candidates_in, fn, "candidates",
                                                                  "a path (str or os.PathLike) or a sequence of them");
          const converter::SceneReadOptions read = read_options(spz_frame);
          audit::AuditOptions options;
          options.worst_views = 0;
          const bool cuda = resolve_device(str_arg(device, fn, "device")) == api::Device::kCuda;
          options.backend = cuda ? audit::Backend::kCuda : audit::Backend::kCpu;
          Result<audit::AuditResult> result = Status(StatusCode::kInvalidArgument, "not audited");
          std::string views_note;
          {
            py::gil_scoped_release release;
            auto run = [&]() -> Result<audit::AuditResult> {
              RGS_ASSIGN_OR_RETURN(audit::AuditScene src, audit::load_audit_scene(source.string(), "", read));
              std::vector<audit::AuditScene> scenes;
              for (const auto& c : candidates) {
                RGS_ASSIGN_OR_RETURN(audit::AuditScene scene, audit::load_audit_scene(c.string(), "", read));
                scenes.push_back(std::move(scene));
              }
              std::vector<api::Camera> views;
              if (cameras) {
                views = *cameras;
              } else if (orbit) {
                RGS_ASSIGN_OR_RETURN(views, runtime::orbit_cameras(src.bounds, *orbit, width, height));
              } else {  // as rgs-audit: the scene's own cameras.json, else views guessed from its content
                api::CameraChoice choice;
                choice.width = width;
                choice.height = height;
                RGS_ASSIGN_OR_RETURN(api::DefaultViews found,
                                     api::default_views(source.string(), src.cloud, choice));
                views = std::move(found.cameras);
                views_note = std::move(found.note);
              }
              return audit::run_audit(src, scenes, views, options);
            };
            result = run();
          }
          const audit::AuditResult r = unwrap(std::move(result));
          py::dict d;
          d["device"] = r.device;
          d["views"] = r.views.size();
          if (!views_note.empty()) d["views_note"] = views_note;
          d["source"] = py::dict(py::arg("path") = r.source.path, py::arg("format") = r.source.format,
                                 py::arg("bytes") = r.source.file_bytes, py::arg("gaussians") = r.source.gaussians);
          py::list out;
          bool all_passed = true;
          for (size_t i = 0; i < r.candidates.size(); ++i) {
            const audit::CandidateResult& c = r.candidates[i];
            py::dict cd;
            cd["path"] = c.scene.path;
            cd["format"] = c.scene.format;
            cd["bytes"] = c.scene.file_bytes;
            cd["gaussians"] = c.scene.gaussians;
            cd["sh_degree"] = c.scene.sh_degree;
            cd["bytes_per_gaussian"] =
                r.source.gaussians ? double(c.scene.file_bytes) / double(r.source.gaussians) : 0.0;
            py::list sections;
            for (const audit::SectionSize& sec : c.scene.sections) {
              sections.append(py::dict(py::arg("name") = sec.name, py::arg("codec") = sec.codec,
                                       py::arg("stored_bytes") = sec.stored_bytes, py::arg("raw_bytes") = sec.raw_bytes));
            }
            cd["sections"] = sections;
            cd["psnr_mean_db"] = c.summary.psnr_mean_db;
            cd["psnr_min_db"] = c.summary.psnr_min_db;
            cd["ssim_mean"] = c.summary.ssim_mean;
            cd["ssim_min"] = c.summary.ssim_min;
            cd["max_abs_diff"] = c.summary.max_abs_diff;
            cd["worst_view"] = r.views[c.summary.worst_view].name;
            if (c.attributes) {
              cd["errors"] = attribute_errors(c.attributes->errors);
            } else {
              cd["errors_note"] = c.attributes_note;
            }
            cd["notes"] = c.scene.notes;
            // rgs-audit --json's verdict of the candidate (audit_report.cpp).
            const audit::Verdict v = audit::verdict(r, i, threshold);
            all_passed = all_passed && v.passed;
            cd["verdict"] = py::dict(
                py::arg("passed") = v.passed, py::arg("metric") = audit::verdict_metric_name(v.metric),
                py::arg("psnr_mean_db") = v.psnr_mean_db,
                py::arg("whole_frame_psnr_mean_db") = v.whole_frame_psnr_mean_db,
                py::arg("foreground_psnr_mean_db") = v.foreground_psnr_mean_db,
                py::arg("worst_view") = py::dict(py::arg("name") = v.worst_view, py::arg("psnr_db") = v.worst_psnr_db),
                py::arg("bytes_saved") = v.bytes_saved ? py::object(py::int_(*v.bytes_saved)) : py::object(py::none()),
                py::arg("bytes_saved_fraction") =
                    v.bytes_saved ? py::object(py::float_(v.bytes_saved_fraction)) : py::object(py::none()));
            out.append(cd);
          }
          d["candidates"] = out;
          d["verdict"] = py::dict(py::arg("threshold_db") = threshold,
                                  py::arg("criterion") =
                                      "mean PSNR over the views (each candidate's verdict metric) >= threshold_db",
                                  py::arg("passed") = all_passed);
          return d;
        },
        py::arg("source"), py::arg("candidates"), py::kw_only(), py::arg("cameras") = py::none(),
        py::arg("orbit") = py::none(), py::arg("width") = 960, py::arg("height") = 540, py::arg("device") = "auto",
        py::arg("spz_frame") = "rub", py::arg("threshold") = audit::kDefaultVerdictThresholdDb,
        "What conversions cost, as rgs-audit measures it: every candidate (any format load() reads) rendered "
        "against the source on the same views (`cameras`; else an orbit of `orbit` cameras at width x height; else, "
        "as rgs-audit, the source's own cameras.json of the 3DGS output layout beside it or views guessed from its "
        "content, said in the dict's views_note) "
        "with the faithful preset, on the GPU when `device` resolves to CUDA, else the CPU reference. Returns "
        "a dict: device, views, source (path, format, bytes, gaussians) and one dict per candidate: bytes, "
        "bytes_per_gaussian (per Gaussian of the source), sections (.rgs), PSNR mean/min (dB, clamped RGB), "
        "SSIM mean/min, max_abs_diff, worst_view, per-attribute errors when every candidate Gaussian is paired with "
        "a source Gaussian, in whatever order its file keeps them (as rgs-audit pairs them; else errors_note), and "
        "verdict (rgs-audit --json's: metric, foreground where the source's renders have "
        "background, else whole_frame; passed when the mean PSNR in it is at least `threshold` dB; psnr_mean_db "
        "in it, whole_frame_psnr_mean_db, foreground_psnr_mean_db, worst_view name and psnr_db in it, bytes_saved and bytes_saved_fraction against the source); "
        "the dict's verdict: threshold_db, criterion, passed (every candidate passed). `candidates`: one path or "
        "a list of them");
}
