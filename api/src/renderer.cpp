// Renderer and Image: presets rendered into caller memory on the GPU (runtime::GpuRenderer) or the CPU
// (runtime::render_cpu).
#include "rgs/api/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <optional>

#include "internal_scene.h"
#include "rgs/format/half.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/lod_selection.h"
#include "rgs/runtime/preset_techniques.h"

#if RGS_HAS_CUDA
#include "internal_gpu_scene_loading.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/gpu_renderer.h"
#include "rgs/runtime/lod_streamer.h"
#endif

namespace rgs::api {

size_t bytes_per_pixel(PixelFormat format) {
  return format == PixelFormat::kRgba32f ? 16 : format == PixelFormat::kRgba16f ? 8 : 4;
}

const char* pixel_format_name(PixelFormat format) {
  switch (format) {
    case PixelFormat::kRgba32f: return "rgba32f";
    case PixelFormat::kRgba16f: return "rgba16f";
    case PixelFormat::kRgba8: return "rgba8";
  }
  return "unknown";
}

Result<PixelFormat> parse_pixel_format(const std::string& name) {
  for (PixelFormat f : {PixelFormat::kRgba32f, PixelFormat::kRgba16f, PixelFormat::kRgba8}) {
    if (name == pixel_format_name(f)) return f;
  }
  return Status(StatusCode::kInvalidArgument, "unknown pixel format '" + name + "' (use rgba32f, rgba16f or rgba8)");
}

namespace {

/// Host-side checks of a target (the GPU path repeats them in runtime::validate_output_image).
Status check_target(const ImageTarget& t, const Camera& camera) {
  RGS_RETURN_ERROR_IF(t.width != camera.width || t.height != camera.height, StatusCode::kInvalidArgument,
                      "image target: size " + std::to_string(t.width) + "x" + std::to_string(t.height) +
                          " differs from the camera's " + std::to_string(camera.width) + "x" +
                          std::to_string(camera.height));
  RGS_RETURN_ERROR_IF(t.color == nullptr, StatusCode::kInvalidArgument, "image target: colour pointer is null");
  const size_t row = size_t(t.width) * bytes_per_pixel(t.format);
  const size_t channel = bytes_per_pixel(t.format) / 4;
  RGS_RETURN_ERROR_IF(t.color_pitch < row || t.color_pitch % channel != 0 ||
                          reinterpret_cast<uintptr_t>(t.color) % channel != 0,
                      StatusCode::kInvalidArgument,
                      "image target: colour pitch " + std::to_string(t.color_pitch) + " must be >= " +
                          std::to_string(row) + " and, like the pointer, a multiple of " + std::to_string(channel));
  if (t.depth != nullptr) {
    RGS_RETURN_ERROR_IF(t.depth_pitch < size_t(t.width) * 4 || t.depth_pitch % 4 != 0 ||
                            reinterpret_cast<uintptr_t>(t.depth) % 4 != 0,
                        StatusCode::kInvalidArgument,
                        "image target: depth pitch " + std::to_string(t.depth_pitch) +
                            " must be a multiple of 4 of at least " + std::to_string(size_t(t.width) * 4));
  }
  return Status();
}

/// Writes a CPU render into a host target (the rules of kernels/output_convert.h).
void write_host_target(const runtime::RenderResult& r, const ImageTarget& t) {
  for (uint32_t y = 0; y < t.height; ++y) {
    char* row = static_cast<char*>(t.color) + size_t(y) * t.color_pitch;
    for (uint32_t x = 0; x < t.width; ++x) {
      const size_t p = size_t(y) * t.width + x;
      const float v[4] = {r.rgb[p * 3], r.rgb[p * 3 + 1], r.rgb[p * 3 + 2], t.write_alpha ? r.alpha[p] : 1.f};
      if (t.format == PixelFormat::kRgba32f) {
        std::memcpy(row + size_t(x) * 16, v, 16);
      } else if (t.format == PixelFormat::kRgba16f) {
        uint16_t h[4];
        for (int c = 0; c < 4; ++c) h[c] = format::float_to_half_bits(v[c]);
        std::memcpy(row + size_t(x) * 8, h, 8);
      } else {
        uint8_t* out = reinterpret_cast<uint8_t*>(row) + size_t(x) * 4;
        for (int c = 0; c < 4; ++c) out[c] = kernels::unorm8(v[c]);
      }
    }
    if (t.depth != nullptr) {
      float* drow = reinterpret_cast<float*>(reinterpret_cast<char*>(t.depth) + size_t(y) * t.depth_pitch);
      std::memcpy(drow, r.depth.data() + size_t(y) * t.width, size_t(t.width) * sizeof(float));
    }
  }
}

/// The Gaussians a CPU frame of a level-of-detail scene draws, into `out` (its memory reused): the chosen level of
/// each chunk of `selection`, in its (chunk) order, copied from the full detail `full` (level 0) or the coarser
/// levels `lod.coarse`. The GPU's LodStreamer gathers its resident levels in the same order.
Status gather_lod_frame(const format::GaussianCloud& full, const LodState& lod,
                        const runtime::LodSelection& selection, format::GaussianCloud& out) {
  const uint64_t n0 = full.size();
  const size_t k3 = size_t(full.sh_coefficients()) * 3;
  uint64_t total = 0;
  for (const runtime::LodChoice& choice : selection.choices) total += lod.index.at(choice.level, choice.chunk).count;
  out.sh_degree = full.sh_degree;
  out.antialiased = full.antialiased;
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&] { out.resize(total); return Status(); }, [&] {
    return "level-of-detail frame: cannot hold " + std::to_string(total) + " Gaussians";
  }));
  size_t at = 0;
  for (const runtime::LodChoice& choice : selection.choices) {
    const format::LodLevel& range = lod.index.at(choice.level, choice.chunk);
    const format::GaussianCloud& src = range.first < n0 ? full : lod.coarse;
    const size_t first = range.first < n0 ? range.first : range.first - n0;
    const size_t n = range.count;
    const auto copy = [&](const std::vector<float>& from, std::vector<float>& to, size_t record) {
      std::copy_n(from.begin() + first * record, n * record, to.begin() + at * record);
    };
    copy(src.means, out.means, 3);
    copy(src.rotations, out.rotations, 4);
    copy(src.scales, out.scales, 3);
    copy(src.opacities, out.opacities, 1);
    copy(src.sh, out.sh, k3);
    at += n;
  }
  return Status();
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// Image

