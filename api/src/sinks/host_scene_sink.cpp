// The host sink of load(): the Scene of the CPU reference renderer, the float Gaussians it renders: a .rgs
// dequantized (every level of a level-of-detail file when its levels are used), another format as read or
// dequantized from its quantized form (what its .rgs would render).
#include <new>

#include "../internal_load.h"
#include "rgs/format/encoded_scene.h"

namespace rgs::api::detail {

namespace {

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

/// A level-of-detail .rgs on the CPU: the full detail (read_scene: every section checked) and every coarser
/// level (each range checked), dequantized; frames select from both (Renderer::render).
Result<Scene> load_cpu_lod(const format::RgsFile& file, const std::string& path, const LoadOptions& options,
                           const ContentFrame& content) {
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
  info.content = content;
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

}  // namespace

Result<Scene> make_host_scene(LoadScene scene, const LoadOptions& options) {
  const std::string& path = scene.name;
  if (scene.rgs && use_levels(*scene.rgs, options)) return load_cpu_lod(*scene.rgs, path, options, scene.content);
  if (scene.rgs) {
    RGS_ASSIGN_OR_RETURN(scene.input, converter::rgs_file_scene(*scene.rgs, options.read_options));
  }
  converter::InputScene& input = *scene.input;
  auto impl = std::make_shared<Scene::Impl>();
  format::SceneBounds bounds = input.bounds;
  if (scene.encoded) {
    auto cloud = format::dequantize(*scene.encoded);
    if (!cloud.ok()) return Status(cloud.status()).prepend(path);
    impl->cloud = std::move(cloud).value();
    bounds = scene.encoded->metadata.bounds;
  } else {
    impl->cloud = std::move(input.cloud);
  }
  const format::GaussianCloud& cloud = impl->cloud;
  SceneInfo& info = impl->info;
  info = scene_info(path, Device::kCpu, bounds, scene.content, cloud.size(), cloud.sh_degree, cloud.antialiased);
  info.notes = std::move(input.notes);
  info.description = input.description;
  info.source_is_rgs = scene.rgs.has_value();
  info.file_bytes = input.file_bytes;
  info.memory_bytes = cloud_bytes(impl->cloud);
  info.runtime_section_bytes = (scene.rgs || scene.encoded) ? runtime_bytes(info.gaussians, info.sh_degree) : 0;
  describe_unused_levels(path, options, &info, scene.rgs ? &*scene.rgs : nullptr);
  return Scene(std::move(impl));
}

}  // namespace rgs::api::detail
