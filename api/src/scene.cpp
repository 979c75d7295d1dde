// load() and load_cloud(): every supported file, or float Gaussians in memory, into a Scene on the CPU or the GPU,
// through one pipeline (internal_load.h): the source opened once, the quantizing stage, the device's sink.
#include <cmath>
#include <cstring>
#include <new>
#include <optional>

#include "internal_load.h"
#include "internal_scene.h"

#if RGS_HAS_CUDA
#include "rgs/runtime/cuda_device.h"
#endif

namespace rgs::api {

const char* device_name(Device device) { return device == Device::kCuda ? "cuda" : "cpu"; }

Result<Device> parse_device(const std::string& name) {
  if (name == "cpu") return Device::kCpu;
  if (name == "cuda" || name == "gpu") return Device::kCuda;
  if (name == "auto") return cuda_available() ? Device::kCuda : Device::kCpu;
  return Status(StatusCode::kInvalidArgument, "unknown device '" + name + "' (use cpu, cuda or auto)");
}

bool cuda_available(std::string* why) {
#if RGS_HAS_CUDA
  std::string reason;
  const bool available = runtime::cuda_device_count(&reason) > 0;
  if (!available && why != nullptr) *why = reason;
  return available;
#else
  if (why != nullptr) *why = "this build has no CUDA (configured with RGS_WITH_CUDA=OFF)";
  return false;
#endif
}

const SceneInfo& Scene::info() const { return impl_->info; }

const format::GaussianCloud* Scene::cloud() const {
  return impl_->info.device == Device::kCpu ? &impl_->cloud : nullptr;
}

const runtime::GpuScene* Scene::gpu_scene() const {
#if RGS_HAS_CUDA
  return impl_->gpu ? &*impl_->gpu : nullptr;  // unset for level-of-detail scenes
#else
  return nullptr;
#endif
}

namespace {

/// kInvalidArgument for level-of-detail settings no frame can use (checked whatever the file, when enabled).
Status check_lod_settings(const LodSettings& s, const std::string& path) {
  if (!s.enabled) return Status();
  RGS_RETURN_ERROR_IF(!std::isfinite(s.pixel_error) || s.pixel_error < 0, StatusCode::kInvalidArgument,
                      path + ": level-of-detail pixel error " + std::to_string(s.pixel_error) +
                          " must be finite and >= 0 (pixels)");
  RGS_RETURN_ERROR_IF(s.stream_bytes_per_frame == 0, StatusCode::kInvalidArgument,
                      path + ": level-of-detail stream_bytes_per_frame must be > 0 bytes (nothing could stream)");
  return Status();
}

/// The pipeline of load() from the source on: the stage, then the sink of options.device.
Result<Scene> load_scene(detail::LoadScene scene, const LoadOptions& options) {
  // Before quantizing, which frees a float input's cloud: a PLY and its .rgs frame the same content.
  RGS_ASSIGN_OR_RETURN(scene.content, detail::load_content_frame(scene));
  RGS_RETURN_IF_ERROR(detail::quantize_for_load(&scene, options));
  if (options.device == Device::kCpu) return detail::make_host_scene(std::move(scene), options);
  return detail::make_gpu_scene(std::move(scene), options);
}

}  // namespace

Result<Scene> load(const std::string& path, const LoadOptions& options) {
  RGS_RETURN_IF_ERROR(check_lod_settings(options.lod, path));
  if (options.device == Device::kCuda && !RGS_HAS_CUDA) {
    return Status(StatusCode::kUnsupportedFeature,
                  path + ": device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF); use device cpu");
  }
  RGS_ASSIGN_OR_RETURN(detail::LoadScene scene, detail::open_load_scene(path, options));
  return load_scene(std::move(scene), options);
}

Result<Scene> load_cloud(format::GaussianCloud cloud, const format::SceneBounds& bounds, const std::string& name,
                         const LoadOptions& options) {
  RGS_RETURN_ERROR_IF(!cloud.is_consistent(), StatusCode::kInvalidArgument,
                      name + ": Gaussian cloud arrays do not match its size and SH degree");
  detail::LoadScene scene;
  scene.name = name;
  converter::InputScene& input = scene.input.emplace();
  input.cloud = std::move(cloud);
  input.bounds = bounds;
  input.description = "float Gaussians in memory";
  LoadOptions as_given = options;  // the cloud's own values, FP32 on the GPU
  as_given.quantize_other_formats = false;
  as_given.lod = LodSettings{};
  return load_scene(std::move(scene), as_given);
}

}  // namespace rgs::api