Image::Impl::~Impl() {
#if RGS_HAS_CUDA
  if (ready != nullptr) cudaEventDestroy(ready);
  if (device_color != nullptr) cudaFree(device_color);
  if (device_depth != nullptr) cudaFree(device_depth);
#endif
}

Image::Image() : impl_(std::make_unique<Impl>()) {}
Image::Image(Image&&) noexcept = default;
Image& Image::operator=(Image&&) noexcept = default;
Image::~Image() = default;

Device Image::device() const { return impl_->device; }
int Image::cuda_device() const { return impl_->cuda_device; }
uint32_t Image::width() const { return impl_->width; }
uint32_t Image::height() const { return impl_->height; }
PixelFormat Image::format() const { return impl_->format; }
void* Image::color() const {
  return impl_->device == Device::kCuda ? impl_->device_color : static_cast<void*>(impl_->host_color.data());
}
size_t Image::color_pitch() const { return size_t(impl_->width) * bytes_per_pixel(impl_->format); }
float* Image::depth() const {
  if (!impl_->with_depth) return nullptr;
  return impl_->device == Device::kCuda ? impl_->device_depth : impl_->host_depth.data();
}
const FrameStats& Image::frame_stats() const { return impl_->stats; }

ImageTarget Image::target() const {
  ImageTarget t;
  t.width = width();
  t.height = height();
  t.color = color();
  t.color_pitch = color_pitch();
  t.format = format();
  t.depth = depth();
  t.depth_pitch = size_t(width()) * sizeof(float);
  return t;
}

