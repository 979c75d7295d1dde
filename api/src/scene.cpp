// load() and load_cloud(): every supported file, or float Gaussians in memory, into a Scene on the CPU or the GPU.
#include "internal_scene.h"
#include "rgs/api/scene_loading.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

#if RGS_HAS_CUDA
#include "rgs/api/gpu_scene_loading.h"
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
  return impl_->gpu ? &*impl_->gpu : nullptr;
#else
  return nullptr;
#endif
}

namespace {

uint64_t cloud_bytes(const format::GaussianCloud& c) {
  return (c.means.size() + c.rotations.size() + c.scales.size() + c.opacities.size() + c.sh.size()) * sizeof(float);
}

uint64_t runtime_bytes(uint64_t n, uint32_t degree) {
  return n * (12 + 8 + 6 + 2) + n * format::sh_coefficient_count(degree) * 3;
}

Result<Scene> load_cpu(const std::string& path, const LoadOptions& options) {
  auto impl = std::make_shared<Scene::Impl>();
  SceneInfo& info = impl->info;
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(path, options.read_options));
  info.notes = std::move(input.notes);
  info.description = input.description;
  info.source_is_rgs = input.format_id == "rgs";
  info.file_bytes = input.file_bytes;
  if (info.source_is_rgs || !options.quantize_other_formats) {
    impl->cloud = std::move(input.cloud);
    info.bounds = input.bounds;
  } else {
    auto encoded = converter::quantize(input.cloud, converter::QuantizeOptions{});
    if (!encoded.ok()) return Status(encoded.status()).prepend(path);
    auto cloud = format::dequantize(*encoded);
    if (!cloud.ok()) return Status(cloud.status()).prepend(path);
    impl->cloud = std::move(cloud).value();
    info.bounds = encoded->metadata.bounds;
  }
  info.device = Device::kCpu;
  info.path = path;
  info.gaussians = impl->cloud.size();
  info.sh_degree = impl->cloud.sh_degree;
  info.memory_bytes = cloud_bytes(impl->cloud);
  info.runtime_section_bytes = (info.source_is_rgs || options.quantize_other_formats)
                                   ? runtime_bytes(info.gaussians, info.sh_degree)
                                   : 0;
  return Scene(std::move(impl));
}

#if RGS_HAS_CUDA
Result<Scene> load_cuda(const std::string& path, const LoadOptions& options) {
  RGS_RETURN_IF_ERROR(require_cuda_device(options.cuda_device));
  runtime::GpuSceneOptions gpu_options;
  gpu_options.fp32_attributes = false;
  for (Preset p : options.presets) gpu_options.fp32_attributes |= preset_reads_fp32(p);

  std::optional<LoadedGpuScene> loaded;
  if (is_rgs_path(path) || !options.quantize_other_formats) {
    RGS_ASSIGN_OR_RETURN(LoadedGpuScene l, load_gpu_scene(path, gpu_options, nullptr, options.read_options));
    loaded.emplace(std::move(l));
  } else {
    RGS_ASSIGN_OR_RETURN(converter::InputScene ply, converter::read_scene(path, options.read_options));
    std::vector<std::string> l_notes = std::move(ply.notes);
    auto encoded = converter::quantize(ply.cloud, converter::QuantizeOptions{});
    if (!encoded.ok()) return Status(encoded.status()).prepend(path);
    ply.cloud = format::GaussianCloud{};
    auto bytes = format::serialize_scene(*encoded);
    if (!bytes.ok()) return Status(bytes.status()).prepend(path);
    RGS_ASSIGN_OR_RETURN(LoadedGpuScene l, upload_rgs_bytes(*bytes, ply.file_bytes, path, gpu_options));
    l.is_rgs = false;
    l.notes = std::move(l_notes);
    l.description = ply.description + ", quantized in memory as rgs-convert would";
    loaded.emplace(std::move(l));
  }
  auto impl = std::make_shared<Scene::Impl>();
  SceneInfo& info = impl->info;
  info.device = Device::kCuda;
  info.path = path;
  info.bounds = loaded->bounds;
  info.source_is_rgs = loaded->is_rgs;
  info.file_bytes = loaded->file_bytes;
  info.notes = std::move(loaded->notes);
  info.description = loaded->description;
  impl->gpu.emplace(std::move(loaded->scene));
  const runtime::GpuScene& gpu = *impl->gpu;
  info.gaussians = gpu.size();
  info.sh_degree = gpu.sh_degree();
  info.has_compact = gpu.has_compact();
  info.has_fp32 = gpu.has_fp32();
  info.memory_bytes = gpu.device_bytes();
  info.runtime_section_bytes = gpu.runtime_section_bytes();
  return Scene(std::move(impl));
}
#endif

}  // namespace

Result<Scene> load_cloud(format::GaussianCloud cloud, const format::SceneBounds& bounds, const std::string& name,
                         const LoadOptions& options) {
  RGS_RETURN_ERROR_IF(!cloud.is_consistent(), StatusCode::kInvalidArgument,
                      name + ": Gaussian cloud arrays do not match its size and SH degree");
  auto impl = std::make_shared<Scene::Impl>();
  SceneInfo& info = impl->info;
  info.path = name;
  info.device = options.device;
  info.bounds = bounds;
  info.gaussians = cloud.size();
  info.sh_degree = cloud.sh_degree;
  info.description = "float Gaussians in memory";
  if (options.device == Device::kCpu) {
    info.memory_bytes = cloud_bytes(cloud);
    impl->cloud = std::move(cloud);
    return Scene(std::move(impl));
  }
#if RGS_HAS_CUDA
  RGS_RETURN_IF_ERROR(require_cuda_device(options.cuda_device));
  auto gpu = runtime::GpuScene::from_cloud(cloud, bounds);
  if (!gpu.ok()) return Status(gpu.status()).prepend(name);
  impl->gpu.emplace(std::move(gpu).value());
  info.has_fp32 = true;
  info.memory_bytes = impl->gpu->device_bytes();
  return Scene(std::move(impl));
#else
  return Status(StatusCode::kUnsupportedFeature,
                name + ": device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF); use device cpu");
#endif
}

Result<Scene> load(const std::string& path, const LoadOptions& options) {
  if (options.device == Device::kCpu) return load_cpu(path, options);
#if RGS_HAS_CUDA
  return load_cuda(path, options);
#else
  return Status(StatusCode::kUnsupportedFeature,
                path + ": device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF); use device cpu");
#endif
}

}  // namespace rgs::api
