// rgs-convert: any supported scene (3DGS PLY, PlayCanvas compressed PLY / SOG, SPZ, glTF, .splat, .rgs) into
// a .rgs runtime profile, an INRIA PLY, an SPZ v4 file or a KHR_gaussian_splatting GLB.
//
//   rgs-convert point_cloud.ply scene.rgs [options]   quantize and print what it cost
//   rgs-convert scene.rgs restored.ply                dequantize to a PLY other 3DGS tools load
//   rgs-convert scene.sog scene.spz --sh-degree 1     any input to any output, dropping SH bands
//   cat scene.ply | rgs-convert - scene.rgs --json -  read standard input, JSON summary on standard output
//
// The output format follows --to, else the output's extension (.rgs, .ply, .spz, .glb); a name whose
// extension is another of these four than --to says is a usage error.
//
// Exit status: 0 on success (every output written), 1 when the conversion failed (no output written, an
// existing one left as it was), 2 on a usage error (nothing read or written), 128 + N on signal N.

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>
#include <xxhash.h>

#include "cli_common.h"
#include "error_stats_output.h"
#include "read_limits_option.h"
#include "rgs/config.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/gltf_writer.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/spz_writer.h"
#include "rgs/format/file_io.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"
#include "rgs/format/writer.h"

namespace {

using namespace rgs;
using Clock = std::chrono::steady_clock;
constexpr const char* kTool = "rgs-convert";

struct Options {
  std::string input;
  std::string output;
  std::string scale_encoding = "linear";
  float sh_clip_percentile = 100.0f;
  std::vector<std::string> zstd_sections;
  int zstd_level = 19;
  bool sanitize = false;
  bool allow_empty = false;
  bool quiet = false;
  std::string json_path;  ///< "-": standard output, instead of the text summary
  std::optional<uint32_t> lod;
  std::string profile = "runtime";
  double position_error = format::kDefaultArchivePositionError;
  std::string to;                     ///< --to: rgs, ply, spz or glb; empty: the output's extension decides
  std::optional<uint32_t> sh_degree;  ///< --sh-degree: drop the SH bands above it
  bool keep_frame = false;            ///< --keep-frame: SPZ axes as stored (no RUB <-> RDF turn)

