// Python bindings of the RoofGS front door (rgs/api). Errors become roofgs.Error (a RuntimeError) carrying
// .code (the StatusCode number) and .code_name ("kIoError", ...); an argument of the wrong type or outside its
// rule raises TypeError or ValueError naming the function and the argument (internal_py_arguments.h). GPU images
// implement the DLPack protocol (__dlpack__, __dlpack_device__), so torch.from_dlpack() shares their memory
// without a copy.
//
// The module's areas are in py_*.cpp (internal_py_bindings.h lists them); this file makes the module, its
// constants and roofgs.Error.
#include <pybind11/pybind11.h>

#include <exception>
#include <string>

#include "internal_py_bindings.h"
#include "internal_py_errors.h"
#include "rgs/api/roofgs.h"

namespace py = pybind11;
using namespace rgs;
using rgs::python::StatusError;

namespace {

PyObject* g_error_type = nullptr;

}  // namespace

PYBIND11_MODULE(roofgs, m) {
  m.doc() =
      "RoofGS: load scenes (.rgs, 3DGS PLY, PlayCanvas compressed PLY, SOG meta.json/.sog/folder, streamed SOG "
      "lod-meta.json, SPZ, .ksplat, .splat, glTF/GLB), render them with presets on the GPU or the CPU reference, convert "
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

  python::bind_cameras(m);
  python::bind_images(m);
  python::bind_scenes(m);
#if RGS_WITH_VIEWER
  python::bind_viewer(m);
#endif
  python::bind_loading(m);
  python::bind_conversion(m);
  python::bind_rasterization(m);
  python::bind_audit(m);
}
