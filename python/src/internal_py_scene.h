// roofgs.Scene's object: a loaded scene and the renderer Python uses for it (py_scenes.cpp).
#pragma once

#include <pybind11/pybind11.h>

#include <memory>
#include <mutex>
#include <optional>
#include <utility>

#include "internal_py_arguments.h"
#include "rgs/api/roofgs.h"

namespace py = pybind11;

namespace rgs::python {

/// A scene and the renderer Python uses for it (created on first render; calls serialized by a mutex), and the
/// counts of the last frame rendered through it.
struct PyScene {
  api::Scene scene;
  int cuda_device = 0;  // the device of a CUDA scene
  std::unique_ptr<api::Renderer> renderer;
  std::mutex mutex;
  std::optional<api::FrameStats> last_stats;  // guarded by mutex

  explicit PyScene(api::Scene s, int device = 0) : scene(std::move(s)), cuda_device(device) {}

  /// Scene.render(): the arguments as bind_scenes() names them, converted and checked here.
  py::object render(const api::Camera& camera_in, const StrArg& preset, const std::optional<IntArg>& width_arg,
                    const std::optional<IntArg>& height_arg, const PointArg& background, const StrArg& format,
                    bool depth, const py::object& stream, const IntArg& scratch_budget, bool settle);
};

}  // namespace rgs::python
