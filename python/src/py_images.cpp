// roofgs.DeviceImage: a rendered image plane, shared with array libraries through DLPack without a copy.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <string>
#include <vector>

#include "internal_py_arguments.h"
#include "internal_py_bindings.h"
#include "internal_py_errors.h"
#include "internal_py_images.h"

namespace rgs::python {

namespace {

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

}  // namespace

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

void bind_images(py::module_& m) {
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
}

}  // namespace rgs::python
