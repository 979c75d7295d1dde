// The .rgs sink: the quantized scene (with its levels of detail) written by format::write_scene_file in the
// runtime or the archive profile, or the levels of an out-of-core build streamed (format::write_streamed_scene_file);
// for the archive, what its codecs cost measured on what it decodes to.
#include <algorithm>

#include "../internal_pipeline.h"
#include "rgs/format/archive.h"
#include "rgs/format/writer.h"

namespace rgs::api::detail {

namespace {

/// Sections a user may name in zstd_sections.
constexpr std::pair<const char*, format::SectionId> kSectionNames[] = {
    {"metadata", format::SectionId::kMetadata}, {"provenance", format::SectionId::kProvenance},
    {"means", format::SectionId::kMeans},       {"rotations", format::SectionId::kRotations},
    {"scales", format::SectionId::kScales},     {"opacities", format::SectionId::kOpacities},
    {"sh", format::SectionId::kSh},
    {"sh_dc_residual", format::SectionId::kShDcResidual}};

/// `values` ([N, width], in the archive's order) in the source's order: Gaussian i goes to source_index[i].
template <typename T>
Result<std::vector<T>> to_source_order(std::vector<T>* values, const std::vector<uint64_t>& source_index,
                                       size_t width) {
  const size_t n = source_index.size();
  RGS_RETURN_ERROR_IF(values->size() != n * width, StatusCode::kInvalidArgument,
                      "internal error: an archive array disagrees with its Gaussian count");
  std::vector<T> out(values->size());
  for (size_t i = 0; i < n; ++i) {
    std::copy_n(values->data() + i * width, width, out.data() + source_index[i] * width);
  }
  *values = {};  // freed as soon as it is copied (peak memory)
  return out;
}

/// What the archive codecs cost: the errors of `archive`'s decoded scene (what readers of the file get)
/// against `source`, the cloud the runtime scene was quantized from, over the Gaussians it keeps (the omitted
/// ones decode to nothing: archive.h).
Result<converter::AttributeErrors> archive_errors(format::GaussianCloud source, format::ArchiveScene archive) {
  format::EncodedScene& decoded = archive.decoded;
  const uint64_t n = decoded.count;
  RGS_RETURN_ERROR_IF(archive.source_count != source.size() || archive.source_index.size() != n ||
                          n + archive.omitted.size() != archive.source_count,
                      StatusCode::kInvalidArgument,
                      "internal error: the archive holds " + std::to_string(n) + " Gaussians and omits " +
                          std::to_string(archive.omitted.size()) + ", the source " + std::to_string(source.size()));
  // rank[s]: where source Gaussian s stands among the kept ones (n for an omitted one).
  std::vector<uint64_t> rank(archive.source_count, 0);
  for (uint64_t s : archive.omitted) rank[s] = n;
  for (uint64_t s = 0, r = 0; s < archive.source_count; ++s) {
    if (rank[s] != n) rank[s] = r++;
  }
  std::vector<uint64_t> order(n);
  std::vector<bool> seen(n, false);
  for (uint64_t i = 0; i < n; ++i) {
    const uint64_t s = archive.source_index[i];
    RGS_RETURN_ERROR_IF(s >= archive.source_count || rank[s] == n || seen[rank[s]], StatusCode::kInvalidArgument,
                        "internal error: the archive's source order is not a permutation of the kept Gaussians");
    order[i] = rank[s];
    seen[rank[s]] = true;
  }
  source.remove_gaussians(archive.omitted);
  format::EncodedScene in_order;
  in_order.metadata = decoded.metadata;
  in_order.count = n;
  const size_t sh_values = 3 * format::sh_coefficient_count(decoded.metadata.sh_degree);
  RGS_ASSIGN_OR_RETURN(in_order.means, to_source_order(&decoded.means, order, 3));
  RGS_ASSIGN_OR_RETURN(in_order.rotations, to_source_order(&decoded.rotations, order, 4));
  RGS_ASSIGN_OR_RETURN(in_order.scales, to_source_order(&decoded.scales, order, 3));
  RGS_ASSIGN_OR_RETURN(in_order.opacities, to_source_order(&decoded.opacities, order, 1));
  RGS_ASSIGN_OR_RETURN(in_order.sh, to_source_order(&decoded.sh, order, sh_values));
  return converter::measure_quantization_errors(source, in_order);
}

}  // namespace

Result<format::WriteOptions> rgs_write_options(const ConvertOptions& options) {
  const int level = zstd_level_for(options);
  RGS_RETURN_ERROR_IF(level < 1 || level > 22, StatusCode::kInvalidArgument,
                      "convert: zstd level " + std::to_string(level) + " outside 1..22");
  format::WriteOptions write;
  write.zstd_level = level;
  if (options.profile == format::StorageProfile::kArchive) {
    write.profile = format::StorageProfile::kArchive;
    write.archive = options.archive;
    write.archive.zstd_level = level;
    write.archive_earlier = options.archive_earlier.get();
  }
  for (const std::string& name : options.zstd_sections) {
    bool found = false;
    for (const auto& [n, id] : kSectionNames) {
      if (name == "all" || name == n) {
        write.codecs[id] = format::Codec::kZstd;
        found = true;
      }
    }
    RGS_RETURN_ERROR_IF(!found, StatusCode::kInvalidArgument,
                        "convert: unknown zstd section '" + name +
                            "' (use all, metadata, provenance, means, rotations, scales, opacities, sh, sh_dc_residual)");
  }
  if (options.lod_levels) {
    // SPEC §4.9 A level-of-detail file keeps its per-Gaussian sections raw, so that a chunk is a byte range.
    RGS_RETURN_ERROR_IF(*options.lod_levels > format::kMaxLodLevels, StatusCode::kInvalidArgument,
                        "convert: " + std::to_string(*options.lod_levels) + " levels of detail, at most " +
                            std::to_string(format::kMaxLodLevels) + " (0: auto)");
    RGS_RETURN_ERROR_IF(options.lod_chunk_gaussians == 0, StatusCode::kInvalidArgument,
                        "convert: a level-of-detail chunk must hold at least one Gaussian");
    RGS_RETURN_ERROR_IF(write.profile == format::StorageProfile::kArchive, StatusCode::kInvalidArgument,
                        "convert: levels of detail need the runtime profile (the archive codes sections whole)");
    for (const auto& [id, codec] : write.codecs) {
      RGS_RETURN_ERROR_IF(id != format::SectionId::kMetadata && id != format::SectionId::kProvenance,
                          StatusCode::kInvalidArgument,
                          std::string("convert: levels of detail keep section ") + format::section_name(id) +
                              " raw (a chunk is read as a byte range); drop it from the zstd sections");
    }
  }
  return write;
}

Status write_rgs_output(const std::string& dst, const ConvertOptions& options, ProgressReporter* progress,
                        PipelineScene* scene, format::FileSink& files) {
  RGS_ASSIGN_OR_RETURN(format::WriteOptions write, rgs_write_options(options));
  const bool archive = write.profile == format::StorageProfile::kArchive;
  ConvertReport& report = scene->report;
  RgsOutputReport& rgs = *report.rgs;
  const converter::Levels* levels = scene->levels.get();  // built in memory or out of core
  if (levels != nullptr) {
    write.lod = &levels->index();
    rgs.lod_levels = levels->index().level_count;
    rgs.lod_chunks = levels->index().chunk_count;
    rgs.lod_gaussians = levels->head().count;
  }
  if (archive) progress->encoding_archive();
  format::ArchiveScene coded;
  const auto write_start = Clock::now();
  // The levels of an out-of-core build (no scene in memory) have their sections streamed into the file.
  RGS_ASSIGN_OR_RETURN(report.output_bytes,
                       scene->encoded ? format::write_scene_file(dst, scene->lod ? scene->lod->scene : *scene->encoded,
                                                                 write, files, archive ? &coded : nullptr)
                                      : format::write_streamed_scene_file(dst, levels->streamed(), write, files));
  report.seconds.write = seconds_since(write_start);
  report.output_description = archive  ? "RoofGS .rgs, archive profile"
                              : levels ? "RoofGS .rgs, runtime profile with levels of detail"
                                       : "RoofGS .rgs, runtime profile";
  if (levels != nullptr) note_read_limit(levels->head().count, &report);
  const format::SceneMetadata& metadata = scene->encoded ? scene->encoded->metadata : levels->head().metadata;
  rgs.sh_quantization = metadata.sh_quantization;
  const format::SceneBounds& bounds = metadata.bounds;
  rgs.extent = std::max({double(bounds.aabb_max[0]) - bounds.aabb_min[0],
                         double(bounds.aabb_max[1]) - bounds.aabb_min[1],
                         double(bounds.aabb_max[2]) - bounds.aabb_min[2], 0.0});
  if (!scene->encoded) return Status();  // the out-of-core build measured the rest
  if (archive) {
    rgs.position_step = coded.position.step;
    rgs.position_bits = coded.position.bits;
    scene->encoded.reset();  // freed before the archive's decoded scene is reordered (peak RSS)
    const auto measure_start = Clock::now();
    rgs.archive_omitted = coded.omitted.size();
    auto errors = archive_errors(std::move(scene->input.cloud), std::move(coded));
    if (!errors.ok()) return Status(errors.status()).prepend(dst);
    rgs.errors = std::move(errors).value();
    report.seconds.quantize += seconds_since(measure_start);
  }
  return Status();
}

}  // namespace rgs::api::detail
