// convert(): read any scene, write .rgs, PLY, SPZ or GLB (with a target, the archive profile fitted to it by rate
// control, internal_rate_control.h), and report what it cost.
#include "rgs/api/convert.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <utility>

#include "internal_convert_memory.h"
#include "internal_rate_control.h"
#include "internal_rate_knobs.h"
#include "rgs/config.h"
#include "rgs/converter/gltf.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/sog_writer.h"
#include "rgs/format/archive.h"
#include "rgs/format/file_io.h"

namespace rgs::api {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

struct FormatName {
  OutputFormat format;
  const char* name;
  const char* extension;
};
constexpr FormatName kFormatNames[] = {{OutputFormat::kRgs, "rgs", ".rgs"},
                                       {OutputFormat::kPly, "ply", ".ply"},
                                       {OutputFormat::kSpz, "spz", ".spz"},
                                       {OutputFormat::kGlb, "glb", ".glb"},
                                       {OutputFormat::kSog, "sog", ".sog"}};

const FormatName& entry(OutputFormat format) {
  for (const FormatName& f : kFormatNames) {
    if (f.format == format) return f;
  }
  return kFormatNames[0];
}

/// Sections a user may name in zstd_sections.
constexpr std::pair<const char*, format::SectionId> kSectionNames[] = {
    {"metadata", format::SectionId::kMetadata}, {"provenance", format::SectionId::kProvenance},
    {"means", format::SectionId::kMeans},       {"rotations", format::SectionId::kRotations},
    {"scales", format::SectionId::kScales},     {"opacities", format::SectionId::kOpacities},
    {"sh", format::SectionId::kSh},
    {"sh_dc_residual", format::SectionId::kShDcResidual}};

Result<format::WriteOptions> write_options(const ConvertOptions& options) {
  const int level = zstd_level_for(options);
  RGS_RETURN_ERROR_IF(level < 1 || level > 22, StatusCode::kInvalidArgument,
                      "convert: zstd level " + std::to_string(level) + " outside 1..22");
  format::WriteOptions write;
  write.zstd_level = level;
  if (options.profile == format::StorageProfile::kArchive) {
    write.profile = format::StorageProfile::kArchive;
    write.archive = options.archive;
    write.archive.zstd_level = level;
    write.archive.xz = options.archive.xz && level >= kArchiveXzMinZstdLevel;
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

}  // namespace

Result<format::WriteOptions> detail::rgs_write_options(const ConvertOptions& options) { return write_options(options); }

int zstd_level_for(const ConvertOptions& options) {
  const bool archive = options.profile == format::StorageProfile::kArchive;
  return options.zstd_level.value_or(archive ? kArchiveDefaultZstdLevel : kDefaultZstdLevel);
}

namespace {

/// Whether `choice` differs from the default CameraChoice (the orbit's default size aside).
bool names_views(const CameraChoice& choice) {
  return !choice.cameras_path.empty() || choice.every != 1 || choice.limit != 0 || choice.fly != 0 ||
         choice.orbit != 0 || choice.path != 0 || choice.width != 0 || choice.height != 0;
}

/// The target's own rules (check_convert_options).
Status check_target(const ConvertOptions& options) {
  const ConvertTarget& target = options.target;
  RGS_RETURN_ERROR_IF(!target.active() && names_views(target.views), StatusCode::kInvalidArgument,
                      "convert: views (cameras, every, limit, fly, orbit, path, width, height) are chosen only for "
                      "a PSNR or byte target, and none is set");
  if (!target.active()) return Status();
  RGS_RETURN_ERROR_IF(target.psnr_db && target.bytes, StatusCode::kInvalidArgument,
                      "convert: a PSNR target and a byte target exclude each other");
  RGS_RETURN_ERROR_IF(target.psnr_db && !(std::isfinite(*target.psnr_db) && *target.psnr_db > 0),
                      StatusCode::kInvalidArgument,
                      "convert: target PSNR " + std::to_string(target.psnr_db.value_or(0)) +
                          " dB is not a finite, positive number");
  RGS_RETURN_ERROR_IF(target.bytes && *target.bytes == 0, StatusCode::kInvalidArgument,
                      "convert: a target of 0 bytes");
  RGS_RETURN_ERROR_IF(options.lod_levels.has_value(), StatusCode::kInvalidArgument,
                      "convert: a PSNR or byte target writes the archive profile, which has no levels of detail "
                      "(they need the runtime profile)");
  RGS_RETURN_ERROR_IF(options.to && *options.to != OutputFormat::kRgs, StatusCode::kInvalidArgument,
                      std::string("convert: a PSNR or byte target chooses the archive profile of a .rgs output, not ") +
                          output_format_name(*options.to));
  return Status();
}

}  // namespace

Status check_convert_options(const ConvertOptions& options) {
  RGS_RETURN_IF_ERROR(check_target(options));
  if (options.target.active() && options.profile != format::StorageProfile::kArchive) {
    ConvertOptions archive = options;  // a target writes the archive profile
    archive.profile = format::StorageProfile::kArchive;
    return check_convert_options(archive);
  }
  RGS_RETURN_ERROR_IF(options.sh_degree && *options.sh_degree > 3, StatusCode::kInvalidArgument,
                      "convert: SH degree " + std::to_string(*options.sh_degree) + " outside 0..3");
  RGS_RETURN_ERROR_IF(!(options.sh_clip_percentile > 0.0f && options.sh_clip_percentile <= 100.0f),
                      StatusCode::kInvalidArgument, "convert: SH clip percentile outside (0, 100]");
  RGS_RETURN_ERROR_IF(options.sh_dc_bits != 8 && options.sh_dc_bits != 16, StatusCode::kInvalidArgument,
                      "convert: SH DC precision of " + std::to_string(options.sh_dc_bits) + " bits is not 8 or 16");
  if (options.profile == format::StorageProfile::kArchive) {
    format::ArchiveOptions archive_options = options.archive;
    archive_options.zstd_level = zstd_level_for(options);  // as write_options() codes the archive
    Status archive = format::check_archive_options(archive_options);
    if (!archive.ok()) return archive.prepend("convert: archive profile");
  }
  return write_options(options).status();
}

namespace {

/// The transaction of a conversion (ConvertOptions::files, set by OwnedOutputs before any writing).
format::FileSink& output_files(const ConvertOptions& options) { return *options.files; }

/// Where each stage of a conversion starts, as a fraction of the whole, by output: rough shares of the
/// time of typical conversions (reading and quantizing are quick next to the archive and SPZ encoders).
struct StageShares {
  double quantize, encode, write;
};

/// With a target, rate control runs between reading and quantizing: it spreads its steps over
/// [kFitStart, kFitEnd) of the whole, and the stages that write its choice take the rest.
constexpr double kFitStart = 0.02, kFitEnd = 0.95;

StageShares stage_shares(OutputFormat output, const ConvertOptions& options) {
  if (options.target.active()) return StageShares{kFitEnd, kFitEnd + 0.01, 0.99};
  const format::StorageProfile profile = options.profile;
  if (output == OutputFormat::kRgs) {
    return profile == format::StorageProfile::kArchive ? StageShares{0.1, 0.25, 0.95} : StageShares{0.45, 0.85, 0.85};
  }
  return output == OutputFormat::kSpz ? StageShares{0.05, 0.05, 0.05} : StageShares{0.4, 0.4, 0.4};
}

/// Calls ConvertOptions::progress, if set, once per stage, keeping the fractions non-decreasing.
class ProgressReporter {
 public:
  ProgressReporter(const ConvertOptions& options, OutputFormat output)
      : callback_(options.progress), shares_(stage_shares(output, options)) {}
  void reading() { report("reading", 0.0); }
  /// Rate control's `done` steps of at most `bound`, with what its search is doing.
  void fitting(const std::string& what, uint32_t done, uint32_t bound) {
    if (!callback_) return;
    text_ = "rate control, step " + std::to_string(done) + " of <= " + std::to_string(bound) + ": " + what;
    stage_ = text_.c_str();
    const double share = bound > 0 ? double(done) / double(bound) : 0.0;
    fraction_ = std::max(fraction_, kFitStart + (kFitEnd - kFitStart) * share);
    ConvertProgress p{stage_, fraction_};
    p.step = done;
    p.steps = bound;
    callback_(p);
  }
  void quantizing() { report("quantizing", shares_.quantize); }
  void encoding_archive() { report("encoding the archive", shares_.encode); }
  void building_lod() { report("building levels of detail", shares_.quantize); }
  void writing() { report("writing", shares_.write); }
  void done() { report("done", 1.0); }

 private:
  void report(const char* stage, double fraction) {
    if (!callback_ || stage == stage_) return;
    stage_ = stage;
    fraction_ = std::max(fraction_, fraction);
    callback_(ConvertProgress{stage, fraction_});
  }
  const std::function<void(const ConvertProgress&)>& callback_;
  StageShares shares_;
  std::string text_;  ///< rate control's stage text
  const char* stage_ = nullptr;
  double fraction_ = 0;
};

/// Forwards to another sink, reporting the "writing" stage when the first bytes reach the file (before
/// that, the archive profile's encoder or the SPZ compressor is still running).
class StageSink final : public format::FileSink {
 public:
  StageSink(format::FileSink& inner, ProgressReporter& progress) : inner_(inner), progress_(progress) {}
  using format::FileSink::write;
  Status write(const std::string& path, const format::ChunkProducer& produce) override {
    return inner_.write(path, [&](const format::ChunkSink& sink) {
      return produce([&](const void* data, size_t size) {
        progress_.writing();
        return sink(data, size);
      });
    });
  }
  Status write_by_name(const std::string& path, const format::ByNameWriter& write_to) override {
    progress_.writing();
    return inner_.write_by_name(path, write_to);
  }
  Status declare(const std::vector<std::string>& paths) override { return inner_.declare(paths); }
  Status create_folder(const std::string& path) override { return inner_.create_folder(path); }

 private:
  format::FileSink& inner_;
  ProgressReporter& progress_;
};

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
/// against `source`, the cloud the runtime scene was quantized from, over the Gaussians the archive keeps (the
/// omitted ones decode to nothing: archive.h).
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

/// Whether the input's format is one made for distribution (ConvertReport::input_compact).
bool is_compact_input(const converter::InputScene& input) {
  for (const char* id : {"spz", "sog", "sog_bundle", "sog_lod", "compressed_ply", "glb", "gltf"}) {
    if (input.format_id == id) return true;
  }
  return input.storage_format == "rgs archive";
}

std::string hex64(uint64_t v) {
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(v));
  return text;
}

/// The provenance's "options" entry: every option that changes the bytes written.
std::string options_text(const ConvertOptions& options) {
  std::ostringstream text;
  text << "scale_encoding=" << (options.scale_encoding == format::ScaleEncoding::kLog ? "log" : "linear")
       << " sh_clip_percentile=" << options.sh_clip_percentile << " sh_dc_bits=" << options.sh_dc_bits << " sanitize=" << (options.sanitize ? 1 : 0)
       << " zstd_level=" << zstd_level_for(options) << " zstd=";
  for (size_t i = 0; i < options.zstd_sections.size(); ++i) text << (i ? "," : "") << options.zstd_sections[i];
  if (options.sh_degree) text << " sh_degree=" << *options.sh_degree;
  if (options.read.lod) text << " lod=" << *options.read.lod;
  text << " spz_frame=" << converter::spz_frame_name(options.read.spz_frame);
  if (options.profile == format::StorageProfile::kArchive) {
    const format::ArchiveOptions& a = options.archive;
    text << " profile=archive position_error=" << a.position_error << " rotation_bits=" << a.rotation_bits
         << " rotation_step=" << a.rotation_step << " scale_bits=" << a.scale_bits << " scale_step=" << a.scale_step
         << " opacity_bits=" << a.opacity_bits << " opacity_step=" << a.opacity_step
         << " opacity_floor=" << a.opacity_floor << " sh_step_multipliers="
         << a.sh_step_multipliers[0] << "," << a.sh_step_multipliers[1] << "," << a.sh_step_multipliers[2] << ","
         << a.sh_step_multipliers[3] << " sh_codebook_size=" << a.sh_codebook_size << " xz=" << (a.xz ? 1 : 0);
  }
  return text.str();
}

}  // namespace

void detail::note_read_limit(uint64_t gaussians, ConvertReport* report) {
  const uint64_t limit = format::ReadLimits{}.max_gaussians;
  if (gaussians <= limit) return;
  report->output_notes.push_back("the file holds " + group_digits(gaussians) +
                                 " Gaussians with its levels, over the readers' default limit of " +
                                 group_digits(limit) + ": read it with --max-gaussians " + std::to_string(gaussians) +
                                 " (Python max_gaussians=, format::ReadLimits::max_gaussians)");
}

format::Provenance detail::rgs_provenance(const std::string& src_name, const ConvertOptions& options,
                                          uint64_t file_bytes, uint64_t file_xxh64, const std::string& storage,
                                          uint64_t dropped_gaussians) {
  return {
      {"source_file", std::filesystem::path(src_name).filename().string()},
      {"source_bytes", std::to_string(file_bytes)},
      {"source_xxh64", hex64(file_xxh64)},
      {"source_storage", storage},
      {"converter", options.converter_name + " " + RGS_VERSION_STRING},
      {"options", options_text(options)},
      {"dropped_gaussians", std::to_string(dropped_gaussians)},
  };
}

namespace {

Status write_rgs(const std::string& src_name, const std::string& dst, const ConvertOptions& options,
                 converter::InputScene* input, ConvertReport* report, ProgressReporter& progress) {
  RGS_ASSIGN_OR_RETURN(format::WriteOptions write, write_options(options));
  const bool archive = write.profile == format::StorageProfile::kArchive;
  converter::QuantizeOptions quantize_options;
  quantize_options.scale_encoding = options.scale_encoding;
  quantize_options.sh_clip_percentile = options.sh_clip_percentile;
  // The archive drops the DC residual (SPEC §4.8), so its errors are measured without it.
  quantize_options.sh_dc_bits = write.profile == format::StorageProfile::kArchive ? 8 : options.sh_dc_bits;
  RgsOutputReport rgs;
  progress.quantizing();
  const auto quantize_start = Clock::now();
  // The archive's errors are measured on what it decodes to, after writing (archive_errors).
  auto encoded = converter::quantize(input->cloud, quantize_options, &rgs.quantization, archive ? nullptr : &rgs.errors);
  if (!encoded.ok()) return Status(encoded.status()).prepend(src_name);
  report->seconds.quantize = seconds_since(quantize_start);
  // Not read again by the runtime profile: freed before the writer's buffers exist (peak RSS). The archive
  // profile measures its errors against it.
  if (!archive) input->cloud = {};
  encoded->provenance = detail::rgs_provenance(src_name, options, input->file_bytes, input->file_xxh64.value_or(0),
                                               input->storage_format, input->hygiene.dropped_gaussians);
  std::optional<converter::LodScene> lod;
  if (options.lod_levels) {
    progress.building_lod();
    const auto lod_start = Clock::now();
    converter::LodBuildOptions lod_options;
    lod_options.levels = *options.lod_levels;
    lod_options.max_chunk_gaussians = options.lod_chunk_gaussians;
    auto built = converter::build_lod(*encoded, lod_options);
    if (!built.ok()) return Status(built.status()).prepend(src_name);
    lod.emplace(std::move(built).value());
    write.lod = &lod->index;
    rgs.lod_levels = lod->index.level_count;
    rgs.lod_chunks = lod->index.chunk_count;
    rgs.lod_gaussians = lod->scene.count;
    report->seconds.lod = seconds_since(lod_start);
  }
  if (archive) progress.encoding_archive();
  StageSink files(output_files(options), progress);
  format::ArchiveScene coded;
  const auto write_start = Clock::now();
  RGS_ASSIGN_OR_RETURN(report->output_bytes,
                       format::write_scene_file(dst, lod ? lod->scene : *encoded, write, files,
                                                archive ? &coded : nullptr));
  report->seconds.write = seconds_since(write_start);
  rgs.sh_quantization = encoded->metadata.sh_quantization;
  const format::SceneBounds& bounds = encoded->metadata.bounds;
  rgs.extent = std::max({double(bounds.aabb_max[0]) - bounds.aabb_min[0],
                         double(bounds.aabb_max[1]) - bounds.aabb_min[1],
                         double(bounds.aabb_max[2]) - bounds.aabb_min[2], 0.0});
  report->gaussians = encoded->count;
  report->sh_degree = encoded->metadata.sh_degree;
  if (archive) {
    rgs.position_step = coded.position.step;
    rgs.position_bits = coded.position.bits;
    encoded = format::EncodedScene{};  // freed before the archive's decoded scene is reordered (peak RSS)
    const auto measure_start = Clock::now();
    rgs.archive_omitted = coded.omitted.size();
    auto errors = archive_errors(std::move(input->cloud), std::move(coded));
    if (!errors.ok()) return Status(errors.status()).prepend(dst);
    rgs.errors = std::move(errors).value();
    report->seconds.quantize += seconds_since(measure_start);
  }
  report->output_description = archive ? "RoofGS .rgs, archive profile"
                               : lod   ? "RoofGS .rgs, runtime profile with levels of detail"
                                       : "RoofGS .rgs, runtime profile";
  report->rgs = std::move(rgs);
  if (lod) detail::note_read_limit(lod->scene.count, report);
  return Status();
}

Status write_float(const std::string& dst, const ConvertOptions& options, const converter::InputScene& input,
                   ConvertReport* report, ProgressReporter& progress) {
  const format::GaussianCloud& cloud = input.cloud;
  StageSink files(output_files(options), progress);
  const auto write_start = Clock::now();
  switch (report->output_format) {
    case OutputFormat::kPly: {
      converter::PlyWriteReport ply;
      RGS_ASSIGN_OR_RETURN(report->output_bytes, converter::write_ply(dst, cloud, &ply, files));
      report->output_description = input.format_id == "rgs" ? "INRIA PLY, dequantized" : "INRIA PLY";
      report->zero_scales = ply.zero_scales;
      if (ply.zero_scales > 0) {
        char log_scale[32];
        std::snprintf(log_scale, sizeof(log_scale), "%.4f", static_cast<double>(converter::kZeroScaleLog));
        report->output_notes.push_back(std::to_string(ply.zero_scales) + " zero scales written as log-scale " +
                                       log_scale + ", not -inf");
      }
      break;
    }
    case OutputFormat::kSpz: {
      converter::SpzWriteOptions spz_options;
      spz_options.frame = converter::spz_frame_for(options.read, dst);
      RGS_ASSIGN_OR_RETURN(converter::SpzWriteSummary spz, converter::write_spz(dst, cloud, spz_options, files));
      report->output_bytes = spz.bytes;
      report->output_description = "SPZ v" + std::to_string(spz.version);
      report->output_notes = spz.limitations;
      auto clamped = [&](uint64_t n, const char* what) {
        if (n > 0) report->output_notes.push_back(std::to_string(n) + " " + what + " clamped to the SPZ range");
      };
      clamped(spz.scales_clamped, "scale values");
      clamped(spz.colors_clamped, "DC colour values");
      clamped(spz.sh_clamped, "SH rest values");
      report->spz = std::move(spz);
      break;
    }
    case OutputFormat::kGlb: {
      RGS_ASSIGN_OR_RETURN(converter::GltfWriteSummary glb, converter::write_glb(dst, cloud, {}, files));
      report->output_bytes = glb.bytes;
      report->output_description = "KHR_gaussian_splatting GLB";
      report->output_notes = glb.limitations;
      break;
    }
    case OutputFormat::kSog: {
      converter::SogWriteOptions sog_options;
      sog_options.container = converter::is_sog_folder_path(dst) ? converter::SogContainer::kFolder
                                                                  : converter::SogContainer::kBundle;
      RGS_ASSIGN_OR_RETURN(converter::SogWriteSummary sog, converter::write_sog(dst, cloud, sog_options, files));
      report->output_bytes = sog.bytes;
      report->output_description =
          sog_options.container == converter::SogContainer::kFolder ? "PlayCanvas SOG v2 folder" : "PlayCanvas SOG v2";
      report->output_notes = sog.limitations;
      break;
    }
    case OutputFormat::kRgs:
      return Status(StatusCode::kInvalidArgument, "convert: .rgs is not a float output");
  }
  if (cloud.antialiased && report->output_format != OutputFormat::kSpz) {
    // PLY and KHR_gaussian_splatting have no field for it; SPZ keeps it in its header flag.
    report->output_notes.push_back(
        "anti-aliased scene (2D Mip filter): this format cannot say so; read the file back with --antialiased "
        "(Python: antialiased=True) to render it as trained");
  }
  report->seconds.write = seconds_since(write_start);
  report->gaussians = cloud.size();
  report->sh_degree = cloud.sh_degree;
  return Status();
}

/// A streamed SOG (dst named lod-meta.json): the cloud quantized to the runtime profile, its levels of detail
/// built (ConvertOptions::lod_levels, default 0 = auto), each level's chunks written as SOG files.
Status write_sog_lod_output(const std::string& src_name, const std::string& dst, const ConvertOptions& options,
                            converter::InputScene* input, ConvertReport* report, ProgressReporter& progress) {
  converter::QuantizeOptions quantize_options;
  quantize_options.scale_encoding = options.scale_encoding;
  quantize_options.sh_clip_percentile = options.sh_clip_percentile;
  progress.quantizing();
  const auto quantize_start = Clock::now();
  auto encoded = converter::quantize(input->cloud, quantize_options);
  if (!encoded.ok()) return Status(encoded.status()).prepend(src_name);
  report->seconds.quantize = seconds_since(quantize_start);
  report->gaussians = input->cloud.size();
  report->sh_degree = input->cloud.sh_degree;
  input->cloud = {};
  progress.building_lod();
  const auto lod_start = Clock::now();
  converter::LodBuildOptions lod_options;
  lod_options.levels = options.lod_levels.value_or(0);
  lod_options.max_chunk_gaussians = options.lod_chunk_gaussians;
  auto lod = converter::build_lod(*encoded, lod_options);
  if (!lod.ok()) return Status(lod.status()).prepend(src_name);
  report->seconds.lod = seconds_since(lod_start);
  StageSink files(output_files(options), progress);
  const auto write_start = Clock::now();
  RGS_ASSIGN_OR_RETURN(converter::SogWriteSummary sog, converter::write_sog_lod(dst, *lod, {}, files));
  report->seconds.write = seconds_since(write_start);
  report->output_bytes = sog.bytes;
  report->output_description = "PlayCanvas streamed SOG";
  report->output_notes = sog.limitations;
  return Status();
}

/// Everything after reading: checks, SH bands, the output, the report.
Result<ConvertReport> write_input(converter::InputScene input, const std::string& src_name, const std::string& dst,
                                  OutputFormat output, const ConvertOptions& options, Clock::time_point start,
                                  ProgressReporter& progress) {
  ConvertReport report;
  report.seconds.read = seconds_since(start);
  report.output_format = output;
  report.input_format = input.format_id;
  report.input_description = input.description;
  report.input_storage = input.storage_format;
  report.input_bytes = input.file_bytes;
  report.declared_gaussians = input.declared_vertices;
  report.input_compact = is_compact_input(input);
  report.hygiene = input.hygiene;
  report.input_notes = input.notes;
  if (input.cloud.size() == 0 && !options.allow_empty) {
    const std::string why = input.hygiene.dropped_gaussians > 0
                                ? "sanitizing (--sanitize) dropped all " +
                                      std::to_string(input.hygiene.dropped_gaussians) + " Gaussians, so the scene is empty"
                                : "the input has no Gaussians";
    return Status(StatusCode::kInvalidArgument,
                  src_name + ": " + why + "; allow_empty (--allow-empty) writes an empty scene");
  }
  if (options.sh_degree && *options.sh_degree < input.cloud.sh_degree) {
    report.input_notes.push_back("SH degree " + std::to_string(input.cloud.sh_degree) + " reduced to " +
                                 std::to_string(*options.sh_degree));
    RGS_RETURN_IF_ERROR(converter::reduce_sh_degree(&input.cloud, *options.sh_degree));
  }
  if (output == OutputFormat::kRgs) {
    RGS_RETURN_IF_ERROR(write_rgs(src_name, dst, options, &input, &report, progress));
  } else if (output == OutputFormat::kSog && converter::is_sog_lod_path(dst)) {
    RGS_RETURN_IF_ERROR(write_sog_lod_output(src_name, dst, options, &input, &report, progress));
  } else {
    progress.writing();
    RGS_RETURN_IF_ERROR(write_float(dst, options, input, &report, progress));
  }
  report.seconds.total = seconds_since(start);
  return report;
}

/// write_input(), after rate control with a target: the archive options fitted to it on the scene as read (its
/// SH bands all rendered as the source), then written; a file over a byte target is kLimitExceeded.
Result<ConvertReport> convert_input(converter::InputScene input, const std::string& src_name,
                                    const std::string& dst, OutputFormat output, const ConvertOptions& options,
                                    Clock::time_point start, ProgressReporter& progress) {
  if (!options.target.active()) {
    RGS_ASSIGN_OR_RETURN(ConvertReport report, write_input(std::move(input), src_name, dst, output, options, start,
                                                           progress));
    progress.done();
    return report;
  }
  const double read_seconds = seconds_since(start);
  ConvertOptions fitted = options;
  RGS_ASSIGN_OR_RETURN(RateControlReport rate,
                       detail::fit_target(input, src_name, &fitted,
                                          [&](const std::string& what, uint32_t done, uint32_t bound) {
                                            progress.fitting(what, done, bound);
                                          }));
  RGS_ASSIGN_OR_RETURN(ConvertReport report,
                       write_input(std::move(input), src_name, dst, output, fitted, start, progress));
  if (options.target.bytes && report.output_bytes > *options.target.bytes) {
    return Status(StatusCode::kLimitExceeded,
                  dst + ": the archive has " + detail::group_digits(report.output_bytes) +
                      " bytes, over the target of " + detail::group_digits(*options.target.bytes) +
                      " (its provenance is larger than the fit allowed for)");
  }
  report.seconds.read = read_seconds;  // the fit's time is rate_control.seconds (and in total)
  report.rate_control = std::move(rate);
  progress.done();
  return report;
}

}  // namespace

const char* output_format_name(OutputFormat format) { return entry(format).name; }

Status check_convert_output(const std::string& dst, OutputFormat output, const ConvertOptions& options) {
  RGS_RETURN_ERROR_IF(options.target.active() && output != OutputFormat::kRgs, StatusCode::kInvalidArgument,
                      dst + ": a PSNR or byte target chooses the archive profile of a .rgs output, not " +
                          output_format_name(output));
  const bool levels_out = output == OutputFormat::kRgs || (output == OutputFormat::kSog && converter::is_sog_lod_path(dst));
  RGS_RETURN_ERROR_IF(options.lod_levels && !levels_out, StatusCode::kInvalidArgument,
                      dst + ": levels of detail (lod_levels, --lod-levels) are written into a .rgs or a streamed SOG "
                            "(lod-meta.json), and a " + std::string(output_format_name(output)) +
                          " output has none");
  return check_convert_options(options);
}

converter::SceneReadOptions scene_read_options(const ConvertOptions& options) {
  converter::SceneReadOptions read = options.read;
  read.invalid_policy = options.sanitize ? converter::InvalidPolicy::kSanitize : converter::InvalidPolicy::kReject;
  read.hash_file = true;  // provenance's source_xxh64, computed in the reading pass
  return read;
}

Result<OutputFormat> parse_output_format(const std::string& name) {
  for (const FormatName& f : kFormatNames) {
    if (name == f.name) return f.format;
  }
  return Status(StatusCode::kInvalidArgument, "unknown output format '" + name + "' (use rgs, ply, spz, glb or sog)");
}

std::vector<std::string> output_paths(const std::string& dst, OutputFormat output) {
  if (output == OutputFormat::kSog && converter::is_sog_folder_path(dst)) return converter::sog_folder_files(dst);
  return {dst};
}

Result<OutputFormat> output_format_for(const std::string& dst, std::optional<OutputFormat> to) {
  std::string ext = std::filesystem::path(dst).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const FormatName* by_ext = nullptr;
  for (const FormatName& f : kFormatNames) {
    // A SOG entry's name (meta.json, lod-meta.json) chooses SOG only when `to` does not choose: as a .json it
    // contradicts no format.
    const bool sog_entry = converter::is_sog_folder_path(dst) || converter::is_sog_lod_path(dst);
    if (ext == f.extension || (!to && f.format == OutputFormat::kSog && sog_entry)) by_ext = &f;
  }
  if (!to) {
    RGS_RETURN_ERROR_IF(by_ext == nullptr, StatusCode::kInvalidArgument,
                        dst + ": cannot tell the output format from this name; name the output *.rgs, *.ply, "
                              "*.spz, *.glb, *.sog, meta.json (a SOG folder) or lod-meta.json (a streamed SOG), or "
                              "choose the format with "
                              "rgs-convert --to or Python's to= (rgs, ply, spz, glb, sog)");
    return by_ext->format;
  }
  RGS_RETURN_ERROR_IF(by_ext != nullptr && by_ext->format != *to, StatusCode::kInvalidArgument,
                      dst + ": the name says " + by_ext->name + " but the format asked for is " +
                          entry(*to).name + "; name the output *" + entry(*to).extension +
                          " or leave the format to the name");
  return *to;
}

namespace {

/// The output transaction of one conversion: the caller's (ConvertOptions::files), or one of its own that
/// commit() commits. `options()` are the caller's with `files` pointing to it.
class ConversionOutputs {
 public:
  explicit ConversionOutputs(const ConvertOptions& options) : options_(options) {
    if (options_.files == nullptr) options_.files = &own_;
  }
  const ConvertOptions& options() const { return options_; }
  /// Declares the files of `dst` (OutputFormat `output`) and the files read, `inputs`, to the transaction.
  Status declare(const std::string& dst, OutputFormat output, const std::vector<std::string>& inputs) {
    for (const std::string& input : inputs) RGS_RETURN_IF_ERROR(options_.files->add_input(input));
    return options_.files->declare(output_paths(dst, output));
  }
  /// Commits the transaction when it is the conversion's own; `report` is passed through.
  Result<ConvertReport> commit(Result<ConvertReport> report) {
    if (!report.ok() || options_.files != &own_) return report;
    RGS_RETURN_IF_ERROR(own_.commit());
    return report;
  }

