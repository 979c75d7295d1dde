// rgs-convert: trained 3DGS PLY -> .rgs runtime profile, and .rgs -> standard INRIA PLY.
//
//   rgs-convert point_cloud.ply scene.rgs [options]   quantize and print what it cost
//   rgs-convert scene.rgs restored.ply                dequantize to a PLY other 3DGS tools load
//
// Exit status: 0 on success, 1 when the conversion failed (nothing written, an existing output left as
// it was), 2 on a usage error.

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.h"
#include "error_stats_output.h"
#include "rgs/config.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/ply_writer.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/converter/quantize.h"
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
  bool quiet = false;
  std::string json_path;
  std::optional<uint32_t> lod;
};

/// Sections a user may name in --zstd.
const std::vector<std::pair<std::string, format::SectionId>> kSectionNames = {
    {"metadata", format::SectionId::kMetadata}, {"provenance", format::SectionId::kProvenance},
    {"means", format::SectionId::kMeans},       {"rotations", format::SectionId::kRotations},
    {"scales", format::SectionId::kScales},     {"opacities", format::SectionId::kOpacities},
    {"sh", format::SectionId::kSh}};

Result<format::WriteOptions> make_write_options(const Options& opt) {
  format::WriteOptions write;
  write.zstd_level = opt.zstd_level;
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

/// PLY -> .rgs: read, quantize, write atomically, measure, print the summary.
int convert_ply_to_rgs(const Options& opt) {
  const auto t_start = Clock::now();
  auto write_options = make_write_options(opt);
  if (!write_options.ok()) return tools::report_error(kTool, write_options.status());

  converter::SceneReadOptions read_options;
  read_options.invalid_policy =
      opt.sanitize ? converter::InvalidPolicy::kSanitize : converter::InvalidPolicy::kReject;
  read_options.hash_file = true;  // provenance's source_xxh64, computed in the reading pass
  read_options.lod = opt.lod;
  auto ply = converter::read_scene(opt.input, read_options);
  if (!ply.ok()) return tools::report_error(kTool, ply.status());
  const double t_read = tools::seconds_since(t_start);

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

  std::ostringstream options_text;
  options_text << "scale_encoding=" << opt.scale_encoding << " sh_clip_percentile=" << opt.sh_clip_percentile
               << " sanitize=" << (opt.sanitize ? 1 : 0) << " zstd_level=" << opt.zstd_level << " zstd=";
  for (size_t i = 0; i < opt.zstd_sections.size(); ++i) options_text << (i ? "," : "") << opt.zstd_sections[i];
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
                  {"declared_vertices", ply->declared_vertices}};
    j["output"] = {{"path", opt.output}, {"bytes", *written}};
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
    j["scales_fp16"] = {{"subnormal", report.scales_subnormal}, {"flushed_to_zero", report.scales_flushed_to_zero}};
    j["errors"] = {{"position", tools::stats_json(errors.position)},
                   {"rotation_deg", tools::stats_json(errors.rotation_deg)},
                   {"scale_relative", tools::stats_json(errors.scale_relative)},
                   {"opacity", tools::stats_json(errors.opacity)},
                   {"sh", sh}};
    // "quantize" includes the error measurement, which runs in the same pass.
    j["seconds"] = {{"read", t_read}, {"quantize", t_quantize}, {"write", t_write}, {"total", t_total}};
    const std::string text = j.dump(2) + "\n";
    Status s = format::write_file_atomic(opt.json_path, text.data(), text.size());
    if (!s.ok()) return tools::report_error(kTool, s);
  }
  if (opt.quiet) return tools::kExitOk;

  std::printf("%s %s -> %s\n", kTool, opt.input.c_str(), opt.output.c_str());
  std::printf("  gaussians        %s (SH degree %u, %s)\n", tools::group_digits(n).c_str(), degree,
              ply->description.c_str());
  std::printf("  input            %s bytes  (%s B/Gaussian)\n", tools::group_digits(ply->file_bytes).c_str(),
              tools::fixed(in_bytes * per_gaussian, 1).c_str());
  std::printf("  output           %s bytes  (%s B/Gaussian), ratio %sx\n",
              tools::group_digits(*written).c_str(), tools::fixed(out_bytes * per_gaussian, 1).c_str(),
              tools::fixed(out_bytes > 0 ? in_bytes / out_bytes : 0.0, 2).c_str());
  std::printf("  input hygiene    %s non-finite values in %s Gaussians, %s zero-norm quaternions, "
              "%s infinite opacity logits (kept), %s Gaussians dropped\n",
              tools::group_digits(hygiene.nonfinite_values).c_str(),
              tools::group_digits(hygiene.gaussians_with_nonfinite).c_str(),
              tools::group_digits(hygiene.zero_norm_quaternions).c_str(),
              tools::group_digits(hygiene.infinite_opacity_logits).c_str(),
              tools::group_digits(hygiene.dropped_gaussians).c_str());
  std::printf("  %-16s %12s %12s\n", "error", "max", "rms");
  tools::print_stats_row("position", errors.position, "scene units (FP32, exact)");
  tools::print_stats_row("rotation", errors.rotation_deg, "degrees");
  const std::string scale_note =
      "relative; " + tools::group_digits(report.scales_subnormal) + " values FP16-subnormal (< 6.1e-5), " +
      tools::group_digits(report.scales_flushed_to_zero) + " flushed to 0" +
      (report.scales_subnormal + report.scales_flushed_to_zero ? " (--scale-encoding log keeps them)" : "");
  tools::print_stats_row("scale", errors.scale_relative, scale_note.c_str());
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
  return tools::kExitOk;
}

