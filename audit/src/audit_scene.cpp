#include "rgs/audit/audit_scene.h"

#include <filesystem>

#include "rgs/converter/scene_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"

namespace rgs::audit {

namespace {

Status naming(Status status, const std::string& path) {
  if (status.message().find(path) == std::string::npos) status.prepend(path);
  return status;
}

Result<AuditScene> load_rgs(const std::string& path, const format::ReadOptions& options) {
  AuditScene scene;
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(path, options));
  auto encoded = file.read_scene();
  if (!encoded.ok()) return naming(encoded.status(), path);
  auto cloud = format::dequantize(*encoded);
  if (!cloud.ok()) return naming(cloud.status(), path);
  scene.cloud = std::move(cloud).value();
  scene.bounds = file.metadata().bounds;
  scene.sh_quantization = encoded->metadata.sh_quantization;
  scene.info.format = "rgs";
  scene.info.file_bytes = file.file_size();
  uint64_t stored = 0;
  for (const format::SectionEntry& e : file.sections()) {
    scene.info.sections.push_back(
        SectionSize{format::section_name(e.id), format::codec_name(e.codec), e.stored_size, e.raw_size});
    stored += e.stored_size;
  }
  scene.info.overhead_bytes = scene.info.file_bytes >= stored ? scene.info.file_bytes - stored : 0;
  return scene;
}

Result<AuditScene> load_other(const std::string& path, const format::ReadOptions& options) {
  AuditScene scene;
  converter::SceneReadOptions read_options;
  read_options.max_gaussians = options.limits.max_gaussians;
  read_options.max_decompression_ratio = options.limits.max_decompression_ratio;
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(path, read_options));
  scene.cloud = std::move(input.cloud);
  scene.bounds = converter::compute_bounds(scene.cloud);
  scene.info.format = input.format_id;
  scene.info.file_bytes = input.file_bytes;
  return scene;
}

}  // namespace

Result<AuditScene> load_audit_scene(const std::string& path, const std::string& label,
                                    const format::ReadOptions& options) {
  auto loaded = format::is_rgs_path(path) ? load_rgs(path, options) : load_other(path, options);
  if (!loaded.ok()) return loaded.status();
  AuditScene scene = std::move(loaded).value();
  scene.info.path = path;
  scene.info.label = label.empty() ? std::filesystem::path(path).filename().string() : label;
  scene.info.gaussians = scene.cloud.size();
  scene.info.sh_degree = scene.cloud.sh_degree;
  return scene;
}

}  // namespace rgs::audit
