// Gaussians of the roofgs module given as arrays: NumPy (or anything with __array__) read through host memory,
// and CUDA arrays (torch tensors, any DLPack producer's) borrowed where they are, with no host copy
// (py_arrays.cpp).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "internal_py_dlpack.h"
#include "rgs/api/device_gaussians.h"
#include "rgs/format/gaussian_cloud.h"

namespace py = pybind11;

namespace rgs::python {

// ---------------------------------------------------------------------------------------------------------
// Gaussians from arrays

/// A C-contiguous float32 copy of `obj` (a NumPy array, or anything with __array__: a CPU torch tensor). A
/// CUDA tensor is copied to the host first (`.cpu()`): the host path, and the small per-view arrays (viewmats,
/// Ks, backgrounds) of the device path.
py::array_t<float> float_array(const py::object& obj, const char* what);

/// Checks that `a`'s shape is [n, cols...] (n taken from the first array when *n is 0).
void check_shape(const py::array_t<float>& a, const char* what, size_t* n, const std::vector<int64_t>& cols);

/// format::GaussianCloud from arrays in its activated layout: means [N, 3], quats [N, 4] (w, x, y, z),
/// linear scales [N, 3], opacities [N] in [0, 1], SH [N, K, 3] (or RGB [N, 3] when `rgb`).
format::GaussianCloud cloud_from_arrays(const py::object& means, const py::object& quats, const py::object& scales,
                                        const py::object& opacities, const py::object& colors, bool rgb);

// ---------------------------------------------------------------------------------------------------------
// Gaussians in CUDA memory (DLPack in, no host copy)

/// Whether `obj` is a torch tensor (false when torch was never imported).
bool is_torch_tensor(const py::object& obj);

/// The torch module; ImportError saying why it is needed when it cannot be imported.
py::module_ import_torch();

/// torch's current stream on CUDA device `device` (its handle; 0 is the legacy default stream).
int64_t torch_stream(const py::module_& torch, int device);

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

/// Calls the deleter of a DLPack tensor this module consumed (nothing for null).
void release_managed(DLManagedTensor* managed);

/// A float32 array in CUDA memory borrowed through DLPack for the duration of one call: a torch tensor
/// (detached, and made float32 and contiguous on its device when it is not), or any producer's array already
/// float32 and C-contiguous. The producer's work is ordered before `stream` (DLPack's stream argument).
class DeviceArray {
 public:
  DeviceArray(const py::object& obj, const char* what, int device, int64_t stream);

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
                        std::optional<uint32_t> sh_degree, int device, int64_t stream);

  const api::DeviceGaussians& gaussians() const { return g_; }

 private:
  DeviceArray means_, quats_, scales_, opacities_, colors_;
  api::DeviceGaussians g_;
};

/// The CUDA device whose memory holds the Gaussian arrays when they are to be read there: all five on one
/// device, `device` not "cpu", and for "auto" a build and host with CUDA (else they go through host memory, as
/// "auto" then renders on the CPU). "cuda" without a usable device raises resolve_device's error.
std::optional<int> device_arrays_device(const std::array<const py::object*, 5>& arrays, const std::string& device);

}  // namespace rgs::python