/// .rgs -> PLY: validate fully (checksums, codecs, values), dequantize, write a standard INRIA PLY atomically.
int convert_rgs_to_ply(const Options& opt) {
  const auto t_start = Clock::now();
  auto mapping = format::MappedFile::open(opt.input);
  if (!mapping.ok()) return tools::report_error(kTool, mapping.status());
  const uint8_t* bytes = (*mapping)->data();
  const size_t size = (*mapping)->size();
  Status valid = format::validate(bytes, size, format::ReadLimits{}, opt.input);
  if (!valid.ok()) return tools::report_error(kTool, valid);
  auto file = format::RgsFile::from_bytes(bytes, size, format::ReadOptions{}, opt.input);
  if (!file.ok()) return tools::report_error(kTool, file.status());
  auto scene = file->read_scene();
  if (!scene.ok()) return tools::report_error(kTool, scene.status());
  auto cloud = format::dequantize(*scene);
  if (!cloud.ok()) return tools::report_error(kTool, Status(cloud.status()).prepend(opt.input));
  auto written = converter::write_ply(opt.output, *cloud);
  if (!written.ok()) return tools::report_error(kTool, written.status());
  if (!opt.quiet) {
    std::printf("%s %s -> %s\n", kTool, opt.input.c_str(), opt.output.c_str());
    std::printf("  gaussians        %s (SH degree %u)\n", tools::group_digits(cloud->size()).c_str(),
                cloud->sh_degree);
    std::printf("  input            %s bytes\n", tools::group_digits(file->file_size()).c_str());
    std::printf("  output           %s bytes (INRIA PLY, dequantized)\n", tools::group_digits(*written).c_str());
    std::printf("  time             %s s\n", tools::fixed(tools::seconds_since(t_start), 3).c_str());
  }
  return tools::kExitOk;
}

/// Sniffs the input's first bytes: .rgs magic, "ply" or neither.
enum class InputKind { kPly, kRgs, kUnknown };
InputKind sniff(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  in.read(head, 8);
  if (in.gcount() == 8 && std::equal(head, head + 8, reinterpret_cast<const char*>(format::kMagic))) {
    return InputKind::kRgs;
  }
  if (in.gcount() >= 3 && head[0] == 'p' && head[1] == 'l' && head[2] == 'y') return InputKind::kPly;
  return InputKind::kUnknown;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Convert a trained 3DGS PLY into the compact .rgs runtime format (INT8 SH with a scale per "
               "degree and channel, FP16 rotation/scale/opacity, FP32 means), or a .rgs back into a standard "
               "INRIA PLY. The direction follows the input's content; the output must end in .rgs or .ply.",
               kTool};
  app.add_option("input", opt.input,
                 "Input .rgs file, or a scene in any format converter::read_scene detects (3DGS PLY, PlayCanvas "
                 "compressed PLY, SOG meta.json/.sog/folder, streamed SOG lod-meta.json)")
      ->required();
  app.add_option("output", opt.output, "Output .rgs or .ply file (replaced atomically on success only)")
      ->required();
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
  app.add_option("--zstd-level", opt.zstd_level, "zstd level 1..22")
      ->check(CLI::Range(1, 22))
      ->capture_default_str();
  app.add_flag("--sanitize", opt.sanitize,
               "Drop Gaussians with NaN/Inf values or zero-norm quaternions instead of failing "
               "(docs/INPUT_HYGIENE.md)");
  app.add_option("--json", opt.json_path, "Also write the summary as JSON to this file (PLY -> .rgs only)");
  app.add_option("--lod", opt.lod, "Level of detail to read from a streamed SOG (lod-meta.json); 0 = finest "
                                  "(default)");
  app.add_flag("-q,--quiet", opt.quiet, "Print nothing on success");
  app.set_version_flag("--version", std::string(kTool) + " " + RGS_VERSION_STRING);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? rgs::tools::kExitOk : rgs::tools::kExitUsage;
  }

  std::error_code ec;
  if (std::filesystem::equivalent(opt.input, opt.output, ec)) {
    return rgs::tools::report_error(
        kTool, rgs::Status(rgs::StatusCode::kInvalidArgument, opt.output + ": output is the input file"));
  }
  if (!std::filesystem::exists(opt.input, ec)) {
    return rgs::tools::report_error(kTool, rgs::Status(rgs::StatusCode::kIoError,
                                                       opt.input + ": no such file"));
  }
  const std::string out_ext = rgs::tools::extension_of(opt.output);
  switch (sniff(opt.input)) {
    case InputKind::kPly:
      if (out_ext != ".rgs") {
        return rgs::tools::report_error(kTool, rgs::Status(rgs::StatusCode::kInvalidArgument,
                                                           opt.input + ": is a PLY file, which converts to .rgs; "
                                                                       "name the output *.rgs (not " + opt.output + ")"));
      }
      return convert_ply_to_rgs(opt);
    case InputKind::kRgs:
      if (out_ext != ".ply") {
        return rgs::tools::report_error(kTool, rgs::Status(rgs::StatusCode::kInvalidArgument,
                                                           opt.input + ": is a .rgs file, which converts to PLY; "
                                                                       "name the output *.ply (not " + opt.output + ")"));
      }
      return convert_rgs_to_ply(opt);
    case InputKind::kUnknown:
      break;
  }
  // Neither signature: let the reader the extension asks for explain what is wrong with the file.
  if (rgs::tools::extension_of(opt.input) == ".rgs") return convert_rgs_to_ply(opt);
  if (out_ext != ".rgs") {  // other scene formats (SOG, ...) convert to .rgs too
    return rgs::tools::report_error(kTool, rgs::Status(rgs::StatusCode::kInvalidArgument,
                                                       opt.input + ": scenes convert to .rgs; name the output "
                                                                   "*.rgs (not " + opt.output + ")"));
  }
  return convert_ply_to_rgs(opt);
}
