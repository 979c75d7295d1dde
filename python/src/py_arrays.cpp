// Gaussians given as arrays (internal_py_arrays.h): host arrays copied into a GaussianCloud, CUDA arrays
// borrowed through DLPack.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <algorithm>

#include "internal_py_arguments.h"
#include "internal_py_arrays.h"
#include "internal_py_errors.h"
#include "rgs/kernels/shared/spherical_harmonics.h"

namespace rgs::python {

namespace {

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

}  // namespace

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

void check_shape(const py::array_t<float>& a, const char* what, size_t* n, const std::vector<int64_t>& cols) {
  check_dims(shape_of(a), what, n, cols);
}

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

namespace {

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

}  // namespace

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

int64_t torch_stream(const py::module_& torch, int device) {
  return torch.attr("cuda").attr("current_stream")(device).attr("cuda_stream").cast<int64_t>();
}

void release_managed(DLManagedTensor* managed) {
  if (managed != nullptr && managed->deleter != nullptr) managed->deleter(managed);
}

DeviceArray::DeviceArray(const py::object& obj, const char* what, int device, int64_t stream) {
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

DeviceGaussiansArrays::DeviceGaussiansArrays(const py::object& means, const py::object& quats,
                                             const py::object& scales, const py::object& opacities,
                                             const py::object& colors, bool rgb,
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

}  // namespace rgs::python
