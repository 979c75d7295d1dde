// What every part of the conversion pipeline shares: progress reporting, the report's input fields, and the
// settings of a .rgs output (write options, quantization, provenance).
#include <algorithm>
#include <cstdio>
#include <cstring>
#include <sstream>
#include <utility>

#include "internal_pipeline.h"
#include "rgs/config.h"
#include "rgs/converter/sog_writer.h"

namespace rgs::api::detail {

double seconds_since(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

namespace {

/// With a target, rate control runs between reading and quantizing: it spreads its steps over
/// [kFitStart, kFitEnd) of the whole, and the stages that write its choice take the rest.
constexpr double kFitStart = 0.02, kFitEnd = 0.95;

/// Where the out-of-core build starts, as a fraction of the whole conversion (after the reading pass).
constexpr double kOutOfCoreStart = 0.2;

}  // namespace

ProgressReporter::ProgressReporter(const ConvertOptions& options, OutputFormat output) : callback_(options.progress) {
  // The first estimate of the time left extrapolates from the time reading took, so each share is what reading
  // (and quantizing) measured of the whole (docs/BENCHMARKS.md#progress-shares): SOG's k-means and zstd at level
  // 19 or .xz, which run before the first byte is written, take all but 0.1-2 % of their conversions.
  const bool slow_zstd = zstd_level_for(options) >= 19;
  if (options.target.active()) {
    shares_ = {kFitEnd, kFitEnd + 0.01, 0.99};
  } else if (output == OutputFormat::kRgs && options.profile == format::StorageProfile::kArchive) {
    shares_ = slow_zstd ? Shares{0.005, 0.015, 0.99} : Shares{0.05, 0.25, 0.95};
  } else if (output == OutputFormat::kRgs) {
    shares_ = options.zstd_sections.empty() || !slow_zstd ? Shares{0.45, 0.85, 0.85} : Shares{0.02, 0.98, 0.98};
  } else {
    const double read = output == OutputFormat::kSog ? 0.003 : output == OutputFormat::kSpz ? 0.05 : 0.4;
    shares_ = {read, read, read};
  }
}

void ProgressReporter::fitting(const std::string& what, uint32_t done, uint32_t bound) {
  text_ = "rate control, step " + std::to_string(done) + " of <= " + std::to_string(bound) + ": " + what;
  const double share = bound > 0 ? double(done) / double(bound) : 0.0;
  advance(text_.c_str(), kFitStart + (kFitEnd - kFitStart) * share, done, bound);
}

void ProgressReporter::scanning(double fraction) { advance("reading", kOutOfCoreStart * fraction); }

void ProgressReporter::out_of_core(const char* stage, double fraction) {
  advance(stage, kOutOfCoreStart + (1 - kOutOfCoreStart) * fraction);
}

void ProgressReporter::report(const char* stage, double fraction) {
  // By content: the same literal can have several addresses (inline copies in several files, sanitizers).
  if (stage_ == nullptr || std::strcmp(stage, stage_) != 0) advance(stage, fraction);
}

void ProgressReporter::advance(const char* stage, double fraction, uint32_t step, uint32_t steps) {
  if (!callback_) return;
  stage_ = stage;
  fraction_ = std::max(fraction_, fraction);
  callback_(ConvertProgress{stage, fraction_, step, steps});
}

Status ProgressSink::write(const std::string& path, const format::ChunkProducer& produce) {
  return inner_.write(path, [&](const format::ChunkSink& sink) {
    return produce([&](const void* data, size_t size) {
      progress_->writing();
      return sink(data, size);
    });
  });
}

Status ProgressSink::write_by_name(const std::string& path, const format::ByNameWriter& write_to) {
  progress_->writing();
  return inner_.write_by_name(path, write_to);
}

namespace {

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
  // A merge's edits of one input first, each named by its place among the inputs (source_file's order); then the
  // merged scene's.
  const char* separator = " edits=";
  for (size_t i = 0; i < options.input_edits.size(); ++i) {
    for (const converter::EditAction& edit : options.input_edits[i]) {
      text << std::exchange(separator, "; ") << "input " << i + 1 << ": " << converter::edit_action_text(edit);
    }
  }
  for (const converter::EditAction& edit : options.edits) {
    text << std::exchange(separator, "; ") << converter::edit_action_text(edit);
  }
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

void describe_input(const converter::InputScene& input, ConvertReport* report) {
  report->input_format = input.format_id;
  report->input_description = input.description;
  report->input_storage = input.storage_format;
  report->input_bytes = input.file_bytes;
  report->declared_gaussians = input.declared_vertices;
  report->input_compact = is_compact_input(input);
  report->hygiene = input.hygiene;
  report->input_notes = input.notes;
}

void note_read_limit(uint64_t gaussians, ConvertReport* report) {
  const uint64_t limit = format::ReadLimits{}.max_gaussians;
  if (gaussians <= limit) return;
  report->output_notes.push_back("the file holds " + group_digits(gaussians) +
                                 " Gaussians with its levels, over the readers' default limit of " +
                                 group_digits(limit) + ": read it with --max-gaussians " + std::to_string(gaussians) +
                                 " (Python max_gaussians=, format::ReadLimits::max_gaussians)");
}

format::Provenance rgs_provenance(const std::string& source_file, const ConvertOptions& options, uint64_t file_bytes,
                                  uint64_t file_xxh64, const std::string& storage, uint64_t dropped_gaussians) {
  return {
      {"source_file", source_file},
      {"source_bytes", std::to_string(file_bytes)},
      {"source_xxh64", hex64(file_xxh64)},
      {"source_storage", storage},
      {"converter", options.converter_name + " " + RGS_VERSION_STRING},
      {"options", options_text(options)},
      {"dropped_gaussians", std::to_string(dropped_gaussians)},
  };
}

converter::QuantizeOptions sog_lod_quantize_options(const ConvertOptions& options) {
  converter::QuantizeOptions quantize;
  quantize.scale_encoding = options.scale_encoding;
  quantize.sh_clip_percentile = options.sh_clip_percentile;
  return quantize;
}

converter::QuantizeOptions rgs_quantize_options(const ConvertOptions& options) {
  converter::QuantizeOptions quantize = sog_lod_quantize_options(options);
  quantize.sh_dc_bits = options.profile == format::StorageProfile::kArchive ? 8 : options.sh_dc_bits;
  return quantize;
}

bool writes_levels(const std::string& dst, OutputFormat output, const ConvertOptions& options) {
  return (output == OutputFormat::kRgs && options.lod_levels) ||
         (output == OutputFormat::kSog && converter::is_sog_lod_path(dst));
}

}  // namespace rgs::api::detail