  bool json_to_stdout() const { return json_path == "-"; }
  /// The text summary goes to stdout unless -q or the JSON takes its place.
  bool print_summary() const { return !quiet && !json_to_stdout(); }
};

/// The input: a file, or standard input ("-") read into memory.
struct Input {
  std::string path;
  std::vector<uint8_t> bytes;  ///< standard input's content when path is "-"
  bool from_stdin() const { return path == "-"; }
};

/// A .rgs input (a file, or standard input's bytes): validated fully (checksums, codecs, values), then
/// dequantized, and described as read_scene describes the other formats.
Result<converter::InputScene> read_rgs_input(const Options& opt, const Input& input) {
  std::shared_ptr<const format::MappedFile> mapping;
  const uint8_t* bytes = input.bytes.data();
  size_t size = input.bytes.size();
  if (!input.from_stdin()) {
    RGS_ASSIGN_OR_RETURN(mapping, format::MappedFile::open(opt.input));
    bytes = mapping->data();
    size = mapping->size();
  }
  RGS_RETURN_IF_ERROR(format::validate(bytes, size, tools::read_limits(), opt.input));
  RGS_ASSIGN_OR_RETURN(format::RgsFile file,
                       format::RgsFile::from_bytes(bytes, size, tools::read_options(), opt.input));
  RGS_ASSIGN_OR_RETURN(format::EncodedScene encoded, file.read_scene());
  auto cloud = format::dequantize(encoded);
  if (!cloud.ok()) return Status(cloud.status()).prepend(opt.input);
  converter::InputScene scene;
  scene.cloud = std::move(cloud).value();
  scene.format_id = "rgs";
  scene.description = "RoofGS .rgs, dequantized";
  scene.storage_format = "rgs";
  scene.file_bytes = file.file_size();
  scene.file_count = 1;
  scene.declared_vertices = file.gaussian_count();
  scene.file_xxh64 = XXH64(bytes, size, 0);
  return scene;
}

/// The input as float Gaussians, whatever its format, with --sh-degree applied.
Result<converter::InputScene> read_input(const Options& opt, const Input& input, bool is_rgs) {
  converter::InputScene scene;
  if (is_rgs) {
    RGS_ASSIGN_OR_RETURN(scene, read_rgs_input(opt, input));
  } else {
    converter::SceneReadOptions read_options;
    read_options.invalid_policy =
        opt.sanitize ? converter::InvalidPolicy::kSanitize : converter::InvalidPolicy::kReject;
    read_options.max_gaussians = tools::read_limits().max_gaussians;
    read_options.max_decompression_ratio = tools::read_limits().max_decompression_ratio;
    read_options.hash_file = true;  // provenance's source_xxh64, computed in the reading pass
    read_options.lod = opt.lod;
    read_options.convert_spz_frame = !opt.keep_frame;
    if (input.from_stdin()) {  // only PLY is read from standard input: the other formats need a file
      RGS_ASSIGN_OR_RETURN(scene, converter::read_scene_bytes(input.bytes.data(), input.bytes.size(),
                                                                  input.path, read_options));
    } else {
      RGS_ASSIGN_OR_RETURN(scene, converter::read_scene(opt.input, read_options));
    }
  }
  if (opt.sh_degree && *opt.sh_degree < scene.cloud.sh_degree) {
    scene.notes.push_back("SH degree " + std::to_string(scene.cloud.sh_degree) + " reduced to " +
                          std::to_string(*opt.sh_degree) + " (--sh-degree)");
    RGS_RETURN_IF_ERROR(converter::reduce_sh_degree(&scene.cloud, *opt.sh_degree));
  }
  return scene;
}

/// The error for an empty scene unless --allow-empty.
Status check_not_empty(const Options& opt, const converter::InputScene& scene) {
  if (scene.cloud.size() != 0 || opt.allow_empty) return Status();
  const std::string why = scene.hygiene.dropped_gaussians > 0
                              ? "--sanitize dropped all " + tools::group_digits(scene.hygiene.dropped_gaussians) +
                                    " Gaussians, so the scene is empty"
                              : "the input has no Gaussians";
  return Status(StatusCode::kInvalidArgument, opt.input + ": " + why + "; --allow-empty writes an empty scene");
}

/// The input's notes, one line each, in the text summary.
void print_notes(const char* label, const std::vector<std::string>& notes) {
  for (const std::string& note : notes) std::printf("  %-16s %s\n", label, tools::escape_text(note).c_str());
}

/// Writes the JSON summary: staged as an output of `outputs`, or printed when it goes to stdout.
Status emit_json(const Options& opt, const nlohmann::json& j, format::OutputSet* outputs) {
  const std::string text = j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
  if (opt.json_to_stdout()) {
    std::fwrite(text.data(), 1, text.size(), stdout);
    return Status();
  }
  return outputs->write(opt.json_path, text.data(), text.size());
}

/// The last steps of a conversion whose outputs are staged: the printed report must have reached stdout
/// before the files change, so that a failed report (a full disk, a closed pipe) leaves no output behind.
int commit_outputs(format::OutputSet* outputs) {
  Status flushed = tools::flush_standard_streams();
  if (!flushed.ok()) return tools::report_error(kTool, flushed);
  Status committed = outputs->commit();
  if (!committed.ok()) return tools::report_error(kTool, committed);
  return tools::kExitOk;
}

/// Sections a user may name in --zstd.
const std::vector<std::pair<std::string, format::SectionId>> kSectionNames = {
    {"metadata", format::SectionId::kMetadata}, {"provenance", format::SectionId::kProvenance},
    {"means", format::SectionId::kMeans},       {"rotations", format::SectionId::kRotations},
    {"scales", format::SectionId::kScales},     {"opacities", format::SectionId::kOpacities},
    {"sh", format::SectionId::kSh}};

Result<format::WriteOptions> make_write_options(const Options& opt) {
  format::WriteOptions write;
  write.zstd_level = opt.zstd_level;
  if (opt.profile == "archive") {
    write.profile = format::StorageProfile::kArchive;
    write.archive.position_error = opt.position_error;
  }
  for (const std::string& name : opt.zstd_sections) {
    if (name == "all") {
      for (const auto& [n, id] : kSectionNames) write.codecs[id] = format::Codec::kZstd;
      continue;
    }
    bool found = false;
    for (const auto& [n, id] : kSectionNames) {
      if (n == name) {
        write.codecs[id] = format::Codec::kZstd;
        found = true;
      }
    }
    RGS_RETURN_ERROR_IF(!found, StatusCode::kInvalidArgument,
                        "--zstd: unknown section '" + name +
                            "' (use all, metadata, provenance, means, rotations, scales, opacities, sh)");
  }
  return write;
}

std::string hex64(uint64_t v) {
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx", static_cast<unsigned long long>(v));
  return buf;
}

/// Any input -> .rgs: read, quantize, stage the outputs, measure, print the summary, commit.
int convert_to_rgs(const Options& opt, const Input& input, bool is_rgs, format::OutputSet* outputs) {
  const auto t_start = Clock::now();
  auto write_options = make_write_options(opt);
  if (!write_options.ok()) return tools::report_error(kTool, write_options.status());

  auto ply = read_input(opt, input, is_rgs);
  if (!ply.ok()) return tools::report_error(kTool, ply.status());
  const double t_read = tools::seconds_since(t_start);
  if (Status empty = check_not_empty(opt, *ply); !empty.ok()) return tools::report_error(kTool, empty);

  converter::QuantizeOptions quantize_options;
  quantize_options.scale_encoding =
      opt.scale_encoding == "log" ? format::ScaleEncoding::kLog : format::ScaleEncoding::kLinear;
  quantize_options.sh_clip_percentile = opt.sh_clip_percentile;
  converter::QuantizationReport report;
  converter::AttributeErrors errors;  // measured inside quantize(), in the pass that encodes
  const auto t_quantize_start = Clock::now();
  auto encoded = converter::quantize(ply->cloud, quantize_options, &report, &errors);
  if (!encoded.ok()) return tools::report_error(kTool, Status(encoded.status()).prepend(opt.input));
  const double t_quantize = tools::seconds_since(t_quantize_start);
  ply->cloud = {};  // the float copy is not read again; freed before the writer's buffers exist (peak RSS)

  std::ostringstream options_text;
  options_text << "scale_encoding=" << opt.scale_encoding << " sh_clip_percentile=" << opt.sh_clip_percentile
               << " sanitize=" << (opt.sanitize ? 1 : 0) << " zstd_level=" << opt.zstd_level << " zstd=";
  for (size_t i = 0; i < opt.zstd_sections.size(); ++i) options_text << (i ? "," : "") << opt.zstd_sections[i];
  if (opt.sh_degree) options_text << " sh_degree=" << *opt.sh_degree;
  if (opt.keep_frame) options_text << " keep_frame=1";
  encoded->provenance = {
      {"source_file", std::filesystem::path(opt.input).filename().string()},
      {"source_bytes", std::to_string(ply->file_bytes)},
      {"source_xxh64", hex64(ply->file_xxh64.value_or(0))},
      {"source_storage", ply->storage_format},
      {"converter", std::string("rgs-convert ") + RGS_VERSION_STRING},
      {"options", options_text.str()},
      {"dropped_gaussians", std::to_string(ply->hygiene.dropped_gaussians)},
  };

  const auto t_write_start = Clock::now();
  // Staged in `outputs` (declared there): renamed into place by commit_outputs().
  auto written = format::write_scene_file(opt.output, *encoded, *write_options);
  if (!written.ok()) return tools::report_error(kTool, written.status());
  const double t_write = tools::seconds_since(t_write_start);

  const double t_total = tools::seconds_since(t_start);

  const uint64_t n = encoded->count;
  const double per_gaussian = n ? 1.0 / static_cast<double>(n) : 0.0;
  const uint32_t degree = encoded->metadata.sh_degree;
  const double in_bytes = static_cast<double>(ply->file_bytes);
  const double out_bytes = static_cast<double>(*written);
  const auto& hygiene = ply->hygiene;

  if (!opt.json_path.empty()) {
    nlohmann::json j;
    j["input"] = {{"path", opt.input}, {"bytes", ply->file_bytes}, {"storage", ply->storage_format},
                  {"format", ply->format_id}, {"declared_vertices", ply->declared_vertices}, {"notes", ply->notes}};
    j["output"] = {{"path", opt.output}, {"bytes", *written}, {"format", "rgs"}};
    j["gaussians"] = n;
    j["sh_degree"] = degree;
    j["bytes_per_gaussian"] = {{"input", in_bytes * per_gaussian}, {"output", out_bytes * per_gaussian}};
    j["ratio"] = out_bytes > 0 ? in_bytes / out_bytes : 0.0;
    j["hygiene"] = {{"nonfinite_values", hygiene.nonfinite_values},
                    {"gaussians_with_nonfinite", hygiene.gaussians_with_nonfinite},
                    {"zero_norm_quaternions", hygiene.zero_norm_quaternions},
                    {"infinite_opacity_logits", hygiene.infinite_opacity_logits},
                    {"dropped_gaussians", hygiene.dropped_gaussians}};
    nlohmann::json sh = nlohmann::json::array();
    for (uint32_t d = 0; d <= degree; ++d) {
      sh.push_back({{"degree", d}, {"error", tools::stats_json(errors.sh[d])},
                    {"scale", {encoded->metadata.sh_quantization.scales[d][0],
                               encoded->metadata.sh_quantization.scales[d][1],
                               encoded->metadata.sh_quantization.scales[d][2]}},
                    {"clipped", {report.sh_clipped[d][0], report.sh_clipped[d][1], report.sh_clipped[d][2]}}});
    }
    j["scales_fp16"] = {{"subnormal", report.scales_subnormal}, {"flushed_to_zero", report.scales_flushed_to_zero},
                        {"max_flushed_of_largest_axis", report.max_flushed_of_largest_axis}};
    j["errors"] = {{"position", tools::stats_json(errors.position)},
                   {"rotation_deg", tools::stats_json(errors.rotation_deg)},
                   {"scale_relative", tools::stats_json(errors.scale_relative)},
                   {"scale_of_largest_axis", tools::stats_json(errors.scale_of_largest_axis)},
                   {"opacity", tools::stats_json(errors.opacity)},
                   {"sh", sh}};
    // "quantize" includes the error measurement, which runs in the same pass.
    j["seconds"] = {{"read", t_read}, {"quantize", t_quantize}, {"write", t_write}, {"total", t_total}};
    Status s = emit_json(opt, j, outputs);
    if (!s.ok()) return tools::report_error(kTool, s);
  }
  if (!opt.print_summary()) return commit_outputs(outputs);

  std::printf("%s %s -> %s\n", kTool, tools::escape_text(opt.input).c_str(), tools::escape_text(opt.output).c_str());
  std::printf("  gaussians        %s (SH degree %u, %s)\n", tools::group_digits(n).c_str(), degree,
              ply->description.c_str());
  std::printf("  input            %s bytes  (%s B/Gaussian)\n", tools::group_digits(ply->file_bytes).c_str(),
              tools::fixed(in_bytes * per_gaussian, 1).c_str());
  std::printf("  output           %s bytes  (%s B/Gaussian), ratio %sx\n",
              tools::group_digits(*written).c_str(), tools::fixed(out_bytes * per_gaussian, 1).c_str(),
              tools::fixed(out_bytes > 0 ? in_bytes / out_bytes : 0.0, 2).c_str());
  if (write_options->profile == format::StorageProfile::kArchive) {
    const auto pq = format::choose_position_quantization(encoded->metadata.bounds, opt.position_error);
    std::printf("  profile          archive: %s B/Gaussian, position step %s (%u bits, error <= %s of the "
                "extent); the errors below are the runtime quantization's, before the archive codecs\n",
                tools::fixed(out_bytes * per_gaussian, 2).c_str(), tools::sci(pq.ok() ? pq->step : 0.0).c_str(),
                pq.ok() ? pq->bits : 0u, tools::sci(opt.position_error).c_str());
  } else {
    std::printf("  profile          runtime\n");
  }
  std::printf("  input hygiene    %s non-finite values in %s Gaussians, %s zero-norm quaternions, "
              "%s infinite opacity logits (kept), %s Gaussians dropped\n",
              tools::group_digits(hygiene.nonfinite_values).c_str(),
              tools::group_digits(hygiene.gaussians_with_nonfinite).c_str(),
              tools::group_digits(hygiene.zero_norm_quaternions).c_str(),
              tools::group_digits(hygiene.infinite_opacity_logits).c_str(),
              tools::group_digits(hygiene.dropped_gaussians).c_str());
  print_notes("input note", ply->notes);
  std::printf("  %-16s %12s %12s\n", "error", "max", "rms");
  tools::print_stats_row("position", errors.position, "scene units (FP32, exact)");
  tools::print_stats_row("rotation", errors.rotation_deg, "degrees");
  const std::string scale_note =
      "of the Gaussian's largest axis; " + tools::group_digits(report.scales_subnormal) +
      " axes FP16-subnormal (< 6.1e-5), " + tools::group_digits(report.scales_flushed_to_zero) + " flushed to 0" +
      (report.scales_flushed_to_zero ? " (each < 3e-8, at most " + tools::sci(report.max_flushed_of_largest_axis) +
                                           " of its largest axis: no visible effect)"
                                     : std::string());
  tools::print_stats_row("scale", errors.scale_of_largest_axis, scale_note.c_str());
  tools::print_stats_row("opacity", errors.opacity, "absolute");
  for (uint32_t d = 0; d <= degree; ++d) {
    const std::string name = "SH degree " + std::to_string(d);
    const uint64_t clipped = report.sh_clipped[d][0] + report.sh_clipped[d][1] + report.sh_clipped[d][2];
    const std::string note = "absolute, INT8" + (clipped ? ", " + tools::group_digits(clipped) + " clipped"
                                                         : std::string());
    tools::print_stats_row(name.c_str(), errors.sh[d], note.c_str());
  }
  std::printf("  time             %s s (read %s, quantize + measure %s, write %s)\n",
              tools::fixed(t_total, 3).c_str(), tools::fixed(t_read, 3).c_str(),
              tools::fixed(t_quantize, 3).c_str(), tools::fixed(t_write, 3).c_str());
  return commit_outputs(outputs);
}

/// Output formats.
enum class OutputKind { kRgs, kPly, kSpz, kGlb };

/// What a float-format writer kept and lost, for the summary.
struct WrittenOutput {
  uint64_t bytes = 0;
  std::string format;  ///< in words, e.g. "INRIA PLY, dequantized"
  std::vector<std::string> limitations;
  nlohmann::json details = nlohmann::json::object();  ///< clamp counts and the like, for --json
};

/// Writes `cloud` as PLY, SPZ or GLB to opt.output (staged in the OutputSet that declared it).
Result<WrittenOutput> write_float_output(const Options& opt, OutputKind kind, const converter::InputScene& scene) {
  WrittenOutput out;
  const bool dequantized = scene.format_id == "rgs";
  if (kind == OutputKind::kPly) {
    converter::PlyWriteReport report;
    RGS_ASSIGN_OR_RETURN(out.bytes, converter::write_ply(opt.output, scene.cloud, &report));
    out.format = dequantized ? "INRIA PLY, dequantized" : "INRIA PLY";
    out.details["zero_scales"] = report.zero_scales;
    if (report.zero_scales > 0) {
      char log_scale[32];
      std::snprintf(log_scale, sizeof(log_scale), "%.4f", static_cast<double>(converter::kZeroScaleLog));
      out.limitations.push_back(tools::group_digits(report.zero_scales) + " zero scales written as log-scale " +
                                log_scale + ", not -inf");
    }
  } else if (kind == OutputKind::kSpz) {
    converter::SpzWriteOptions options;
    options.convert_frame = !opt.keep_frame;
    RGS_ASSIGN_OR_RETURN(converter::SpzWriteSummary summary, converter::write_spz(opt.output, scene.cloud, options));
    out.bytes = summary.bytes;
    out.format = "SPZ v" + std::to_string(summary.version) + (opt.keep_frame ? " (axes kept)" : "");
    out.limitations = summary.limitations;
    auto clamped = [&](uint64_t n, const char* what) {
      if (n > 0) out.limitations.push_back(tools::group_digits(n) + " " + what + " clamped to the SPZ range");
    };
    clamped(summary.scales_clamped, "scale values");
    clamped(summary.colors_clamped, "DC colour values");
    clamped(summary.sh_clamped, "SH rest values");
    out.details = {{"version", summary.version},
                   {"fractional_bits", summary.fractional_bits},
                   {"position_step", summary.position_step},
                   {"scales_clamped", summary.scales_clamped},
                   {"colors_clamped", summary.colors_clamped},
                   {"sh_clamped", summary.sh_clamped},
                   {"frame_converted", !opt.keep_frame}};
  } else {
    RGS_ASSIGN_OR_RETURN(converter::GltfWriteSummary summary, converter::write_glb(opt.output, scene.cloud));
    out.bytes = summary.bytes;
    out.format = "KHR_gaussian_splatting GLB";
    out.limitations = summary.limitations;
  }
  return out;
}

/// Any input -> PLY, SPZ or GLB: read, stage the output (and the JSON summary), print, commit.
int convert_to_float_format(const Options& opt, const Input& input, bool is_rgs, OutputKind kind,
                            format::OutputSet* outputs) {
  const auto t_start = Clock::now();
  auto scene = read_input(opt, input, is_rgs);
  if (!scene.ok()) return tools::report_error(kTool, scene.status());
  if (Status empty = check_not_empty(opt, *scene); !empty.ok()) return tools::report_error(kTool, empty);
  const double t_read = tools::seconds_since(t_start);
  auto written = write_float_output(opt, kind, *scene);
  if (!written.ok()) return tools::report_error(kTool, written.status());
  const double t_total = tools::seconds_since(t_start);
  const format::GaussianCloud& cloud = scene->cloud;
  const auto& hygiene = scene->hygiene;
  if (!opt.json_path.empty()) {
    nlohmann::json j;
    j["input"] = {{"path", opt.input},         {"bytes", scene->file_bytes},
                  {"format", scene->format_id}, {"storage", scene->storage_format},
                  {"declared_vertices", scene->declared_vertices}, {"notes", scene->notes}};
    j["output"] = {{"path", opt.output},
                   {"bytes", written->bytes},
                   {"format", written->format},
                   {"limitations", written->limitations},
                   {"details", written->details}};
    j["gaussians"] = cloud.size();
    j["sh_degree"] = cloud.sh_degree;
    if (kind == OutputKind::kPly) j["zero_scales"] = written->details["zero_scales"];
    j["hygiene"] = {{"nonfinite_values", hygiene.nonfinite_values},
                    {"gaussians_with_nonfinite", hygiene.gaussians_with_nonfinite},
                    {"zero_norm_quaternions", hygiene.zero_norm_quaternions},
                    {"infinite_opacity_logits", hygiene.infinite_opacity_logits},
                    {"dropped_gaussians", hygiene.dropped_gaussians}};
    j["seconds"] = {{"read", t_read}, {"total", t_total}};
    Status s = emit_json(opt, j, outputs);
    if (!s.ok()) return tools::report_error(kTool, s);
  }
  if (opt.print_summary()) {
    std::printf("%s %s -> %s\n", kTool, tools::escape_text(opt.input).c_str(),
                tools::escape_text(opt.output).c_str());
    std::printf("  gaussians        %s (SH degree %u, %s)\n", tools::group_digits(cloud.size()).c_str(),
                cloud.sh_degree, scene->description.c_str());
    std::printf("  input            %s bytes\n", tools::group_digits(scene->file_bytes).c_str());
    std::printf("  output           %s bytes (%s)\n", tools::group_digits(written->bytes).c_str(),
                written->format.c_str());
    if (hygiene.dropped_gaussians > 0) {
      std::printf("  input hygiene    %s Gaussians dropped\n", tools::group_digits(hygiene.dropped_gaussians).c_str());
    }
    print_notes("input note", scene->notes);
    print_notes("output note", written->limitations);
    std::printf("  time             %s s (read %s)\n", tools::fixed(t_total, 3).c_str(),
                tools::fixed(t_read, 3).c_str());
  }
  return commit_outputs(outputs);
}

/// The input's kind from its first bytes: .rgs magic, "ply" or neither.
enum class InputKind { kPly, kRgs, kUnknown };
InputKind sniff(const std::string& head) {
  if (head.size() >= 8 && std::equal(head.begin(), head.begin() + 8, reinterpret_cast<const char*>(format::kMagic))) {
    return InputKind::kRgs;
  }
  if (head.size() >= 3 && head.compare(0, 3, "ply") == 0) return InputKind::kPly;
  return InputKind::kUnknown;
}

/// What an input's extension promises; kUnknown for any other name (content decides).
InputKind expected_kind(const std::string& extension) {
  if (extension == ".ply") return InputKind::kPly;
  if (extension == ".rgs") return InputKind::kRgs;
  return InputKind::kUnknown;
}

/// Declares an output; an alias of an input or of another output, or a device, is a usage error.
int declare_output(format::OutputSet* outputs, const std::string& path) {
  Status s = outputs->add_output(path);
  if (s.ok()) return tools::kExitOk;
  return s.code() == StatusCode::kInvalidArgument ? tools::report_usage_error(kTool, s) : tools::report_error(kTool, s);
}

/// The output formats, by --to name and by extension.
struct OutputFormatName {
  const char* name;
  const char* extension;
  OutputKind kind;
};
constexpr OutputFormatName kOutputFormats[] = {{"rgs", ".rgs", OutputKind::kRgs},
                                               {"ply", ".ply", OutputKind::kPly},
                                               {"spz", ".spz", OutputKind::kSpz},
                                               {"glb", ".glb", OutputKind::kGlb}};

/// The output format: --to, else the output's extension. An extension naming another of the four formats
/// than --to is refused (a GLB called scene.rgs would mislead every later reader of the name); any other
/// extension is accepted with --to.
Result<OutputKind> output_kind(const Options& opt) {
  const std::string ext = tools::extension_of(opt.output);
  const OutputFormatName* by_ext = nullptr;
  const OutputFormatName* by_to = nullptr;
  for (const OutputFormatName& f : kOutputFormats) {
    if (ext == f.extension) by_ext = &f;
    if (opt.to == f.name) by_to = &f;
  }
  if (opt.to.empty()) {
    RGS_RETURN_ERROR_IF(by_ext == nullptr, StatusCode::kInvalidArgument,
                        opt.output + ": cannot tell the output format from this name; name the output *.rgs, "
                                     "*.ply, *.spz or *.glb, or give --to rgs|ply|spz|glb");
    return by_ext->kind;
  }
  RGS_RETURN_ERROR_IF(by_to == nullptr, StatusCode::kInvalidArgument,
                      "--to " + opt.to + ": unknown output format (use rgs, ply, spz or glb)");
  RGS_RETURN_ERROR_IF(by_ext != nullptr && by_ext != by_to, StatusCode::kInvalidArgument,
                      opt.output + ": the name says " + by_ext->name + " but --to says " + by_to->name +
                          "; name the output *" + by_to->extension + " or drop --to");
  return by_to->kind;
}

int run(const Options& opt) {
  // Every identity is checked before anything is read or written.
  format::OutputSet outputs;
  if (opt.input != "-") {
    Status s = outputs.add_input(opt.input);
    if (!s.ok()) return tools::report_usage_error(kTool, s);
  }
  if (opt.output == "-") {
    return tools::report_usage_error(kTool, Status(StatusCode::kInvalidArgument,
                                                   "the output cannot be standard output (-): name a .rgs, .ply, "
                                                   ".spz or .glb file (it is written atomically, by rename)"));
  }
  const auto out_kind = output_kind(opt);
  if (!out_kind.ok()) return tools::report_usage_error(kTool, out_kind.status());
  if (opt.keep_frame && *out_kind != OutputKind::kSpz && tools::extension_of(opt.input) != ".spz") {
    // Content decides the input's format, so a misnamed SPZ input still gets the flag; only say what it is for.
    if (!opt.quiet) tools::report_note(kTool, "--keep-frame applies to SPZ inputs and outputs only");
  }
  if (int code = declare_output(&outputs, opt.output); code != tools::kExitOk) return code;
  if (!opt.json_path.empty() && !opt.json_to_stdout()) {
    if (int code = declare_output(&outputs, opt.json_path); code != tools::kExitOk) return code;
  }

  Input input{opt.input, {}};
  std::string head;
  if (input.from_stdin()) {
    auto bytes = tools::read_standard_input();
    if (!bytes.ok()) return tools::report_error(kTool, bytes.status());
    input.bytes = std::move(bytes).value();
    head.assign(input.bytes.begin(), input.bytes.begin() + std::min<size_t>(8, input.bytes.size()));
  } else {
    // The scene and every file it names are inputs: no output may replace one of them.
    if (int code = tools::declare_input(kTool, outputs, opt.input, true); code != tools::kExitOk) return code;
    head = tools::read_file_head(opt.input, 8);
  }

  InputKind kind = sniff(head);
  if (kind == InputKind::kUnknown) {
    // Neither signature: another scene format (read_scene detects it by content) or a damaged file, which the
    // reader the extension asks for explains.
    kind = tools::extension_of(opt.input) == ".rgs" ? InputKind::kRgs : InputKind::kPly;
  } else if (const InputKind named = expected_kind(tools::extension_of(opt.input));
             named != InputKind::kUnknown && kind != named) {
    // The content contradicts the input's name: a problem of the file, not of the command line.
    return tools::report_error(kTool, Status(StatusCode::kNotRgsFile,
                                             opt.input + ": is named " + tools::extension_of(opt.input) +
                                                 " but holds a " + (kind == InputKind::kPly ? "PLY" : ".rgs") +
                                                 " file"));
  }
  if (!opt.quiet) {
    for (const std::string& note : outputs.remove_stale_temporaries()) tools::report_note(kTool, note);
  } else {
    (void)outputs.remove_stale_temporaries();
  }
  const bool is_rgs = kind == InputKind::kRgs;
  return *out_kind == OutputKind::kRgs ? convert_to_rgs(opt, input, is_rgs, &outputs)
                                       : convert_to_float_format(opt, input, is_rgs, *out_kind, &outputs);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Convert a trained 3DGS scene into the compact .rgs runtime format (INT8 SH with a scale per "
               "degree and channel, FP16 rotation/scale/opacity, FP32 means), a standard INRIA PLY, an SPZ v4 "
               "file or a KHR_gaussian_splatting GLB. The input's format follows its content (a .rgs input is "
               "dequantized first); the output's follows --to, else its extension (.rgs, .ply, .spz, .glb).",
               kTool};
  app.add_option("input", opt.input,
                 "Input .rgs file, or a scene in any format converter::read_scene detects (3DGS PLY, PlayCanvas "
                 "compressed PLY, SOG meta.json/.sog/folder, streamed SOG lod-meta.json, SPZ, .splat, glTF/GLB); "
                 "- reads a PLY or .rgs from standard input")
      ->required();
  app.add_option("output", opt.output,
                 "Output .rgs, .ply, .spz or .glb file (replaced atomically on success only)")
      ->required();
  app.add_option("--to", opt.to,
                 "Output format: rgs, ply (INRIA PLY), spz (SPZ v4) or glb (KHR_gaussian_splatting); default: the "
                 "output's extension. A name ending in another of these four is a usage error")
      ->check(CLI::IsMember({"rgs", "ply", "spz", "glb"}));
  app.add_option("--sh-degree", opt.sh_degree,
                 "Drop the SH bands above this degree (0..3) before writing any output")
      ->check(CLI::Range(0, 3));
  app.add_flag("--keep-frame", opt.keep_frame,
               "SPZ input and output: keep the stored axes instead of turning between SPZ's RUB and RoofGS's RDF "
               "frame (for SPZ writers that skip the conversion: converter/INTEROP.md)");
  app.add_option("--scale-encoding", opt.scale_encoding,
                 "FP16 scale encoding: linear (exp applied; best quality) or log (wider range)")
      ->check(CLI::IsMember({"linear", "log"}))
      ->capture_default_str();
  app.add_option("--sh-clip-percentile", opt.sh_clip_percentile,
                 "Percentile of |SH| mapped to 127 per (degree, channel); 100 = max |SH| (the paper's rule); "
                 "lower values clip the tail")
      ->check(CLI::Range(0.001f, 100.0f))
      ->capture_default_str();
  app.add_option("--zstd", opt.zstd_sections,
                 "Compress these sections losslessly with zstd: all, or a comma list of metadata, provenance, "
                 "means, rotations, scales, opacities, sh (default: none, so the runtime maps the file as is)")
      ->delimiter(',');
  app.add_option("--profile", opt.profile,
                 "Storage profile: runtime (lossless sections, mapped as is) or archive (lossy: Draco means, "
                 "quantized rotations, scales, opacities and SH; decoded at load, format/SPEC.md 3.3)")
      ->check(CLI::IsMember({"runtime", "archive"}))
      ->capture_default_str();
  app.add_option("--position-error", opt.position_error,
                 "Archive profile: largest position error relative to the scene extent (longest AABB side); "
                 "sets the Draco quantization bits")
      ->check(CLI::Range(1e-9, 0.5))
      ->capture_default_str();
  app.add_option("--zstd-level", opt.zstd_level, "zstd level 1..22")
      ->check(CLI::Range(1, 22))
      ->capture_default_str();
  app.add_flag("--sanitize", opt.sanitize,
               "Drop Gaussians with NaN/Inf values or zero-norm quaternions instead of failing "
               "(docs/INPUT_HYGIENE.md)");
  app.add_flag("--allow-empty", opt.allow_empty,
               "Write a scene with no Gaussians (an empty input, or --sanitize dropping everything) instead of "
               "failing");
  app.add_option("--json", opt.json_path,
                 "Also write the summary as JSON to this file, committed together with the output; - prints it on "
                 "standard output instead of the text summary");
  app.add_option("--lod", opt.lod, "Level of detail to read from a streamed SOG (lod-meta.json); 0 = finest "
                                  "(default)");
  app.add_flag("-q,--quiet", opt.quiet, "Print nothing on success");
  rgs::tools::add_read_limit_options(app, rgs::tools::read_limits());
  app.set_version_flag("--version", std::string(kTool) + " " + RGS_VERSION_STRING);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return rgs::tools::finish(kTool, rgs::tools::exit_for_parse_error(app, e, kTool));
  }
  rgs::tools::install_interrupt_cleanup();
  return rgs::tools::finish(kTool, run(opt));
}