 private:
  format::OutputTransaction own_;
  ConvertOptions options_;
};

/// convert_bytes and convert_cloud: the scene `read` makes in memory (no file of it for an output to replace),
/// named `name`, written as convert() writes a scene it read.
template <typename Read>
Result<ConvertReport> convert_in_memory(const std::string& name, const std::string& dst, const ConvertOptions& options,
                                        Read&& read) {
  const auto start = Clock::now();
  RGS_ASSIGN_OR_RETURN(OutputFormat output, output_format_for(dst, options.to));
  RGS_RETURN_IF_ERROR(check_convert_output(dst, output, options));
  ConversionOutputs outputs(options);
  RGS_RETURN_IF_ERROR(outputs.declare(dst, output, {}));
  ProgressReporter progress(options, output);
  progress.reading();
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, read(scene_read_options(options)));
  return outputs.commit(convert_input(std::move(input), name, dst, output, outputs.options(), start, progress));
}

}  // namespace

Result<ConvertReport> convert(const std::string& src, const std::string& dst, const ConvertOptions& options) {
  const auto start = Clock::now();
  RGS_ASSIGN_OR_RETURN(OutputFormat output, output_format_for(dst, options.to));
  RGS_RETURN_IF_ERROR(check_convert_output(dst, output, options));
  ConversionOutputs outputs(options);
  RGS_RETURN_IF_ERROR(outputs.declare(dst, output, {src}));
  ProgressReporter progress(options, output);
  progress.reading();
  RGS_ASSIGN_OR_RETURN(std::unique_ptr<converter::PlyStream> stream, detail::out_of_core_input(src, output, options));
  if (stream) return outputs.commit(detail::convert_out_of_core(std::move(stream), src, dst, outputs.options()));
  RGS_RETURN_IF_ERROR(detail::check_convert_memory(src, options));
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(src, scene_read_options(options)));
  // Every file the scene read is an input: no output may be one of them, in any spelling.
  RGS_RETURN_IF_ERROR(outputs.declare(dst, output, input.files));
  return outputs.commit(convert_input(std::move(input), src, dst, output, outputs.options(), start, progress));
}

