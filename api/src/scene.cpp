// load() and load_cloud(): every supported file, or float Gaussians in memory, into a Scene on the CPU or the GPU.
#include <cmath>
#include <cstring>
#include <new>
#include <optional>

#include "internal_scene.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"

#if RGS_HAS_CUDA
#include "internal_gpu_scene_loading.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/lod_streamer.h"
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

uint64_t cloud_bytes(const format::GaussianCloud& c) {
  return (c.means.size() + c.rotations.size() + c.scales.size() + c.opacities.size() + c.sh.size()) * sizeof(float);
}

uint64_t runtime_bytes(uint64_t n, uint32_t degree) {
  return n * (12 + 8 + 6 + 2) + n * format::sh_coefficient_count(degree) * 3;
}

/// `status` with `path` in front unless its message names the file already.
Status naming(Status status, const std::string& path) {
  if (status.message().find(path) == std::string::npos) status.prepend(path);
  return status;
}

/// Bytes of one Gaussian in the runtime sections of `file` (SPEC §4.3-4.8), the DC residual included.
uint64_t stored_gaussian_bytes(const format::RgsFile& file) {
  const bool residual = file.find(format::SectionId::kShDcResidual) != nullptr;
  return runtime_bytes(1, file.metadata().sh_degree) + (residual ? 3 : 0);
}

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

/// A scene loaded whole (not level-of-detail): with options.lod.enabled, a note when the budgets differ from the
/// defaults (the file has no levels to use them on); without, the index of a level-of-detail file in info->lod
/// (inactive), so that callers can tell that the full detail of such a file was loaded. `opened`: the .rgs file
/// loaded, or null for another format.
void describe_unused_levels(const std::string& path, const LoadOptions& options, SceneInfo* info,
                            const format::RgsFile* opened) {
  const LodSettings& s = options.lod;
  const LodSettings d;
  if (s.enabled) {
    if (s.splat_budget != d.splat_budget || s.pixel_error != d.pixel_error || s.memory_budget != d.memory_budget ||
        s.stream_bytes_per_frame != d.stream_bytes_per_frame) {
      info->notes.push_back("level-of-detail budgets not used: " + path +
                            " has no levels of detail (rgs-convert --lod-levels auto writes them); every Gaussian "
                            "is drawn");
    }
    return;
  }
  if (opened != nullptr && opened->lod() != nullptr) {
    info->lod.chunks = opened->lod()->chunk_count;
    info->lod.levels = opened->lod()->level_count;
    info->lod.stored_gaussians = opened->gaussian_count();
  }
}

/// The .rgs file at `path`, opened once for every use a load makes of it; nullopt for another format.
Result<std::optional<format::RgsFile>> open_if_rgs(const std::string& path, const LoadOptions& options) {
  if (!format::is_rgs_path(path)) return std::optional<format::RgsFile>();
  auto opened = format::RgsFile::open(path, converter::rgs_read_options(options.read_options));
  if (!opened.ok()) return naming(opened.status(), path);
  return std::optional<format::RgsFile>(std::move(opened).value());
}

/// True when the levels of detail of `file` are to be used: the file has them and options.lod asks for them (a
/// streamed-SOG level, read_options.lod, given for a .rgs loads the file whole, where read_scene refuses it).
bool use_levels(const format::RgsFile& file, const LoadOptions& options) {
  return options.lod.enabled && !options.read_options.lod.has_value() && file.lod() != nullptr;
}

SceneLodInfo lod_info(const format::RgsFile& file, const LodSettings& settings) {
  SceneLodInfo lod;
  lod.active = true;
  lod.chunks = file.lod()->chunk_count;
  lod.levels = file.lod()->level_count;
  lod.stored_gaussians = file.gaussian_count();
  lod.settings = settings;
  return lod;
}

