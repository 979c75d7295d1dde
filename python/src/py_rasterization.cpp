// roofgs.rasterization(): gsplat's rasterization() call for inference, rendered by RoofGS; CUDA arrays are read
// where they are and the images written into torch tensors.
#include <pybind11/eval.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "internal_py_arguments.h"
#include "internal_py_arrays.h"
#include "internal_py_bindings.h"
#include "internal_py_errors.h"
#include "rgs/api/device_gaussians.h"

namespace rgs::python {

namespace {

/// What identifies the Gaussian arrays of a rasterization() call for the upload cache: each tensor itself
/// (weakly referenced: the cache keeps no tensor alive), its version counter (torch's _version, bumped by
/// every in-place change through the tensor or its views), data pointer, shape, strides and dtype, and how
/// its colours are read.
struct ArraysKey {
  std::vector<py::weakref> tensors;
  std::vector<int64_t> versions, pointers;
  std::vector<std::vector<int64_t>> shapes, strides;
  std::vector<std::string> dtypes;
  bool rgb = false;
  std::optional<uint32_t> sh_degree;

  /// Equal arrays: the same live tensors, unchanged. Needs the GIL.
  bool matches(const ArraysKey& other) const {
    if (tensors.size() != other.tensors.size()) return false;
    for (size_t i = 0; i < tensors.size(); ++i) {
      const py::object a = tensors[i](), b = other.tensors[i]();
      if (a.is_none() || !a.is(b)) return false;
    }
    return versions == other.versions && pointers == other.pointers && shapes == other.shapes &&
           strides == other.strides && dtypes == other.dtypes && rgb == other.rgb && sh_degree == other.sh_degree;
  }
};

/// The cache key of five torch tensors; nullopt when any is not a torch tensor (other arrays are never cached).
std::optional<ArraysKey> arrays_key(const std::array<const py::object*, 5>& arrays, bool rgb,
                                    std::optional<uint32_t> sh_degree) {
  ArraysKey key;
  key.rgb = rgb;
  key.sh_degree = sh_degree;
  for (const py::object* obj : arrays) {
    if (!is_torch_tensor(*obj)) return std::nullopt;
    key.tensors.emplace_back(*obj);
    key.versions.push_back(obj->attr("_version").cast<int64_t>());
    key.pointers.push_back(obj->attr("data_ptr")().cast<int64_t>());
    key.shapes.push_back(obj->attr("shape").cast<std::vector<int64_t>>());
    key.strides.push_back(obj->attr("stride")().cast<std::vector<int64_t>>());
    key.dtypes.push_back(py::str(obj->attr("dtype")));
  }
  return key;
}

/// The views of a rasterization() call: gsplat's viewmats [C, 4, 4] and Ks [C, 3, 3] as cameras, and their
/// backgrounds [C, 3] (black when none).
struct GsplatViews {
  std::vector<api::Camera> cameras;
  std::vector<std::array<float, 3>> backgrounds;
};

GsplatViews gsplat_views(const py::object& viewmats, const py::object& Ks, const py::object& backgrounds,
                         uint32_t width, uint32_t height, float near_plane) {
  const auto views = float_array(viewmats, "viewmats"), intrinsics = float_array(Ks, "Ks");
  size_t count = 0;
  check_shape(views, "viewmats", &count, {4, 4});
  check_shape(intrinsics, "Ks", &count, {3, 3});
  GsplatViews out;
  out.backgrounds.assign(count, {0.f, 0.f, 0.f});
  if (!backgrounds.is_none()) {
    const auto b = float_array(backgrounds, "backgrounds");
    check_shape(b, "backgrounds", &count, {3});
    for (size_t c = 0; c < count; ++c) out.backgrounds[c] = {b.data()[c * 3], b.data()[c * 3 + 1], b.data()[c * 3 + 2]};
  }
  api::CameraOptions camera_options;
  camera_options.near_plane = near_plane;
  for (size_t c = 0; c < count; ++c) {
    const float* v = views.data() + c * 16;
    const float* k = intrinsics.data() + c * 9;
    // gsplat's K puts pixel centres at half-integers (corner origin); camera_from_opencv's at integers.
    const std::array<double, 9> K{k[0], k[1], k[2] - 0.5, k[3], k[4], k[5] - 0.5, k[6], k[7], k[8]};
    const std::array<double, 9> R{v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10]};
    const std::array<double, 3> t{v[3], v[7], v[11]};
    out.cameras.push_back(unwrap(api::camera_from_opencv(K, R, t, width, height, camera_options)));
  }
  return out;
}

/// rasterization()'s meta dict: the preset, the size, and the (tile, Gaussian) pairs of each view.
py::dict gsplat_meta(const std::string& preset, uint32_t width, uint32_t height, const std::vector<uint64_t>& pairs) {
  py::dict meta;
  meta["preset"] = preset;
  meta["width"] = width;
  meta["height"] = height;
  meta["n_cameras"] = pairs.size();
  meta["pairs"] = pairs;
  return meta;
}

/// The renderer, scratch frame and last upload of rasterization() on one CUDA device, shared by the calls
/// (serialized by the mutex, which is only waited for without the GIL).
struct CudaRasterizer {
  std::mutex mutex;
  std::optional<api::Renderer> renderer;
  std::optional<api::Image> frame;  // rgba32f (+ depth) of the last size: rendered into, then split
  std::optional<api::Scene> scene;  // the last upload
  std::optional<ArraysKey> key;     // its tensors, when they can be recognized again
  std::optional<int64_t> stream;    // the stream of the last call
};

CudaRasterizer& cuda_rasterizer(int device) {
  // Never destroyed: its Python references and device memory must not be released after the interpreter and
  // the CUDA runtime have shut down.
  static auto* states = new std::map<int, std::unique_ptr<CudaRasterizer>>();
  std::unique_ptr<CudaRasterizer>& state = (*states)[device];  // under the GIL
  if (!state) state = std::make_unique<CudaRasterizer>();
  return *state;
}

/// rasterization() on Gaussians in CUDA memory: uploaded on the device (or taken from the cache), rendered
/// view by view into a scratch frame and split into torch tensors on torch's current stream.
py::tuple rasterization_cuda(int device, const std::array<const py::object*, 5>& arrays, bool rgb,
                             std::optional<uint32_t> sh_degree, bool antialiased, const GsplatViews& views, uint32_t width,
                             uint32_t height, bool rgb_out, api::DepthOutput depth, const std::string& preset,
                             bool cache) {
  const py::module_ torch = import_torch();
  api::RenderSettings settings;
  settings.preset = unwrap(api::parse_preset(preset));
  const TorchDeviceGuard guard(torch, device);
  CudaRasterizer& state = cuda_rasterizer(device);
  std::unique_lock<std::mutex> lock(state.mutex, std::defer_lock);
  {
    py::gil_scoped_release release;
    lock.lock();
  }
  const int64_t stream = torch_stream(torch, device);
  // The scratch frame and the renderer's buffers were last used on another stream: let that work finish.
  if (state.stream && *state.stream != stream) torch.attr("cuda").attr("synchronize")(device);
  state.stream = stream;
  const api::Stream s = reinterpret_cast<api::Stream>(static_cast<uintptr_t>(stream));

  std::optional<ArraysKey> key = cache ? arrays_key(arrays, rgb, sh_degree) : std::nullopt;
  const bool upload = !key || !state.key || !state.scene || !key->matches(*state.key) ||
                      state.scene->info().antialiased != antialiased;
  if (upload) {
    state.scene.reset();  // frees the last upload before the next one
    state.key.reset();
    const DeviceGaussiansArrays borrowed(*arrays[0], *arrays[1], *arrays[2], *arrays[3], *arrays[4], rgb,
                                         sh_degree, device, stream);
    api::DeviceLoadOptions options;
    options.cuda_device = device;
    options.stream = s;
    options.antialiased = antialiased;
    Result<api::Scene> scene = Status(StatusCode::kInvalidArgument, "not loaded");
    {
      py::gil_scoped_release release;
      scene = api::load_device_gaussians(borrowed.gaussians(), options);
    }
    state.scene.emplace(unwrap(std::move(scene)));
    state.key = std::move(key);
  }

  const size_t cameras = views.cameras.size();
  const size_t pixels = size_t(width) * height;
  const int64_t channels = (rgb_out ? 3 : 0) + (depth != api::DepthOutput::kNone ? 1 : 0);
  const py::object options = py::dict(py::arg("dtype") = torch.attr("float32"),
                                      py::arg("device") = torch.attr("device")("cuda", device));
  const auto empty = [&](int64_t c) {
    return torch.attr("empty")(py::make_tuple(cameras, height, width, c), **options);
  };
  py::object out_colors = empty(channels), out_alphas = empty(1);
  float* colors = reinterpret_cast<float*>(out_colors.attr("data_ptr")().cast<uintptr_t>());
  float* alphas = reinterpret_cast<float*>(out_alphas.attr("data_ptr")().cast<uintptr_t>());
  std::vector<uint64_t> pairs;
  Status status;
  {
    py::gil_scoped_release release;
    auto run = [&]() -> Status {
      if (!state.renderer) {
        RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(api::Device::kCuda, device));
        state.renderer.emplace(std::move(renderer));
      }
      const bool with_depth = depth != api::DepthOutput::kNone;
      for (size_t c = 0; c < cameras; ++c) {
        settings.background = views.backgrounds[c];
        const api::Camera& camera = views.cameras[c];
        api::FrameStats stats;
        if (state.frame && state.frame->width() == width && state.frame->height() == height &&
            (state.frame->depth() != nullptr) == with_depth) {
          RGS_ASSIGN_OR_RETURN(stats, state.renderer->render(*state.scene, camera, settings, state.frame->target(), s));
        } else {
          state.frame.reset();
          RGS_ASSIGN_OR_RETURN(api::Image frame, state.renderer->render_image(*state.scene, camera, settings,
                                                                              api::PixelFormat::kRgba32f,
                                                                              with_depth, s));
          stats = frame.frame_stats();
          state.frame.emplace(std::move(frame));
        }
        api::PlanarTarget target;
        target.colors = colors + c * pixels * size_t(channels);
        target.rgb = rgb_out;
        target.depth = depth;
        target.alphas = alphas + c * pixels;
        RGS_RETURN_IF_ERROR(api::write_planar(*state.frame, target, s));
        pairs.push_back(stats.pairs);
      }
      return Status();
    };
    status = run();
    // An upload nothing can recognize again is not kept (freeing it waits for the frames that read it).
    if (!state.key) state.scene.reset();
  }
  check(status);
  py::dict meta = gsplat_meta(preset, width, height, pairs);
  meta["uploaded"] = upload;  // false: the Gaussians of the last call were rendered again
  return py::make_tuple(out_colors, out_alphas, meta);
}

