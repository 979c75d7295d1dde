// What the host and GPU sinks of load() report alike about a scene: where its content is, its sizes and its levels
// of detail.
#include <algorithm>
#include <new>

#include "../internal_load.h"
#include "rgs/format/half.h"

namespace rgs::api::detail {

uint64_t runtime_bytes(uint64_t n, uint32_t degree) {
  return n * (12 + 8 + 6 + 2) + n * format::sh_coefficient_count(degree) * 3;
}

uint64_t cloud_bytes(const format::GaussianCloud& c) {
  return (c.means.size() + c.rotations.size() + c.scales.size() + c.opacities.size() + c.sh.size()) * sizeof(float);
}

uint64_t stored_gaussian_bytes(const format::RgsFile& file) {
  const bool residual = file.find(format::SectionId::kShDcResidual) != nullptr;
  return runtime_bytes(1, file.metadata().sh_degree) + (residual ? 3 : 0);
}

Result<ContentFrame> load_content_frame(const LoadScene& scene) {
  if (!scene.rgs) return content_frame(scene.input->cloud);
  const format::RgsFile& file = *scene.rgs;
  format::GaussianCloud cloud;  // the means and opacities alone
  std::vector<uint16_t> opacities;
  try {
    cloud.means.resize(3 * file.gaussian_count());
    opacities.resize(file.gaussian_count());
  } catch (const std::bad_alloc&) {
    // Left to the sink, which decodes the sections with its own bounds and names what is wrong with them.
    return ContentFrame::of_sphere(file.metadata().bounds);
  }
  RGS_RETURN_IF_ERROR(file.decode_section(format::SectionId::kMeans, cloud.means.data(), 4 * cloud.means.size()));
  RGS_RETURN_IF_ERROR(file.decode_section(format::SectionId::kOpacities, opacities.data(), 2 * opacities.size()));
  cloud.means.resize(3 * file.full_detail_count());  // a level-of-detail file's coarser levels follow
  opacities.resize(file.full_detail_count());
  cloud.opacities.resize(opacities.size());
  std::transform(opacities.begin(), opacities.end(), cloud.opacities.begin(), format::half_bits_to_float);
  return content_frame(cloud);
}

bool use_levels(const format::RgsFile& file, const LoadOptions& options) {
  return options.lod.enabled && !options.read_options.lod.has_value() && file.lod() != nullptr;
}

SceneInfo scene_info(const std::string& path, Device device, const format::SceneBounds& bounds,
                     const ContentFrame& content, uint64_t gaussians, uint32_t sh_degree, bool antialiased) {
  SceneInfo info;
  info.path = path;
  info.device = device;
  info.bounds = bounds;
  info.content = content;
  info.gaussians = gaussians;
  info.sh_degree = sh_degree;
  info.antialiased = antialiased;
  return info;
}

SceneInfo lod_scene_info(const format::RgsFile& file, const std::string& path, const LoadOptions& options,
                         Device device) {
  SceneInfo info = scene_info(path, device, file.metadata().bounds, {}, file.lod()->full_detail_count(),
                              file.metadata().sh_degree, file.metadata().antialiased);
  info.source_is_rgs = true;
  info.file_bytes = file.file_size();
  if (std::string note = converter::rgs_antialiased_note(file, options.read_options); !note.empty()) {
    info.notes.push_back(std::move(note));
  }
  info.lod.active = true;
  info.lod.chunks = file.lod()->chunk_count;
  info.lod.levels = file.lod()->level_count;
  info.lod.stored_gaussians = file.gaussian_count();
  info.lod.settings = options.lod;
  return info;
}

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

}  // namespace rgs::api::detail
