// The areas of the roofgs module, each adding its functions and classes to it. roofgs_module.cpp calls them in
// the order below: a signature names a class by its Python name only when the class was added before it.
#pragma once

#include <pybind11/pybind11.h>

namespace py = pybind11;

namespace rgs::python {

/// Camera, the camera_from_* functions and load_cameras() (py_cameras.cpp).
void bind_cameras(py::module_& m);

/// DeviceImage, a rendered image plane (py_images.cpp).
void bind_images(py::module_& m);

/// Scene: its properties, from_arrays(), arrays(), orbit_cameras() and render() (py_scenes.cpp).
void bind_scenes(py::module_& m);

/// ViewServer and view(); defined only in a build with the viewer, RGS_WITH_VIEWER (py_viewer.cpp).
void bind_viewer(py::module_& m);

/// load() (py_scenes.cpp).
void bind_loading(py::module_& m);

/// convert() and save(), and _convert() and _save() behind them (py_conversion.cpp).
void bind_conversion(py::module_& m);

/// rasterization(), gsplat's call, and _rasterization() behind it (py_rasterization.cpp).
void bind_rasterization(py::module_& m);

/// audit() (py_audit.cpp).
void bind_audit(py::module_& m);

}  // namespace rgs::python
