// roofgs.view(): the rgs-view server (view/PROTOCOL.md) in this process, in a build with the viewer
// (RGS_WITH_VIEWER).
#include <pybind11/pybind11.h>

#include "internal_py_bindings.h"

#if RGS_WITH_VIEWER
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "internal_py_arguments.h"
#include "internal_py_errors.h"
#include "internal_py_scene.h"
#include "rgs/view/server.h"

namespace rgs::python {

namespace {

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

}  // namespace

void bind_viewer(py::module_& m) {
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
           const IntArg& max_clients_arg, const IntArg& cuda_device_arg, const IntArg& height_arg,
           const py::object& max_mbps_arg) {
          const auto port = int_arg<uint16_t>(port_arg, "view", "port");
          const auto max_clients = int_arg<uint32_t>(max_clients_arg, "view", "max_clients", 1, 64);
          const int cuda_device = int_arg<int>(cuda_device_arg, "view", "cuda_device", 0, kMaxCudaDevice);
          const auto height = int_arg<uint32_t>(height_arg, "view", "height", 1, kMaxImageSide);
          const double max_mbps = float_arg(max_mbps_arg, "view", "max_mbps", {0.0, view::kMaxMbps});
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
          options.max_mbps = max_mbps;
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
        py::arg("max_clients") = 8, py::arg("cuda_device") = 0, py::arg("height") = 600, py::arg("max_mbps") = 0,
        "Starts the rgs-view server (docs/VIEWER.md) in this process for `scene` (a roofgs.Scene or a path; with "
        "`scene2`, the compare mode) and returns a ViewServer: open .url in a browser, or display it in a "
        "notebook (an inline iframe); .stop() ends it. port 0 picks a free port; a host other than 127.0.0.1 "
        "requires the URL's token (random unless `token` is given). Paths load on `device` with every preset "
        "they can render; `cameras` is an INRIA cameras.json whose cameras the page offers; `max_mbps` (Mbit/s, 0: none) "
        "is each browser's bandwidth budget, as rgs-view --max-mbps");
}

}  // namespace rgs::python
#endif
