#include "rgs/audit/audit_scene.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <utility>

#include "internal_report_svg.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"

namespace rgs::audit {

namespace {

/// The longest side of the box of `cloud`'s means (0 without Gaussians).
double means_extent(const format::GaussianCloud& cloud) {
  if (cloud.size() == 0) return 0;
  float lo[3], hi[3];
  format::box_of_means(cloud.means.data(), cloud.size(), lo, hi);
  return std::max({double(hi[0]) - lo[0], double(hi[1]) - lo[1], double(hi[2]) - lo[2]});
}

/// The section table of a .rgs file: what each section stores and decodes to (header and table only).
void list_sections(const format::RgsFile& file, AuditScene* scene) {
  uint64_t stored = 0;
  for (const format::SectionEntry& e : file.sections()) {
    scene->info.sections.push_back(
        SectionSize{format::section_name(e.id), format::codec_name(e.codec), e.stored_size, e.raw_size});
    stored += e.stored_size;
  }
  scene->info.overhead_bytes = scene->info.file_bytes >= stored ? scene->info.file_bytes - stored : 0;
}

/// The scene at `path` read whole; a .rgs opened once, for its Gaussians and its section table.
Result<converter::InputScene> read_audit_input(const std::string& path, const converter::SceneReadOptions& options,
                                               AuditScene* scene) {
  if (!format::is_rgs_path(path)) return converter::read_scene(path, options);
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(path, converter::rgs_read_options(options)));
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::rgs_file_scene(file, options));
  scene->info.file_bytes = input.file_bytes;
  list_sections(file, scene);
  for (const auto& [key, value] : file.provenance()) {
    if (key == "options") scene->conversion_options = value;
  }
  return input;
}

}  // namespace

Result<AuditScene> load_audit_scene(const std::string& path, const std::string& label,
                                    const converter::SceneReadOptions& options) {
  const auto t_start = std::chrono::steady_clock::now();
  converter::SceneReadOptions read_options = options;
  read_options.keep_encoded = true;  // a .rgs candidate's SH quantization
  AuditScene scene;
  auto input = read_audit_input(path, read_options, &scene);
  if (!input.ok()) return naming(input.status(), path);
  scene.cloud = std::move(input->cloud);
  scene.bounds = input->bounds;
  scene.info.format = input->format_id;
  scene.info.file_bytes = input->file_bytes;
  scene.info.notes = std::move(input->notes);
  if (input->encoded) scene.sh_quantization = input->encoded->metadata.sh_quantization;
  scene.info.path = path;
  scene.info.label = label.empty() ? std::filesystem::path(path).filename().string() : label;
  scene.info.gaussians = scene.cloud.size();
  scene.info.sh_degree = scene.cloud.sh_degree;
  scene.info.load_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return scene;
}

Result<converter::GaussianPairing> pair_with_source(const AuditScene& source, const AuditScene& candidate) {
  if (candidate.source_order && candidate.cloud.size() == source.cloud.size()) {
    converter::GaussianPairing pairing;
    pairing.reference_of_test.resize(candidate.cloud.size());
    for (uint64_t i = 0; i < candidate.cloud.size(); ++i) pairing.reference_of_test[i] = i;
    return pairing;
  }
  converter::PairingOptions options;
  options.max_position_distance = kPairingMaxDistanceOfExtent * means_extent(source.cloud);
  auto pairing = converter::pair_gaussians(source.cloud, candidate.cloud, options);
  if (!pairing.ok()) return naming(pairing.status(), candidate.info.path);
  return pairing;
}

std::string unpaired_note(const converter::GaussianPairing& pairing, uint64_t candidate_gaussians) {
  char within[96];
  std::snprintf(within, sizeof(within), "within %.3g scene units", pairing.position_tolerance);
  const std::string of = " of " + group_digits(candidate_gaussians) + " candidate Gaussians ";
  if (pairing.far_test > 0) {
    return group_digits(pairing.far_test) + of + "have no source Gaussian " + within + " (1/" +
           std::to_string(std::lround(1 / kPairingMaxDistanceOfExtent)) + " of the source's extent)";
  }
  return group_digits(pairing.unpaired_test) + of + "cannot be paired one to one with a source Gaussian " + within +
         ": every source Gaussian that near them is paired with a candidate Gaussian nearer to it";
}

Result<std::vector<AuditScene>> attribution_scenes(const AuditScene& source, const AuditScene& candidate) {
  const format::GaussianCloud& a = source.cloud;
  const format::GaussianCloud& b = candidate.cloud;
  RGS_RETURN_ERROR_IF(a.sh_degree != b.sh_degree, StatusCode::kInvalidArgument,
                      candidate.info.path + ": attribution needs the source's SH degree (" +
                          std::to_string(b.sh_degree) + " against " + std::to_string(a.sh_degree) + ")");
  RGS_ASSIGN_OR_RETURN(const converter::GaussianPairing pairing, pair_with_source(source, candidate));
  RGS_RETURN_ERROR_IF(!pairing.complete(), StatusCode::kInvalidArgument,
                      candidate.info.path +
                          ": attribution needs every candidate Gaussian paired with a source Gaussian: " +
                          unpaired_note(pairing, b.size()));
  const std::vector<uint64_t>& to = pairing.reference_of_test;
  const size_t k = a.sh_coefficients();
  // Each group copies its values from candidate Gaussian j into source Gaussian to[j] of a copy of the source.
  auto copy = [&](const std::vector<float>& from, std::vector<float>* into, size_t width, size_t offset, size_t n) {
    for (size_t j = 0; j < to.size(); ++j) std::copy_n(&from[j * width + offset], n, &(*into)[to[j] * width + offset]);
  };
  const std::vector<std::pair<std::string, std::function<void(format::GaussianCloud&)>>> groups = {
      {"means", [&](format::GaussianCloud& c) { copy(b.means, &c.means, 3, 0, 3); }},
      {"rotations", [&](format::GaussianCloud& c) { copy(b.rotations, &c.rotations, 4, 0, 4); }},
      {"scales", [&](format::GaussianCloud& c) { copy(b.scales, &c.scales, 3, 0, 3); }},
      {"opacities", [&](format::GaussianCloud& c) {
         std::fill(c.opacities.begin(), c.opacities.end(), 0.f);  // the Gaussians the candidate left out
         copy(b.opacities, &c.opacities, 1, 0, 1);
       }},
      {"SH DC", [&](format::GaussianCloud& c) { copy(b.sh, &c.sh, k * 3, 0, 3); }},
      {"SH bands 1+", [&](format::GaussianCloud& c) { copy(b.sh, &c.sh, k * 3, 3, (k - 1) * 3); }},
  };
  std::vector<AuditScene> scenes;
  for (const auto& [group, take] : groups) {
    if (group == "SH bands 1+" && k == 1) continue;
    AuditScene hybrid;
    hybrid.cloud = a;
    take(hybrid.cloud);
    // The means scene holds the candidate's means and the source's where the candidate has none.
    hybrid.bounds = group == "means" ? converter::compute_bounds(hybrid.cloud) : source.bounds;
    hybrid.source_order = true;
    hybrid.info = candidate.info;
    hybrid.info.label = candidate.info.label + ": " + group + " only";
    hybrid.info.gaussians = a.size();
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
