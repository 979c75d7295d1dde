// Rendered images of the roofgs module: a plane of a library image, viewed from Python as a NumPy array or,
// through DLPack, as a DeviceImage (py_images.cpp).
#pragma once

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "internal_py_dlpack.h"
#include "rgs/api/roofgs.h"

namespace py = pybind11;

namespace rgs::python {

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

/// A host copy of `plane` as a NumPy array (uint8, float16 or float32 as its format; waits for the render).
py::array plane_numpy(const ImagePlane& plane);

}  // namespace rgs::python