/// The levels coarser than level 0 of a level-of-detail file (Gaussians [full detail, stored)), each range
/// copied as stored and checked on its own (RgsFile::read_lod_range: its XXH64, the value rules).
Result<format::EncodedScene> read_coarse_levels(const format::RgsFile& file) {
  const format::LodIndex& index = *file.lod();
  const uint64_t n0 = index.full_detail_count();
  format::EncodedScene coarse;
  coarse.metadata = file.metadata();
  coarse.count = file.gaussian_count() - n0;
  const uint64_t k3 = 3 * format::sh_coefficient_count(coarse.metadata.sh_degree);
  const bool residual = file.find(format::SectionId::kShDcResidual) != nullptr;
  try {
    coarse.means.resize(coarse.count * 3);
    coarse.rotations.resize(coarse.count * 4);
    coarse.scales.resize(coarse.count * 3);
    coarse.opacities.resize(coarse.count);
    coarse.sh.resize(coarse.count * k3);
    if (residual) coarse.sh_dc_residual.resize(coarse.count * 3);
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, file.name() + ": cannot hold the " + std::to_string(coarse.count) +
                                                " Gaussians of the coarser levels of detail");
  }
  const auto bytes_at = [](auto& array, uint64_t at, uint64_t record) {
    return reinterpret_cast<uint8_t*>(array.data()) + at * record;
  };
  // Record order (level-major) tiles the sections, so levels 1.. fill [n0, stored) in that order.
  uint64_t at = 0;
  for (uint32_t level = 1; level < index.level_count; ++level) {
    for (uint32_t chunk = 0; chunk < index.chunk_count; ++chunk) {
      const format::LodLevel& r = index.at(level, chunk);
      RGS_RETURN_ERROR_IF(r.first != n0 + at || at + r.count > coarse.count, StatusCode::kCorruptData,
                          file.name() + ": level " + std::to_string(level) + " of chunk " + std::to_string(chunk) +
                              " starts at Gaussian " + std::to_string(r.first) + ", not " +
                              std::to_string(n0 + at));
      format::LodRangeTarget target;
      target.means = bytes_at(coarse.means, at, 12);
      target.rotations = bytes_at(coarse.rotations, at, 8);
      target.scales = bytes_at(coarse.scales, at, 6);
      target.opacities = bytes_at(coarse.opacities, at, 2);
      target.sh = bytes_at(coarse.sh, at, k3);
      if (residual) target.sh_dc_residual = bytes_at(coarse.sh_dc_residual, at, 3);
      RGS_RETURN_IF_ERROR(file.read_lod_range(level, chunk, target).status());
      at += r.count;
    }
  }
  RGS_RETURN_ERROR_IF(at != coarse.count, StatusCode::kCorruptData,
                      file.name() + ": the levels of detail hold " + std::to_string(n0 + at) + " Gaussians, the file " +
                          std::to_string(file.gaussian_count()));
  return coarse;
}

/// What every loader of a level-of-detail .rgs reports alike: the file, its full detail and its levels.
SceneInfo lod_scene_info(const format::RgsFile& file, const std::string& path, const LoadOptions& options,
                         Device device) {
  SceneInfo info;
  info.device = device;
  info.path = path;
  info.bounds = file.metadata().bounds;
  info.source_is_rgs = true;
  info.file_bytes = file.file_size();
  info.gaussians = file.lod()->full_detail_count();
  info.sh_degree = file.metadata().sh_degree;
  info.antialiased = file.metadata().antialiased;
  if (std::string note = converter::rgs_antialiased_note(file, options.read_options); !note.empty()) {
    info.notes.push_back(std::move(note));
  }
  info.lod = lod_info(file, options.lod);
  return info;
}