Result<ConvertReport> convert_scene(converter::InputScene input, const std::string& src, const std::string& dst,
                                    const ConvertOptions& options) {
  const auto start = Clock::now();
  RGS_ASSIGN_OR_RETURN(OutputFormat output, output_format_for(dst, options.to));
  RGS_RETURN_IF_ERROR(check_convert_output(dst, output, options));
  ConversionOutputs outputs(options);
  RGS_RETURN_IF_ERROR(outputs.declare(dst, output, input.files));
  ProgressReporter progress(options, output);
  return outputs.commit(convert_input(std::move(input), src, dst, output, outputs.options(), start, progress));
}

Result<ConvertReport> convert_bytes(const uint8_t* data, size_t size, const std::string& name,
                                    const std::string& dst, const ConvertOptions& options) {
  return convert_in_memory(name, dst, options, [&](const converter::SceneReadOptions& read) {
    return converter::read_scene_bytes(data, size, name, read);
  });
}

Result<ConvertReport> convert_cloud(format::GaussianCloud cloud, const std::string& name, const std::string& dst,
                                    const ConvertOptions& options) {
  return convert_in_memory(name, dst, options, [&](const converter::SceneReadOptions& read) {
    return converter::scene_from_cloud(std::move(cloud), name, read);
  });
}

}  // namespace rgs::api