Status Image::make_stream_wait(Stream consumer) const {
#if RGS_HAS_CUDA
  if (impl_->device == Device::kCuda && impl_->ready != nullptr) {
    RGS_RETURN_IF_CUDA_ERROR(cudaStreamWaitEvent(consumer, impl_->ready, 0), "Image: cudaStreamWaitEvent");
  }
#else
  (void)consumer;
#endif
  return Status();
}

Status Image::synchronize() const {
#if RGS_HAS_CUDA
  if (impl_->device == Device::kCuda && impl_->ready != nullptr) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(impl_->ready), "Image: cudaEventSynchronize");
  }
#endif
  return Status();
}

Status Image::copy_to_host(void* color_out, float* depth_out) const {
  const size_t bytes = size_t(width()) * height() * bytes_per_pixel(format());
  const size_t depth_bytes = size_t(width()) * height() * sizeof(float);
  if (impl_->device == Device::kCpu) {
    std::memcpy(color_out, impl_->host_color.data(), bytes);
    if (depth_out != nullptr && impl_->with_depth) std::memcpy(depth_out, impl_->host_depth.data(), depth_bytes);
    return Status();
  }
#if RGS_HAS_CUDA
  RGS_RETURN_IF_ERROR(synchronize());
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpy(color_out, impl_->device_color, bytes, cudaMemcpyDeviceToHost),
                           "Image: colour download");
  if (depth_out != nullptr && impl_->with_depth) {
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpy(depth_out, impl_->device_depth, depth_bytes, cudaMemcpyDeviceToHost),
                             "Image: depth download");
  }
#endif
  return Status();
}

// ---------------------------------------------------------------------------------------------------------
// Renderer

struct Renderer::Impl {
  Device device = Device::kCpu;
  int cuda_device = 0;
  /// CPU: the working memory of every frame, and a level-of-detail frame's Gaussians, kept between frames.
  runtime::CpuScratch cpu;
  format::GaussianCloud lod_frame;
#if RGS_HAS_CUDA
  std::optional<runtime::GpuRenderer> gpu;
#endif
};

Renderer::Renderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&&) noexcept = default;
Renderer::~Renderer() = default;

Device Renderer::device() const { return impl_->device; }

Result<Renderer> Renderer::create(Device device, int cuda_device) {
  auto impl = std::make_unique<Impl>();
  impl->device = device;
  impl->cuda_device = cuda_device;
  if (device == Device::kCuda) {
#if RGS_HAS_CUDA
    RGS_RETURN_IF_ERROR(require_cuda_device(cuda_device));
    RGS_ASSIGN_OR_RETURN(runtime::GpuRenderer gpu, runtime::GpuRenderer::create());
    impl->gpu.emplace(std::move(gpu));
#else
    return Status(StatusCode::kUnsupportedFeature,
                  "Renderer: device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF); use device cpu");
#endif
  }
  return Renderer(std::move(impl));
}