/// A level-of-detail .rgs on the CPU: the full detail (read_scene: every section checked) and every coarser
/// level (each range checked), dequantized; frames select from both (Renderer::render).
Result<Scene> load_cpu_lod(const format::RgsFile& file, const std::string& path, const LoadOptions& options) {
  auto impl = std::make_shared<Scene::Impl>();
  auto encoded = file.read_scene();
  if (!encoded.ok()) return naming(encoded.status(), path);
  auto cloud = format::dequantize(*encoded);
  if (!cloud.ok()) return naming(cloud.status(), path);
  encoded = format::EncodedScene{};
  auto coarse_encoded = read_coarse_levels(file);
  if (!coarse_encoded.ok()) return naming(coarse_encoded.status(), path);
  auto coarse = format::dequantize(*coarse_encoded);
  if (!coarse.ok()) return naming(coarse.status(), path);
  impl->cloud = std::move(cloud).value();
  impl->lod = std::make_unique<LodState>();
  impl->lod->index = *file.lod();
  impl->lod->coarse = std::move(coarse).value();
  impl->lod->stored_bytes = file.gaussian_count() * stored_gaussian_bytes(file);
  SceneInfo& info = impl->info;
  info = lod_scene_info(file, path, options, Device::kCpu);
  info.memory_bytes = cloud_bytes(impl->cloud) + cloud_bytes(impl->lod->coarse);
  info.runtime_section_bytes = runtime_bytes(info.gaussians, info.sh_degree);
  info.description = "RoofGS .rgs, dequantized, " + std::to_string(info.lod.chunks) + " chunks x " +
                     std::to_string(info.lod.levels) + " levels of detail";
  if (options.lod.memory_budget != 0) {
    info.notes.push_back("level-of-detail memory budget not used on the CPU: every level of " + path +
                         " is held in host memory (" + std::to_string(info.memory_bytes) + " bytes)");
  }
  return Scene(std::move(impl));
}

Result<Scene> load_cpu(const std::string& path, const LoadOptions& options) {
  // A .rgs file is sniffed and opened once: its levels are loaded, or its full detail read.
  RGS_ASSIGN_OR_RETURN(std::optional<format::RgsFile> rgs_file, open_if_rgs(path, options));
  if (rgs_file && use_levels(*rgs_file, options)) return load_cpu_lod(*rgs_file, path, options);
  auto impl = std::make_shared<Scene::Impl>();
  SceneInfo& info = impl->info;
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, rgs_file ? converter::rgs_file_scene(*rgs_file, options.read_options)
                                                             : converter::read_scene(path, options.read_options));
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
  info.antialiased = impl->cloud.antialiased;
  info.memory_bytes = cloud_bytes(impl->cloud);
  info.runtime_section_bytes = (info.source_is_rgs || options.quantize_other_formats)
                                   ? runtime_bytes(info.gaussians, info.sh_degree)
                                   : 0;
  describe_unused_levels(path, options, &info, rgs_file ? &*rgs_file : nullptr);
  return Scene(std::move(impl));
}

#if RGS_HAS_CUDA
// LodSettings' defaults are the streamer's (scene.h cannot include the CUDA header that states them).
static_assert(LodSettings{}.splat_budget == runtime::LodStreamOptions{}.budget.max_splats &&
              LodSettings{}.pixel_error == runtime::LodStreamOptions{}.budget.pixel_error &&
              LodSettings{}.memory_budget == runtime::LodStreamOptions{}.memory_budget &&
              LodSettings{}.stream_bytes_per_frame == runtime::LodStreamOptions{}.stream_bytes_per_frame);

/// A level-of-detail .rgs on the GPU: a LodStreamer with the coarsest level of every chunk uploaded.
Result<Scene> load_cuda_lod(const format::RgsFile& file, const std::string& path, const LoadOptions& options) {
  for (Preset p : options.presets) {
    RGS_RETURN_ERROR_IF(preset_reads_fp32(p), StatusCode::kInvalidArgument,
                        path + ": preset " + preset_name(p) +
                            " reads FP32 attributes, and a level-of-detail scene streams the compact ones only; "
                            "load it with LoadOptions::lod.enabled = false to render its full detail");
  }
  runtime::LodStreamOptions stream_options;
  stream_options.budget = {options.lod.splat_budget, options.lod.pixel_error};
  stream_options.memory_budget = options.lod.memory_budget;
  stream_options.stream_bytes_per_frame = options.lod.stream_bytes_per_frame;
  auto streamer = runtime::LodStreamer::open(file, stream_options);
  if (!streamer.ok()) return naming(streamer.status(), path);
  auto impl = std::make_shared<Scene::Impl>();
  impl->lod = std::make_unique<LodState>();
  LodState& lod = *impl->lod;
  lod.index = *file.lod();
  lod.streamer.emplace(std::move(streamer).value());
  cudaEvent_t event = nullptr;
  RGS_RETURN_IF_CUDA_ERROR(cudaEventCreateWithFlags(&event, cudaEventDisableTiming), path + ": frame event");
  lod.frame_done.reset(event);
  SceneInfo& info = impl->info;
  info = lod_scene_info(file, path, options, Device::kCuda);
  info.has_compact = true;
  info.memory_bytes = lod.streamer->device_bytes();
  info.runtime_section_bytes = info.gaussians * stored_gaussian_bytes(file);
  info.lod.pool_bytes = lod.streamer->pool_bytes();
  info.description = "RoofGS .rgs, " + std::to_string(info.lod.chunks) + " chunks x " +
                     std::to_string(info.lod.levels) + " levels of detail, streamed";
  return Scene(std::move(impl));
}

