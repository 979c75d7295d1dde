// The GPU sink of load(): the Scene in device memory, a .rgs's sections uploaded as stored (FP32 arrays only when
// a listed preset reads them), a quantized scene from its arrays, a float one as FP32; or, for a level-of-detail
// .rgs, a streamer with the coarsest level of every chunk uploaded.
#include "../internal_load.h"

#if RGS_HAS_CUDA
#include "../internal_gpu_scene_loading.h"
#include "rgs/runtime/lod_streamer.h"
#endif

namespace rgs::api::detail {

#if RGS_HAS_CUDA
namespace {

// LodSettings' defaults are the streamer's (scene.h cannot include the CUDA header that states them).
static_assert(LodSettings{}.splat_budget == runtime::LodStreamOptions{}.budget.max_splats &&
              LodSettings{}.pixel_error == runtime::LodStreamOptions{}.budget.pixel_error &&
              LodSettings{}.memory_budget == runtime::LodStreamOptions{}.memory_budget &&
              LodSettings{}.stream_bytes_per_frame == runtime::LodStreamOptions{}.stream_bytes_per_frame);

/// A level-of-detail .rgs on the GPU: a LodStreamer with the coarsest level of every chunk uploaded.
Result<Scene> load_cuda_lod(const format::RgsFile& file, const std::string& path, const LoadOptions& options,
                            const ContentFrame& content) {
  for (Preset p : options.presets) {
    RGS_RETURN_ERROR_IF(preset_reads_fp32(p) && !options.skip_unrenderable_presets, StatusCode::kInvalidArgument,
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
  info.content = content;
  info.has_compact = true;
  info.memory_bytes = lod.streamer->device_bytes();
  info.runtime_section_bytes = info.gaussians * stored_gaussian_bytes(file);
  info.lod.pool_bytes = lod.streamer->pool_bytes();
  info.description = "RoofGS .rgs, " + std::to_string(info.lod.chunks) + " chunks x " +
                     std::to_string(info.lod.levels) + " levels of detail, streamed";
  return Scene(std::move(impl));
}

/// The device scene of `scene`: the .rgs file's sections as stored, the quantized arrays, or the float cloud.
Result<LoadedGpuScene> upload(LoadScene& scene, const runtime::GpuSceneOptions& gpu_options,
                              const LoadOptions& options) {
  const std::string& path = scene.name;
  if (scene.rgs) {
    RGS_ASSIGN_OR_RETURN(LoadedGpuScene l, upload_rgs_file(*scene.rgs, scene.rgs->file_size(), path, gpu_options));
    if (std::string note = converter::rgs_antialiased_note(*scene.rgs, options.read_options); !note.empty()) {
      l.notes.push_back(std::move(note));
    }
    return l;
  }
  converter::InputScene& input = *scene.input;
  if (scene.encoded) {
    // Uploaded from the quantized arrays themselves: the device holds what the .rgs file rgs-convert writes
    // would give it, without that file's bytes being made and parsed again.
    auto gpu = runtime::GpuScene::from_encoded(*scene.encoded, gpu_options, path);
    if (!gpu.ok()) return gpu.status();
    return LoadedGpuScene{std::move(gpu).value(), scene.encoded->metadata.bounds, false, input.file_bytes,
                          input.description + ", quantized in memory as rgs-convert would", std::move(input.notes)};
  }
  auto gpu = runtime::GpuScene::from_cloud(input.cloud, input.bounds);
  if (!gpu.ok()) return naming(gpu.status(), path);
  return LoadedGpuScene{std::move(gpu).value(), input.bounds, false, input.file_bytes, input.description,
                        std::move(input.notes)};
}

}  // namespace

Result<Scene> make_gpu_scene(LoadScene scene, const LoadOptions& options) {
  RGS_RETURN_IF_ERROR(require_cuda_device(options.cuda_device));
  const std::string& path = scene.name;
  if (scene.rgs && use_levels(*scene.rgs, options)) return load_cuda_lod(*scene.rgs, path, options, scene.content);
  runtime::GpuSceneOptions gpu_options;
  gpu_options.fp32_attributes = false;
  for (Preset p : options.presets) gpu_options.fp32_attributes |= preset_reads_fp32(p);
  RGS_ASSIGN_OR_RETURN(LoadedGpuScene loaded, upload(scene, gpu_options, options));
  auto impl = std::make_shared<Scene::Impl>();
  const runtime::GpuScene& gpu = impl->gpu.emplace(std::move(loaded.scene));
  SceneInfo& info = impl->info;
  info = scene_info(path, Device::kCuda, loaded.bounds, scene.content, gpu.size(), gpu.sh_degree(), gpu.antialiased());
  info.source_is_rgs = loaded.is_rgs;
  info.file_bytes = loaded.file_bytes;
  info.notes = std::move(loaded.notes);
  info.description = loaded.description;
  info.has_compact = gpu.has_compact();
  info.has_fp32 = gpu.has_fp32();
  info.memory_bytes = gpu.device_bytes();
  info.runtime_section_bytes = gpu.runtime_section_bytes();
  describe_unused_levels(path, options, &info, scene.rgs ? &*scene.rgs : nullptr);
  return Scene(std::move(impl));
}
#else
Result<Scene> make_gpu_scene(LoadScene scene, const LoadOptions&) {
  return Status(StatusCode::kUnsupportedFeature,
                scene.name + ": device cuda: this build has no CUDA support (RGS_WITH_CUDA=OFF); use device cpu");
}
#endif

}  // namespace rgs::api::detail