Result<FrameStats> Renderer::render(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                                    const ImageTarget& target, Stream stream) {
  RGS_RETURN_ERROR_IF(impl_ == nullptr, StatusCode::kInvalidArgument, "Renderer: used after move");
  RGS_RETURN_ERROR_IF(scene.device() != impl_->device, StatusCode::kInvalidArgument,
                      std::string("Renderer: the scene is on ") + device_name(scene.device()) +
                          " and the renderer on " + device_name(impl_->device));
  RGS_RETURN_IF_ERROR(runtime::validate_camera(camera));
  RGS_RETURN_IF_ERROR(check_target(target, camera));
  for (float c : settings.background) {
    RGS_RETURN_ERROR_IF(!std::isfinite(c), StatusCode::kInvalidArgument, "Renderer: background is not finite");
  }
  const SceneInfo& info = scene.info();
  FrameStats stats;
  const LodState* lod = scene.impl_->lod.get();
  if (impl_->device == Device::kCpu) {
    runtime::RenderOptions options = runtime::cpu_backend_options(settings.preset, info.bounds);
    options.background = settings.background;
    options.num_threads = settings.cpu_threads;
    // A level-of-detail scene draws the frame's selection with every level resident (select_lod is pure: no lock).
    if (lod != nullptr) {
      const runtime::LodSelection selection =
          runtime::select_lod(lod->index, camera, {info.lod.settings.splat_budget, info.lod.settings.pixel_error});
      RGS_RETURN_IF_ERROR(gather_lod_frame(*scene.cloud(), *lod, selection, impl_->lod_frame));
      stats.lod.splats = selection.splats;
      stats.lod.chunks_drawn = static_cast<uint32_t>(selection.choices.size());
      stats.lod.chunks_culled = selection.culled;
      stats.lod.chunks_coarsened = selection.coarsened;
      stats.lod.bytes_resident = lod->stored_bytes;
    }
    RGS_RETURN_IF_ERROR(
        runtime::render_cpu(lod != nullptr ? impl_->lod_frame : *scene.cloud(), camera, options, &impl_->cpu));
    const runtime::RenderResult& result = impl_->cpu.result;
    write_host_target(result, target);
    stats.gaussians = result.stats.gaussians;
    stats.pairs = result.stats.pairs;
    return stats;
  }
#if RGS_HAS_CUDA
  runtime::GpuRenderOptions options;
  options.preset = settings.preset;
  const bool reads_fp32 = runtime::gpu_techniques(settings.preset, info.has_compact).reads_fp32();
  RGS_RETURN_ERROR_IF(reads_fp32 && lod != nullptr, StatusCode::kInvalidArgument,
                      std::string("Renderer: preset ") + preset_name(settings.preset) +
                          " reads FP32 attributes, and the level-of-detail scene " + info.path +
                          " streams the compact ones only: load it with LoadOptions::lod.enabled = false to render "
                          "its full detail");
  RGS_RETURN_ERROR_IF(reads_fp32 && !info.has_fp32, StatusCode::kInvalidArgument,
                      std::string("Renderer: preset ") + preset_name(settings.preset) +
                          " reads FP32 attributes, and " + info.path +
                          " was loaded without them: list it in LoadOptions::presets");
  options.background = settings.background;
  options.scratch_budget = settings.gpu_scratch_budget;
  options.time_stages = settings.time_stages;
  runtime::OutputImage out;
  out.width = target.width;
  out.height = target.height;
  out.color = target.color;
  out.color_pitch = target.color_pitch;
  out.format = static_cast<runtime::PixelFormat>(static_cast<uint32_t>(target.format));
  out.write_alpha = target.write_alpha;
  out.depth = target.depth;
  out.depth_pitch = target.depth_pitch;
  runtime::GpuRenderStats gpu_stats;
  if (lod != nullptr) {
    // One frame at a time (the streamer's pool and frame arrays change with every prepare), and on the GPU after
    // the previous frame's render, whichever stream it was enqueued on.
    LodState& state = *scene.impl_->lod;
    std::lock_guard<std::mutex> lock(state.mutex);
    RGS_RETURN_IF_CUDA_ERROR(cudaStreamWaitEvent(stream, state.frame_done.get(), 0),
                             "Renderer: wait for the previous level-of-detail frame");
    auto prepared = state.streamer->prepare(camera, stream);
    // Settling: prepared again while a wanted level is on its way (requested by this call or the one before).
    uint64_t streamed_bytes = 0;
    uint32_t streamed_ranges = 0, quiet = 0;
    for (int n = 1; prepared.ok(); ++n) {
      streamed_bytes += prepared->bytes_streamed;
      streamed_ranges += prepared->ranges_streamed;
      quiet = prepared->ranges_streamed == 0 ? quiet + 1 : 0;
      if (!settings.lod_settle || prepared->chunks_not_resident == 0 || quiet > 2 || n == kLodSettlePrepares) break;
      prepared = state.streamer->prepare(camera, stream);
    }
    if (!prepared.ok()) {
      Status status = prepared.status();
      if (status.message().find(info.path) == std::string::npos) status.prepend(info.path);
      return status;
    }
    auto rendered = impl_->gpu->render(state.streamer->scene(), camera, options, out, stream);
    const cudaError_t recorded = cudaEventRecord(state.frame_done.get(), stream);
    if (!rendered.ok()) return rendered.status();
    RGS_RETURN_IF_CUDA_ERROR(recorded, "Renderer: level-of-detail frame event");
    gpu_stats = *rendered;
    const runtime::LodFrameStats& p = *prepared;
    stats.lod.splats = p.splats;
    stats.lod.chunks_drawn = p.chunks_drawn;
    stats.lod.chunks_culled = p.chunks_culled;
    stats.lod.chunks_coarsened = p.chunks_coarsened;
    stats.lod.chunks_not_resident = p.chunks_not_resident;
    stats.lod.ranges_streamed = streamed_ranges;
    stats.lod.bytes_streamed = streamed_bytes;
    stats.lod.bytes_resident = p.bytes_resident;
  } else {
    RGS_ASSIGN_OR_RETURN(gpu_stats, impl_->gpu->render(*scene.gpu_scene(), camera, options, out, stream));
  }
  stats.gaussians = gpu_stats.gaussians;
  stats.pairs = gpu_stats.pairs;
  stats.tile_groups = gpu_stats.tile_groups;
  if (gpu_stats.timed) {
    stats.times.timed = true;
    stats.times.preprocess_ms = gpu_stats.times.preprocess_ms;
    stats.times.sort_ms = gpu_stats.times.sort_ms;
    stats.times.ranges_ms = gpu_stats.times.ranges_ms;
    stats.times.render_ms = gpu_stats.times.render_ms;
    stats.times.total_ms = gpu_stats.times.total_ms;
  }
  return stats;
#else
  (void)stream;
  return Status(StatusCode::kUnsupportedFeature, "Renderer: this build has no CUDA support");
#endif
}

