// roofgs.Scene and load(): scenes loaded from files or made from arrays, rendered with the presets.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "internal_py_arguments.h"
#include "internal_py_arrays.h"
#include "internal_py_bindings.h"
#include "internal_py_errors.h"
#include "internal_py_images.h"
#include "internal_py_scene.h"
#include "rgs/api/device_gaussians.h"

namespace rgs::python {

namespace {

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

}  // namespace

py::object PyScene::render(const api::Camera& camera_in, const StrArg& preset,
                           const std::optional<IntArg>& width_arg, const std::optional<IntArg>& height_arg,
                           const PointArg& background, const StrArg& format, bool depth,
                           const py::object& stream, const IntArg& scratch_budget, bool settle) {
  const std::optional<uint32_t> width = int_arg<uint32_t>(width_arg, "render", "width", 1, kMaxImageSide);
  const std::optional<uint32_t> height = int_arg<uint32_t>(height_arg, "render", "height", 1, kMaxImageSide);
  const std::array<double, 3> rgb = arr<3>(background, "render", "background");
  api::RenderSettings settings;
  settings.preset = unwrap(api::parse_preset(str_arg(preset, "render", "preset")));
  settings.background = {float(rgb[0]), float(rgb[1]), float(rgb[2])};
  settings.gpu_scratch_budget = int_arg<uint64_t>(scratch_budget, "render", "scratch_budget");
  settings.lod_settle = settle;
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

void bind_scenes(py::module_& m) {
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
             api::CameraChoice choice;
             choice.orbit = int_arg<uint32_t>(count, fn, "count", 1, 100000);
             choice.orbit_width = int_arg<uint32_t>(width, fn, "width", 1, kMaxImageSide);
             choice.orbit_height = int_arg<uint32_t>(height, fn, "height", 1, kMaxImageSide);
             return unwrap(api::make_cameras(choice, s.scene.info().content));
           },
           py::arg("count"), py::arg("width") = 1920, py::arg("height") = 1080,
           "A ring of cameras around the scene's content, as rgs-render --orbit places it: centred and sized on where the "
           "Gaussians are (robust to floaters), not on the bounding sphere")
      .def("render", &PyScene::render, py::arg("camera"), py::arg("preset") = "fastest",
           py::arg("width") = py::none(), py::arg("height") = py::none(),
           py::arg("background") = std::array<float, 3>{0.f, 0.f, 0.f}, py::arg("format") = "rgba32f",
           py::arg("depth") = false, py::arg("stream") = py::none(), py::arg("scratch_budget") = 0,
           py::arg("settle") = false,
           "Render from `camera` (resized to width x height if given). CPU: a NumPy array [H, W, 4]; CUDA: a "
           "DeviceImage (DLPack). depth=True returns (rgba, depth). `stream`: a CUDA stream handle (int, e.g. "
           "torch.cuda.current_stream().cuda_stream); the render is enqueued on it. `scratch_budget`: CUDA, bytes "
           "of renderer scratch memory at most (0: none); frames with more pairs render in groups of tile rows "
           "with the same image. `settle`: a CUDA level-of-detail scene streams the levels this view selects before "
           "drawing it (an offline image, as rgs-render draws), instead of drawing them two frames later");
}

void bind_loading(py::module_& m) {
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
        "Load a scene in any format (.rgs, 3DGS PLY, compressed PLY, SOG, SPZ, glTF/GLB, .ksplat, .splat) onto device "
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
}

}  // namespace rgs::python