/// gsplat's rasterization() for inference on one batch element (the Python rasterization() below checks
/// gsplat's options, loops over leading batch dimensions and returns the caller's array type).
py::tuple rasterization(const py::object& means, const py::object& quats, const py::object& scales,
                        const py::object& opacities, const py::object& colors, const py::object& viewmats,
                        const py::object& Ks, const IntArg& width_arg, const IntArg& height_arg,
                        const FloatArg& near_plane_arg, const std::optional<IntArg>& sh_degree_arg,
                        const py::object& backgrounds, const StrArg& render_mode_arg, bool antialiased,
                        const StrArg& preset_arg, const StrArg& device_arg, bool cache) {
  const char* fn = "rasterization";
  const uint32_t width = int_arg<uint32_t>(width_arg, fn, "width", 1, kMaxImageSide);
  const uint32_t height = int_arg<uint32_t>(height_arg, fn, "height", 1, kMaxImageSide);
  const float near_plane = float(float_arg(near_plane_arg, fn, "near_plane", kPositive));
  const std::optional<uint32_t> sh_degree = int_arg<uint32_t>(sh_degree_arg, fn, "sh_degree");
  const std::string render_mode = str_arg(render_mode_arg, fn, "render_mode");
  const std::string preset = str_arg(preset_arg, fn, "preset"), device = str_arg(device_arg, fn, "device");
  const bool rgb_out = render_mode.rfind("RGB", 0) == 0;
  const std::string depth_mode = rgb_out ? (render_mode.size() > 3 ? render_mode.substr(4) : "") : render_mode;
  if ((rgb_out && render_mode.size() > 3 && render_mode[3] != '+') || (depth_mode != "" && depth_mode != "D" &&
                                                                       depth_mode != "ED")) {
    throw value_error(fn, "render_mode", "RGB, D, ED, RGB+D or RGB+ED", py::repr(render_mode_arg));
  }
  const GsplatViews views = gsplat_views(viewmats, Ks, backgrounds, width, height, near_plane);
  const std::array<const py::object*, 5> arrays{&means, &quats, &scales, &opacities, &colors};
  if (const std::optional<int> cuda = device_arrays_device(arrays, device)) {
    const api::DepthOutput depth = depth_mode.empty()  ? api::DepthOutput::kNone
                                   : depth_mode == "D" ? api::DepthOutput::kAccumulated
                                                       : api::DepthOutput::kExpected;
    return rasterization_cuda(*cuda, arrays, !sh_degree, sh_degree, antialiased, views, width, height, rgb_out, depth,
                              preset, cache);
  }
  format::GaussianCloud cloud = cloud_from_arrays(means, quats, scales, opacities, colors, !sh_degree);
  if (sh_degree) check(converter::reduce_sh_degree(&cloud, *sh_degree));
  cloud.antialiased = antialiased;
  api::LoadOptions load;
  load.device = resolve_device(device);
  api::RenderSettings settings;
  settings.preset = unwrap(api::parse_preset(preset));
  const size_t cameras = views.cameras.size();
  const size_t pixels = size_t(width) * height;
  py::array_t<float> out_colors({py::ssize_t(cameras), py::ssize_t(height), py::ssize_t(width),
                                 py::ssize_t(rgb_out ? 3 : 0) + (depth_mode.empty() ? 0 : 1)});
  py::array_t<float> out_alphas({py::ssize_t(cameras), py::ssize_t(height), py::ssize_t(width), py::ssize_t(1)});
  std::vector<uint64_t> pairs;
  Status status;
  {
    py::gil_scoped_release release;
    std::vector<float> rgba(pixels * 4), depth(pixels);
    float* colors_out = out_colors.mutable_data();
    float* alphas_out = out_alphas.mutable_data();
    const size_t channels = size_t(out_colors.shape(3));
    auto run = [&]() -> Status {
      RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::scene_from_cloud(std::move(cloud), "arrays"));
      RGS_ASSIGN_OR_RETURN(api::Scene scene, api::load_cloud(std::move(input.cloud), input.bounds, "arrays", load));
      RGS_ASSIGN_OR_RETURN(api::Renderer renderer, api::Renderer::create(scene.device(), 0));
      for (size_t c = 0; c < cameras; ++c) {
        settings.background = views.backgrounds[c];
        RGS_ASSIGN_OR_RETURN(api::Image image, renderer.render_image(scene, views.cameras[c], settings,
                                                                      api::PixelFormat::kRgba32f, !depth_mode.empty()));
        RGS_RETURN_IF_ERROR(image.copy_to_host(rgba.data(), depth_mode.empty() ? nullptr : depth.data()));
        for (size_t i = 0; i < pixels; ++i) {
          float* px = colors_out + (c * pixels + i) * channels;
          const float alpha = rgba[i * 4 + 3];
          if (rgb_out) std::copy(&rgba[i * 4], &rgba[i * 4 + 3], px);
          if (!depth_mode.empty()) px[channels - 1] = depth_mode == "D" ? depth[i] * alpha : depth[i];
          alphas_out[c * pixels + i] = alpha;
        }
        pairs.push_back(image.frame_stats().pairs);
      }
      return Status();
    };
    status = run();
  }
  check(status);
  return py::make_tuple(out_colors, out_alphas, gsplat_meta(preset, width, height, pairs));
}

}  // namespace