Result<Scene> load_cuda(const std::string& path, const LoadOptions& options) {
  RGS_RETURN_IF_ERROR(require_cuda_device(options.cuda_device));
  // A .rgs file is sniffed and opened once: the same RgsFile is streamed (levels of detail) or uploaded.
  RGS_ASSIGN_OR_RETURN(std::optional<format::RgsFile> rgs_file, open_if_rgs(path, options));
  if (rgs_file && use_levels(*rgs_file, options)) return load_cuda_lod(*rgs_file, path, options);
  runtime::GpuSceneOptions gpu_options;
  gpu_options.fp32_attributes = false;
  for (Preset p : options.presets) gpu_options.fp32_attributes |= preset_reads_fp32(p);

  std::optional<LoadedGpuScene> loaded;
  if (rgs_file) {
    RGS_ASSIGN_OR_RETURN(LoadedGpuScene l, upload_rgs_file(*rgs_file, rgs_file->file_size(), path, gpu_options));
    if (std::string note = converter::rgs_antialiased_note(*rgs_file, options.read_options); !note.empty()) {
      l.notes.push_back(std::move(note));
    }
    loaded.emplace(std::move(l));
  } else if (!options.quantize_other_formats) {
    RGS_ASSIGN_OR_RETURN(LoadedGpuScene l, load_gpu_scene(path, gpu_options, nullptr, options.read_options));
    loaded.emplace(std::move(l));
  } else {
    RGS_ASSIGN_OR_RETURN(converter::InputScene ply, converter::read_scene(path, options.read_options));
    std::vector<std::string> l_notes = std::move(ply.notes);
    auto encoded = converter::quantize(ply.cloud, converter::QuantizeOptions{});
    if (!encoded.ok()) return Status(encoded.status()).prepend(path);
    ply.cloud = format::GaussianCloud{};
    // Uploaded from the quantized arrays themselves: the device holds what the .rgs file rgs-convert writes
    // would give it, without that file's bytes being made and parsed again.
    auto scene = runtime::GpuScene::from_encoded(*encoded, gpu_options, path);
    if (!scene.ok()) return scene.status();
    loaded.emplace(LoadedGpuScene{std::move(scene).value(), encoded->metadata.bounds, false, ply.file_bytes,
                                  ply.description + ", quantized in memory as rgs-convert would", std::move(l_notes)});
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
  info.antialiased = gpu.antialiased();
  info.has_compact = gpu.has_compact();
  info.has_fp32 = gpu.has_fp32();
  info.memory_bytes = gpu.device_bytes();
  info.runtime_section_bytes = gpu.runtime_section_bytes();
  describe_unused_levels(path, options, &info, rgs_file ? &*rgs_file : nullptr);
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
  info.antialiased = cloud.antialiased;
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
  RGS_RETURN_IF_ERROR(check_lod_settings(options.lod, path));
  if (options.device == Device::kCpu) return load_cpu(path, options);
#if RGS_HAS_CUDA
  return load_cuda(path, options);
#else
  return Status(StatusCode::kUnsupportedFeature,
                path + ": device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF); use device cpu");
#endif
}

}  // namespace rgs::api