Result<Image> Renderer::render_image(const Scene& scene, const Camera& camera, const RenderSettings& settings,
                                     PixelFormat format, bool with_depth, Stream stream) {
  RGS_RETURN_ERROR_IF(impl_ == nullptr, StatusCode::kInvalidArgument, "Renderer: used after move");
  RGS_RETURN_IF_ERROR(runtime::validate_camera(camera));
  Image image;
  Image::Impl& im = *image.impl_;
  im.device = impl_->device;
  im.cuda_device = impl_->cuda_device;
  im.width = camera.width;
  im.height = camera.height;
  im.format = format;
  im.with_depth = with_depth;
  const size_t pixels = size_t(camera.width) * camera.height;
  const size_t color_bytes = pixels * bytes_per_pixel(format);
  if (impl_->device == Device::kCpu) {
    im.host_color.resize(color_bytes);
    if (with_depth) im.host_depth.resize(pixels);
  } else {
#if RGS_HAS_CUDA
    RGS_RETURN_IF_CUDA_ERROR(cudaMalloc(&im.device_color, color_bytes),
                             "Image: cannot allocate " + std::to_string(color_bytes) + " bytes on the GPU");
    if (with_depth) {
      RGS_RETURN_IF_CUDA_ERROR(cudaMalloc(reinterpret_cast<void**>(&im.device_depth), pixels * sizeof(float)),
                               "Image: depth plane");
    }
    RGS_RETURN_IF_CUDA_ERROR(cudaEventCreateWithFlags(&im.ready, cudaEventDisableTiming), "Image: event");
#endif
  }
  RGS_ASSIGN_OR_RETURN(im.stats, render(scene, camera, settings, image.target(), stream));
#if RGS_HAS_CUDA
  if (im.ready != nullptr) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(im.ready, stream), "Image: event record");
#endif
  return image;
}

}  // namespace rgs::api
