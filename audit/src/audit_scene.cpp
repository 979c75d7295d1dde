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

/// The section table of a .rgs file: what each section stores and decodes to (header and table only).
Status list_sections(const std::string& path, const format::ReadOptions& options, AuditScene* scene) {
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(path, options));
  uint64_t stored = 0;
  for (const format::SectionEntry& e : file.sections()) {
    scene->info.sections.push_back(
        SectionSize{format::section_name(e.id), format::codec_name(e.codec), e.stored_size, e.raw_size});
    stored += e.stored_size;
  }
  scene->info.overhead_bytes = scene->info.file_bytes >= stored ? scene->info.file_bytes - stored : 0;
  return Status();
}

}  // namespace

Result<AuditScene> load_audit_scene(const std::string& path, const std::string& label,
                                    const converter::SceneReadOptions& options) {
  converter::SceneReadOptions read_options = options;
  read_options.keep_encoded = true;  // a .rgs candidate's SH quantization
  auto input = converter::read_scene(path, read_options);
  if (!input.ok()) return naming(input.status(), path);
  AuditScene scene;
  scene.cloud = std::move(input->cloud);
  scene.bounds = input->bounds;
  scene.info.format = input->format_id;
  scene.info.file_bytes = input->file_bytes;
  scene.info.notes = std::move(input->notes);
  if (input->encoded) {
    scene.sh_quantization = input->encoded->metadata.sh_quantization;
    input->encoded.reset();
    RGS_RETURN_IF_ERROR(list_sections(path, converter::rgs_read_options(options), &scene));
  }
  scene.info.path = path;
  scene.info.label = label.empty() ? std::filesystem::path(path).filename().string() : label;
  scene.info.gaussians = scene.cloud.size();
  scene.info.sh_degree = scene.cloud.sh_degree;
  return scene;
}

}  // namespace rgs::audit
