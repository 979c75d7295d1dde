// roofgs.Camera and the functions that make cameras: from INRIA, COLMAP, OpenCV, OpenGL and Vulkan conventions,
// and from a cameras.json.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <array>
#include <cstdint>
#include <string>
#include <tuple>
#include <vector>

#include "internal_py_arguments.h"
#include "internal_py_bindings.h"
#include "internal_py_errors.h"

namespace rgs::python {

namespace {

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

}  // namespace

void bind_cameras(py::module_& m) {
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
}

}  // namespace rgs::python
