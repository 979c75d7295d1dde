#include "rgs/audit/audit_scene.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <functional>
#include <utility>

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
  const auto t_start = std::chrono::steady_clock::now();
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
  scene.info.load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return scene;
}

Result<std::vector<AuditScene>> attribution_scenes(const AuditScene& source, const AuditScene& candidate) {
  const format::GaussianCloud& a = source.cloud;
  const format::GaussianCloud& b = candidate.cloud;
  RGS_RETURN_ERROR_IF(a.size() != b.size() || a.sh_degree != b.sh_degree, StatusCode::kInvalidArgument,
                      candidate.info.path + ": attribution needs the source's Gaussians in the same order (" +
                          std::to_string(b.size()) + " of SH degree " + std::to_string(b.sh_degree) + " against " +
                          std::to_string(a.size()) + " of degree " + std::to_string(a.sh_degree) + ")");
  const size_t k = a.sh_coefficients();
  // Each group copies its values from the candidate into a copy of the source.
  const std::vector<std::pair<std::string, std::function<void(format::GaussianCloud&)>>> groups = {
      {"means", [&](format::GaussianCloud& c) { c.means = b.means; }},
      {"rotations", [&](format::GaussianCloud& c) { c.rotations = b.rotations; }},
      {"scales", [&](format::GaussianCloud& c) { c.scales = b.scales; }},
      {"opacities", [&](format::GaussianCloud& c) { c.opacities = b.opacities; }},
      {"SH DC", [&](format::GaussianCloud& c) {
         for (size_t i = 0; i < c.size(); ++i) std::copy_n(&b.sh[i * k * 3], 3, &c.sh[i * k * 3]);
       }},
      {"SH bands 1+", [&](format::GaussianCloud& c) {
         for (size_t i = 0; i < c.size(); ++i) std::copy_n(&b.sh[i * k * 3 + 3], (k - 1) * 3, &c.sh[i * k * 3 + 3]);
       }},
  };
  std::vector<AuditScene> scenes;
  for (const auto& [group, take] : groups) {
    if (group == "SH bands 1+" && k == 1) continue;
    AuditScene hybrid;
    hybrid.cloud = a;
    take(hybrid.cloud);
    hybrid.bounds = group == "means" ? candidate.bounds : source.bounds;
    hybrid.info = candidate.info;
    hybrid.info.label = candidate.info.label + ": " + group + " only";
    hybrid.info.file_bytes = 0;  // not a file: no size to report
    hybrid.info.sections.clear();
    hybrid.info.overhead_bytes = 0;
    hybrid.info.notes.clear();
    hybrid.info.load_seconds = 0;  // made in memory, not read
    scenes.push_back(std::move(hybrid));
  }
  return scenes;
}

}  // namespace rgs::audit