void bind_rasterization(py::module_& m) {
  m.def("_rasterization", &rasterization, py::arg("means"), py::arg("quats"), py::arg("scales"),
        py::arg("opacities"), py::arg("colors"), py::arg("viewmats"), py::arg("Ks"), py::arg("width"),
        py::arg("height"), py::kw_only(), py::arg("near_plane"), py::arg("sh_degree"), py::arg("backgrounds"),
        py::arg("render_mode"), py::arg("antialiased"), py::arg("preset"), py::arg("device"), py::arg("cache"),
        "rasterization()'s implementation: one batch element, gsplat's options already checked");
  py::dict scope = m.attr("__dict__");
  // rasterization() takes gsplat's signature as it is (every option, positional or by name, so a gsplat call
  // runs unchanged); its defaults are the one list of what is accepted. Options that change only how gsplat
  // computes (memory layout, channel chunks, sort) take any value; the others only their default.
  py::exec(R"py(
def rasterization(means, quats, scales, opacities, colors, viewmats, Ks, width, height, near_plane=0.01,
                  far_plane=1e10, radius_clip=0.0, eps2d=0.3, sh_degree=None, packed=True, tile_size=16,
                  backgrounds=None, render_mode="RGB", sparse_grad=False, absgrad=False, rasterize_mode="classic",
                  channel_chunk=32, distributed=False, camera_model="pinhole", segmented=False, covars=None,
                  with_ut=False, with_eval3d=False, radial_coeffs=None, tangential_coeffs=None,
                  thin_prism_coeffs=None, ftheta_coeffs=None, rolling_shutter=None, viewmats_rs=None, *,
                  preset="fastest", device="auto", cache=True):
    _check_gsplat_options(locals())
    lead = tuple(_numpy().shape(means)[:-2])  # nested lists too (any array-like the renderer converts)
    one = lambda b: _rasterization(*b[:7], width, height, near_plane=near_plane, sh_degree=sh_degree,
                                   backgrounds=b[7], render_mode=render_mode,
                                   antialiased=rasterize_mode == "antialiased", preset=preset, device=device,
                                   cache=cache)
    arrays = [means, quats, scales, opacities, colors, viewmats, Ks, backgrounds]
    if not lead:
        out_colors, out_alphas, meta = one(arrays)
        return _as_caller_array(out_colors, means), _as_caller_array(out_alphas, means), meta
    # gsplat's leading batch dimensions [..., N, 3] / [..., C, 4, 4]: one render per batch element.
    import math
    count = math.prod(lead)
    tails = {"means": 2, "quats": 2, "scales": 2, "opacities": 1, "colors": 3 if sh_degree is not None else 2,
             "viewmats": 3, "Ks": 3, "backgrounds": 2}
    flat = []
    for (name, tail), a in zip(tails.items(), arrays):
        if a is None:
            flat.append(None)
            continue
        if not hasattr(a, "reshape"):
            a = _numpy().asarray(a, dtype=_numpy().float32)
        if tuple(a.shape[:-tail]) != lead or len(a.shape) != len(lead) + tail:
            raise ValueError(name + ": expected the leading batch dimensions " + str(list(lead)) + " of means, "
                             "then " + str(tail) + " dimensions; got shape " + str(list(a.shape)))
        flat.append(a.reshape((count,) + tuple(a.shape[len(lead):])))
    results = [one([a if a is None else a[b] for a in flat]) for b in range(count)]
    meta = dict(results[0][2])
    meta["batch_dims"] = list(lead)
    meta["n_cameras"] = sum(r[2]["n_cameras"] for r in results)
    meta["pairs"] = [p for r in results for p in r[2]["pairs"]]
    if "uploaded" in meta:
        meta["uploaded"] = any(r[2]["uploaded"] for r in results)
    def stacked(i):
        parts = [r[i] for r in results]
        torch = _torch_of(parts[0])
        whole = torch.stack(parts) if torch is not None else _numpy().stack(parts)
        return _as_caller_array(whole.reshape(lead + tuple(whole.shape[1:])), means)
    return stacked(0), stacked(1), meta

def _numpy():
    import numpy
    return numpy

def _torch_of(array):
    """torch when `array` is a torch tensor (torch already imported by the caller), else None."""
    import sys
    torch = sys.modules.get("torch")
    return torch if torch is not None and isinstance(array, torch.Tensor) else None

def _as_caller_array(out, like):
    """`out` as the array type of `like`: a host NumPy result becomes a torch CPU tensor for torch inputs."""
    torch = _torch_of(like)
    if torch is not None and _torch_of(out) is None:
        return torch.from_numpy(out)
    return out

# Options that change only how gsplat computes, never the image: any value is taken.
_GSPLAT_ANY_VALUE = ("packed", "channel_chunk", "segmented")

def _check_gsplat_options(given):
    import inspect
    import numbers
    for name, p in inspect.signature(rasterization).parameters.items():
        if p.default is inspect.Parameter.empty or p.kind == p.KEYWORD_ONLY or name in _GSPLAT_ANY_VALUE:
            continue
        if name in ("near_plane", "sh_degree", "backgrounds", "render_mode"):
            continue  # rendered as gsplat does
        if name == "rasterize_mode" and given[name] in ("classic", "antialiased"):
            continue  # antialiased: opacities scaled by the 2D filter's compensation, as gsplat does
        value = given[name]
        if p.default is None:
            ok = value is None or (name == "rolling_shutter" and getattr(value, "name", None) == "GLOBAL")
        elif isinstance(p.default, bool):
            ok = isinstance(value, (bool, int)) and bool(value) == p.default
        elif isinstance(p.default, str):
            ok = value == p.default
        else:
            ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and (
                value == p.default or (name == "far_plane" and value >= p.default))
        if not ok:
            shown = repr(value)[:40] if isinstance(value, (numbers.Real, str)) else "<" + type(value).__name__ + ">"
            raise ValueError("roofgs.rasterization renders gsplat's classic pinhole inference without gradients; "
                             + name + "=" + shown + " is not supported (only " + name + "="
                             + repr(p.default) + ", gsplat's default" + (", or more" if name == "far_plane" else "")
                             + ")")
)py", scope);
  m.attr("rasterization").attr("__doc__") = py::str(
        "gsplat.rasterization's call for inference: swap the import to render trained Gaussians with RoofGS.\n"
        "means [..., N, 3]; quats [..., N, 4] (w, x, y, z, normalized here); scales [..., N, 3] activated "
        "(linear); opacities [..., N] activated, in [0, 1]; colors [..., N, K, 3] SH with sh_degree given (its "
        "first (sh_degree+1)^2 coefficients are used), else [..., N, 3] RGB; viewmats [..., C, 4, 4] "
        "world-to-camera (OpenCV axes: x right, y down, z forward); Ks [..., C, 3, 3] pixel intrinsics with "
        "gsplat's pixel centres at half-integers; width, height in pixels; near_plane: Gaussians nearer are "
        "culled; backgrounds [..., C, 3]; render_mode RGB, D, ED, RGB+D or RGB+ED (ED: expected depth, D: "
        "accumulated = ED x alpha). Leading batch dimensions (gsplat's `...`, the same on every array) are "
        "rendered one batch element after the other and kept on the outputs.\n"
        "Outputs: colors [..., C, H, W, 3 or 4], alphas [..., C, H, W, 1] (float32) in the caller's array type, "
        "and meta. NumPy arrays in: NumPy out. torch CPU tensors in: torch CPU tensors out. CUDA arrays (torch "
        "tensors; any DLPack producer's float32 C-contiguous arrays): the Gaussians are copied and checked on "
        "their device (no host copy) unless device='cpu', rendered on torch's current stream, and the outputs "
        "are torch CUDA tensors on that device. With cache=True the upload of the last torch tensors is reused "
        "while they are the same tensors with the same version counter (in-place changes bump it; writes "
        "through .data or raw pointers do not: pass cache=False then); meta['uploaded'] says whether the call "
        "uploaded. meta: preset, width, height, n_cameras (images rendered), pairs per image, batch_dims with "
        "batch dimensions. rasterize_mode 'antialiased' scales each opacity by the 2D filter's compensation "
        "sqrt(det Σ2 / det(Σ2 + 0.3 I)), as gsplat does (a scene trained with Mip-Splatting's filter). Every other "
        "gsplat option is accepted at its default value; packed, channel_chunk "
        "and segmented (how gsplat computes, not what) at any value; a non-default value of the others "
        "(gradients, other camera models, far plane below 1e10, radius clip, eps2d, tile "
        "size, covariances, distortion, rolling shutter, distributed) raises ValueError naming the option");
}

}  // namespace rgs::python
