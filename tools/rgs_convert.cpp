// rgs-convert: any supported scene (3DGS PLY, PlayCanvas compressed PLY / SOG, SPZ, glTF, .ksplat, .splat, .rgs) into
// a .rgs runtime profile, an INRIA PLY, an SPZ v4 file or a KHR_gaussian_splatting GLB.
//
//   rgs-convert point_cloud.ply scene.rgs [options]   quantize and print what it cost
//   rgs-convert scene.rgs restored.ply                dequantize to a PLY other 3DGS tools load
//   rgs-convert scene.sog scene.spz --sh-degree 1     any input to any output, dropping SH bands
//   rgs-convert in.ply out.ply --rotate 180,0,0 --crop-box -2,-2,-2,2,2,2 --filter 'opacity gt 0.05'
//                                                     edits, in the order given (the SH colour turns too)
//   rgs-convert a.ply b.spz merged.rgs --decimate 0.5  two scenes merged into one, then halved
//   rgs-convert a.ply --rotate 0,180,0 b.ply merged.rgs  a turned alone, then merged with b (edits after an input
//                                                     act on it; after the output, on the merged scene)
//   cat scene.ply | rgs-convert - scene.rgs --json -  read standard input, JSON summary on standard output
//   rgs-convert scene.ply scene.rgs --target-psnr 40 --cameras cameras.json --every 8 --width 960
//                                                     the archive profile's settings for 40 dB (rate control)
//
// The output format follows --to, else the output's extension (.rgs, .ply, .spz, .glb, .sog; a name meta.json is
// a SOG folder); a name whose extension is another of these than --to says is a usage error.
//
// Exit status: 0 on success (every output written), 1 when the conversion failed (no output written, an
// existing one left as it was), 2 on a usage error (nothing read or written), 128 + N on signal N.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <array>
#include <cstdio>
#include <iterator>
#include <limits>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "cli_common.h"
#include "progress_line.h"
#include "rgs/api/convert.h"
#include "rgs/api/scene.h"
#include "rgs/api/camera.h"
#include "rgs/config.h"
#include "rgs/converter/cloud_edits.h"

namespace {

using namespace rgs;
constexpr const char* kTool = "rgs-convert";

struct Options {
  std::vector<std::string> inputs;
  std::string input;  ///< the inputs joined by " + ", as the library names them
  std::string output;
  std::string to;  ///< --to: rgs, ply, spz, glb or sog; empty: the output's extension decides
  std::string scale_encoding = "linear";
  std::string profile = "runtime";
  bool profile_defaulted = true;  ///< --profile not given
  std::string json_path;  ///< "-": standard output, instead of the text summary
  std::string lod_levels;  ///< --lod-levels: "auto", "1".."16", or empty (no levels of detail)
  bool quiet = false;
  api::ConvertOptions convert;  ///< everything else, parsed straight into the library's options
  std::array<std::vector<std::string>, 10> edit_values;  ///< what each edit option (kEditOptions) was given, in order

  bool rate_control() const { return convert.target.active(); }

  bool json_to_stdout() const { return json_path == "-"; }
  /// The text summary goes to stdout unless -q or the JSON takes its place.
  bool print_summary() const { return !quiet && !json_to_stdout(); }
};

/// The edit options: --NAME (converter::parse_edit_action's name), its value's type, its help.
struct EditOption {
  const char* name;
  const char* type;
  const char* help;
};
constexpr EditOption kEditOptions[] = {
    {"translate", "X,Y,Z", "Edit: move every Gaussian by X,Y,Z scene units"},
    {"rotate", "X,Y,Z|W,X,Y,Z",
     "Edit: rotate about the origin by Euler angles in degrees about the fixed world axes, x first, then y, then z "
     "(extrinsic x-y-z, the same as intrinsic z-y'-x'': R = Rz(Z)*Ry(Y)*Rx(X); right-handed, a positive angle turns "
     "counter-clockwise seen from the axis' positive end), or by a unit quaternion W,X,Y,Z (4 numbers; norm within "
     "1e-3 of 1). Means, Gaussian rotations (left-multiplied) and the SH colour (bands 1-3) turn together"},
    {"scale", "S", "Edit: scale uniformly about the origin by S > 0 (means and scales times S, log scales + ln S)"},
    {"filter-nan", "",
     "Edit: drop the Gaussians with a NaN or infinite mean, SH value or rotation, a zero-norm rotation, a NaN opacity "
     "or a log scale that is NaN or overflows; +-inf opacity logits and -inf log scales are kept (reads the input as "
     "--sanitize does)"},
    {"filter", "'NAME OP VALUE'",
     "Edit: keep the Gaussians whose property NAME compares true with VALUE; NAME: x, y, z, opacity (after the "
     "sigmoid), scale_0..2 (after exp), rot_0..3 (normalized, rot_0 = w), f_dc_0..2 (the SH coefficient), red, green, "
     "blue (the colour 0.5 + 0.28209479 * f_dc_0..2), f_rest_K; OP: lt le gt ge eq ne (or < <= > >= == !=)"},
    {"crop-box", "MINX,MINY,MINZ,MAXX,MAXY,MAXZ",
     "Edit: keep the Gaussians whose mean is inside the box (bounds included)"},
    {"crop-box-outside", "MINX,MINY,MINZ,MAXX,MAXY,MAXZ", "Edit: keep the Gaussians whose mean is outside the box"},
    {"crop-sphere", "CX,CY,CZ,R", "Edit: keep the Gaussians whose mean is inside the sphere (surface included; R > 0)"},
    {"crop-sphere-outside", "CX,CY,CZ,R", "Edit: keep the Gaussians whose mean is outside the sphere"},
    {"decimate", "N|FRACTION",
     "Edit: at most N Gaussians (an integer >= 1) or FRACTION in (0, 1) of them, merged by the levels of detail's rule "
     "as a .rgs holds them (docs/LOD.md); needs the whole scene (or input), so an out-of-core build refuses it"},
};

/// Adds the edit options to `app`, each repeatable, their values into opt->edit_values.
void add_edit_options(CLI::App& app, Options* opt) {
  static_assert(std::size(kEditOptions) == std::tuple_size<decltype(Options::edit_values)>::value);
  for (size_t i = 0; i < std::size(kEditOptions); ++i) {
    const EditOption& e = kEditOptions[i];
    if (*e.type == '\0') {
      app.add_flag(std::string("--") + e.name, e.help)->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    } else {
      app.add_option(std::string("--") + e.name, opt->edit_values[i], e.help)
          ->type_name(e.type)
          ->expected(1)  // one value per occurrence, so that a repeated option keeps its place in the order
          ->allow_extra_args(false)  // a positional after it (IN --rotate X OUT) stays a positional
          ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
    }
  }
}

/// The edits of the command line in the order given (CLI11's parse order), parsed by converter::parse_edit_action:
/// with several inputs, those written after an input and before the next input or the output into that input's
/// opt->convert.input_edits (splat-transform's rule), the others (before the first input, after the output) into
/// the merged scene's opt->convert.edits; with one input all into opt->convert.edits.
/// @return "" or the first problem, naming the option.
std::string collect_edits(const CLI::App& app, Options* opt) {
  size_t used[std::size(kEditOptions)] = {};
  size_t positionals = 0;  // the inputs, then the output, met so far
  const size_t inputs = opt->inputs.size();
  for (const CLI::Option* option : app.parse_order()) {
    positionals += option->get_positional() ? 1 : 0;
    for (size_t i = 0; i < std::size(kEditOptions); ++i) {
      if (option->get_name() != std::string("--") + kEditOptions[i].name) continue;
      const std::string value = *kEditOptions[i].type == '\0' ? "" : opt->edit_values[i].at(used[i]++);
      auto edit = converter::parse_edit_action(kEditOptions[i].name, value);
      if (!edit.ok()) return "--" + edit.status().message();
      std::vector<std::vector<converter::EditAction>>& per_input = opt->convert.input_edits;
      if (inputs > 1 && positionals >= 1 && positionals <= inputs) {
        per_input.resize(std::max(per_input.size(), positionals));
        per_input[positionals - 1].push_back(std::move(edit).value());
      } else {
        opt->convert.edits.push_back(std::move(edit).value());
      }
    }
  }
  return "";
}

/// One row of the error table: name, max, rms, then a free-text unit or note.
void print_stats_row(const std::string& name, const converter::ErrorStats& s, const std::string& unit) {
  std::printf("  %-16s %12s %12s  %s\n", name.c_str(), tools::sci(s.max).c_str(), tools::sci(s.rms).c_str(),
              unit.c_str());
}

/// What the .rgs quantization cost, as rows of the text summary.
void print_rgs_errors(const Options& opt, const api::ConvertReport& r) {
  const api::RgsOutputReport& q = *r.rgs;
  const bool archive = q.position_bits > 0;
  if (archive) {
    std::printf("  profile          archive: %s B/Gaussian, position step %s (%u bits, error <= %s of the extent "
                "per coordinate); the errors below are the decoded archive's against the input\n",
                tools::fixed(double(r.output_bytes) / double(std::max<uint64_t>(r.gaussians, 1)), 2).c_str(),
                tools::sci(q.position_step).c_str(), q.position_bits, tools::sci(q.extent > 0 ? q.position_step / (2 * q.extent) : 0).c_str());
    if (q.archive_omitted > 0) {
      const double floor = opt.convert.archive.opacity_floor;
      std::printf("  omitted          %s Gaussians whose opacity code is 0 (they decode to opacity 0, which no "
                  "renderer draws)%s\n",
                  rgs::group_digits(q.archive_omitted).c_str(),
                  floor > 0 ? (" or whose opacity is below " + tools::fixed(255 * floor, 2) + "/255").c_str() : "");
    }
  } else if (q.lod_levels > 0) {
    std::printf("  profile          runtime, levels of detail: %u chunks x %u levels, %s Gaussians in all (%s x the "
                "full detail), built in %s s\n",
                q.lod_chunks, q.lod_levels, rgs::group_digits(q.lod_gaussians).c_str(),
                tools::fixed(double(q.lod_gaussians) / double(std::max<uint64_t>(r.gaussians, 1)), 3).c_str(),
                tools::fixed(r.seconds.lod, 2).c_str());
  } else {
    std::printf("  profile          runtime\n");
  }
  std::printf("  %-16s %12s %12s\n", "error", "max", "rms");
  const double per_extent = q.extent > 0 ? 1.0 / q.extent : 0.0;
  const std::string position_note =
      archive ? "scene units (Euclidean; max " + tools::sci(q.errors.position.max * per_extent) +
                    " of the extent " + tools::sci(q.extent) + ")"
              : std::string("scene units (FP32, exact)");
  print_stats_row("position", q.errors.position, position_note);
  print_stats_row("rotation", q.errors.rotation_deg, "degrees");
  const auto& fp16 = q.quantization;
  const std::string scale_note =
      archive ? std::string("of the Gaussian's largest axis") :
      "of the Gaussian's largest axis; " + rgs::group_digits(fp16.scales_subnormal) +
      " axes FP16-subnormal (< 6.1e-5), " + rgs::group_digits(fp16.scales_flushed_to_zero) + " flushed to 0" +
      (fp16.scales_flushed_to_zero ? " (each < 3e-8, at most " + tools::sci(fp16.max_flushed_of_largest_axis) +
                                         " of its largest axis: no visible effect)"
                                   : std::string());
  print_stats_row("scale", q.errors.scale_of_largest_axis, scale_note);
  print_stats_row("opacity", q.errors.opacity, "absolute");
  for (uint32_t d = 0; d <= r.sh_degree; ++d) {
    const auto& c = fp16.sh_clipped[d];
    const uint64_t clipped = c[0] + c[1] + c[2];
    const bool residual = d == 0 && !archive && opt.convert.sh_dc_bits == 16;
    const std::string note = std::string(archive ? "absolute" : residual ? "absolute, INT8 and DC residual (16-bit)"
                                                                         : "absolute, INT8") +
                             (clipped ? ", " + rgs::group_digits(clipped) + " clipped" : std::string());
    print_stats_row("SH degree " + std::to_string(d), q.errors.sh[d], note);
  }
}

/// "4.74 MB": bytes in decimal units, 3 significant digits from 1 kB on.
std::string size_text(uint64_t bytes) {
  const double b = double(bytes);
  if (b < 1e3) return std::to_string(bytes) + " bytes";
  const auto [value, unit] = b < 1e6 ? std::pair(b / 1e3, " kB") : b < 1e9 ? std::pair(b / 1e6, " MB")
                                                                           : std::pair(b / 1e9, " GB");
  return tools::fixed(value, value < 10 ? 2 : value < 100 ? 1 : 0) + unit;
}

/// On stderr: the output is larger than a compact input (an SPZ, a SOG, an archive .rgs, ...), and what
/// makes a smaller file.
void note_larger_than_input(const Options& opt, const api::ConvertReport& r) {
  if (!r.input_compact || r.input_bytes == 0 || r.output_bytes <= r.input_bytes) return;
  const bool archive = r.rgs && r.rgs->position_bits > 0;
  const char* hint = r.output_format == api::OutputFormat::kRgs
                         ? (archive ? "" : "; for a smaller file use --profile archive")
                     : r.output_format == api::OutputFormat::kSpz ? ""
                                                                   : "; for a smaller file write a .rgs with --profile archive";
  tools::report_note(kTool, "note: " + opt.output + " (" + size_text(r.output_bytes) + ") is " +
                                tools::fixed(double(r.output_bytes) / double(r.input_bytes), 1) +
                                "x larger than the compact input " + opt.input + " (" + size_text(r.input_bytes) +
                                ")" + hint);
}

/// Rate control's rows of the text summary: the target, what the written archive reached, its settings.
void print_fit(const Options& opt, const api::ConvertReport& r, const api::RateControlReport& f) {
  const api::ConvertTarget& t = opt.convert.target;
  const std::string target = t.psnr_db ? "mean PSNR >= " + tools::fixed(*t.psnr_db, 2) + " dB"
                                       : "at most " + rgs::group_digits(*t.bytes) + " bytes";
  std::printf("  rate control     %s: reached %s dB mean (lowest view %s dB) over %u views at %ux%u, "
              "render against the input's render (%s)\n",
              target.c_str(), tools::fixed(f.psnr_mean_db, 2).c_str(), tools::fixed(f.psnr_min_db, 2).c_str(),
              f.views, f.width, f.height, api::device_name(f.device));
  std::printf("  settings         %s\n", api::describe_archive_options(f.settings, r.sh_degree).c_str());
  std::printf("  search           %u archives encoded (%s s), %u rendered at %ux%u (%s dB there; %s s), %s s\n",
              f.encodings, tools::fixed(f.encode_seconds, 1).c_str(), f.renders, f.search_width, f.search_height,
              tools::fixed(f.search_psnr_db, 2).c_str(), tools::fixed(f.render_seconds, 1).c_str(),
              tools::fixed(f.seconds, 1).c_str());
}

void print_summary(const Options& opt, const api::ConvertReport& r) {
  const double per_gaussian = r.gaussians ? 1.0 / static_cast<double>(r.gaussians) : 0.0;
  std::printf("%s %s -> %s\n", kTool, tools::escape_text(opt.input).c_str(), tools::escape_text(opt.output).c_str());
  std::printf("  gaussians        %s (SH degree %u, %s)\n", rgs::group_digits(r.gaussians).c_str(), r.sh_degree,
              r.input_description.c_str());
  std::printf("  input            %s bytes  (%s B/Gaussian)\n", rgs::group_digits(r.input_bytes).c_str(),
              tools::fixed(double(r.input_bytes) * per_gaussian, 1).c_str());
  std::printf("  output           %s bytes (%s), %s B/Gaussian, ratio %sx\n",
              rgs::group_digits(r.output_bytes).c_str(), r.output_description.c_str(),
              tools::fixed(double(r.output_bytes) * per_gaussian, 2).c_str(),
              tools::fixed(r.output_bytes > 0 ? double(r.input_bytes) / double(r.output_bytes) : 0.0, 2).c_str());
  const auto& h = r.hygiene;
  std::printf("  input hygiene    %s non-finite values in %s Gaussians, %s zero-norm quaternions, "
              "%s infinite opacity logits (kept), %s Gaussians dropped\n",
              rgs::group_digits(h.nonfinite_values).c_str(), rgs::group_digits(h.gaussians_with_nonfinite).c_str(),
              rgs::group_digits(h.zero_norm_quaternions).c_str(),
              rgs::group_digits(h.infinite_opacity_logits).c_str(), rgs::group_digits(h.dropped_gaussians).c_str());
  for (size_t i = 0; i < r.merge_inputs.size(); ++i) {
    const api::MergeInput& in = r.merge_inputs[i];
    std::string edits;
    for (const std::string& edit : in.edits) edits += "; " + edit;
    std::printf("  %-16s %s: %s Gaussians%s -> %s\n", ("merge input " + std::to_string(i + 1)).c_str(),
                tools::escape_text(in.path).c_str(), rgs::group_digits(in.gaussians).c_str(),
                tools::escape_text(edits).c_str(), rgs::group_digits(in.kept).c_str());
  }
  if (!r.merge_inputs.empty() && !opt.convert.edits.empty()) {
    std::string edits;
    for (const auto& edit : opt.convert.edits) edits += (edits.empty() ? "" : "; ") + converter::edit_action_text(edit);
    std::printf("  merged edits     %s\n", tools::escape_text(edits).c_str());
  }
  for (const std::string& note : r.input_notes) std::printf("  input note       %s\n", tools::escape_text(note).c_str());
  for (const std::string& note : r.output_notes) std::printf("  output note      %s\n", tools::escape_text(note).c_str());
  if (r.rate_control) print_fit(opt, r, *r.rate_control);
  if (r.rgs) print_rgs_errors(opt, r);
  std::printf("  time             %s s (read %s, quantize + measure %s, write %s)\n",
              tools::fixed(r.seconds.total, 3).c_str(), tools::fixed(r.seconds.read, 3).c_str(),
              tools::fixed(r.seconds.quantize, 3).c_str(), tools::fixed(r.seconds.write, 3).c_str());
}

int run(Options& opt) {
  // Every identity and option is checked before anything is read or written.
  for (const std::string& input : opt.inputs) opt.input += (opt.input.empty() ? "" : " + ") + input;
  if (opt.inputs.size() > 1 && std::count(opt.inputs.begin(), opt.inputs.end(), "-") > 0) {
    return tools::report_usage_error(kTool, Status(StatusCode::kInvalidArgument, "standard input (-) is converted alone"));
  }
  if (opt.output == "-") {
    return tools::report_usage_error(kTool, Status(StatusCode::kInvalidArgument,
                                                   "the output cannot be standard output (-): name a .rgs, .ply, "
                                                   ".spz or .glb file (it is written atomically, by rename)"));
  }
  if (!opt.to.empty()) opt.convert.to = *api::parse_output_format(opt.to);  // --to's check parsed it
  if (!opt.lod_levels.empty()) {
    opt.convert.lod_levels = *rgs::tools::parse_lod_levels(opt.lod_levels);  // CLI11 checked it
  }
  const auto output_format = api::output_format_for(opt.output, opt.convert.to);
  if (!output_format.ok()) return tools::report_usage_error(kTool, output_format.status());
  opt.convert.to = *output_format;
  const api::CameraChoice& views = opt.convert.target.views;
  // The target's rules that only the command line can break (api::check_convert_options has the others).
  if (opt.rate_control()) {
    const char* flag = opt.convert.target.psnr_db ? "--target-psnr" : "--target-bytes";
    std::string why;
    if (opt.profile == "runtime" && !opt.profile_defaulted) why = std::string(flag) + " writes the archive profile, not --profile runtime";
    if (opt.input == "-") {
      why = std::string(flag) + " looks for the scene's own views beside the input: name a file, not standard input";
    }
    if (!why.empty()) return tools::report_usage_error(kTool, Status(StatusCode::kInvalidArgument, why));
    opt.profile = "archive";
  }
  opt.convert.scale_encoding = opt.scale_encoding == "log" ? format::ScaleEncoding::kLog : format::ScaleEncoding::kLinear;
  opt.convert.profile = opt.profile == "archive" ? format::StorageProfile::kArchive : format::StorageProfile::kRuntime;
  opt.convert.read = tools::scene_read_options();  // --lod included
  opt.convert.converter_name = kTool;
  // Options that contradict each other (levels of detail with the archive profile or zstd sections, an unknown
  // section) are a usage error found before anything is read.
  if (Status s = api::check_convert_output(opt.output, *opt.convert.to, opt.convert); !s.ok()) {
    return tools::report_usage_error(kTool, s);
  }

  format::OutputTransaction outputs;
  // Each scene and every file it names are inputs: no output may replace one of them (standard input is converted
  // alone).
  const std::vector<std::string> scenes = opt.input == "-" ? std::vector<std::string>() : opt.inputs;
  if (int code = tools::declare_inputs(kTool, outputs, scenes, views.cameras_path); code != tools::kExitOk) return code;
  // A SOG folder (output named meta.json) writes its images next to it: all are outputs of the run.
  for (const std::string& path : api::output_paths(opt.output, *opt.convert.to)) {
    if (int code = tools::declare_output(kTool, outputs, path); code != tools::kExitOk) return code;
  }
  if (!opt.json_path.empty() && !opt.json_to_stdout()) {
    if (int code = tools::declare_output(kTool, outputs, opt.json_path); code != tools::kExitOk) return code;
  }
  tools::report_notes(kTool, outputs.remove_stale_temporaries(), opt.quiet);

  // Staged in `outputs`, renamed into place by commit() below with the JSON report. A streamed SOG's chunk files
  // are known only once its levels are built: its writer declares them to `outputs` then, before writing any.
  opt.convert.files = &outputs;
  tools::ProgressLine progress(stderr, kTool, !opt.quiet && tools::stderr_is_terminal());
  opt.convert.progress = [&progress](const api::ConvertProgress& p) { progress.update(p); };
  Result<api::ConvertReport> report = Status(StatusCode::kInvalidArgument, "not converted");
  if (opt.rate_control()) opt.convert.target.device = api::cuda_available() ? api::Device::kCuda : api::Device::kCpu;
  if (opt.input == "-") {
    auto bytes = tools::read_standard_input(&opt.convert);
    if (!bytes.ok()) return tools::report_error(kTool, bytes.status());
    report = api::convert_bytes(bytes->data(), bytes->size(), opt.input, opt.output, opt.convert);
  } else {
    report = api::convert(opt.inputs, opt.output, opt.convert);
  }
  progress.clear();
  if (!report.ok()) return tools::report_error(kTool, report.status());
  if (report->rate_control) {
    opt.convert.archive = report->rate_control->settings;  // what the summary and the JSON describe
    if (!report->rate_control->views_note.empty()) {
      tools::report_notes(kTool, {report->rate_control->views_note}, opt.quiet);
    }
  }
  if (!opt.quiet) note_larger_than_input(opt, *report);
  if (!opt.json_path.empty()) {
    const std::string text = api::convert_report_json(*report, opt.input, opt.output, opt.convert) + "\n";
    if (opt.json_to_stdout()) {
      std::fwrite(text.data(), 1, text.size(), stdout);
    } else if (Status s = outputs.write(opt.json_path, text.data(), text.size()); !s.ok()) {
      return tools::report_error(kTool, s);
    }
  }
  if (opt.print_summary()) print_summary(opt, *report);
  return tools::commit_outputs(kTool, outputs, opt.quiet);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Convert a trained 3DGS scene into the compact .rgs runtime format (INT8 SH with a scale per "
               "degree and channel, FP16 rotation/scale/opacity, FP32 means), a standard INRIA PLY, an SPZ v4 "
               "file, a KHR_gaussian_splatting GLB or a PlayCanvas SOG (bundled .sog, meta.json folder or streamed "
               "lod-meta.json). The input's format follows its content (a .rgs input is "
               "dequantized first); the output's follows --to, else its extension (.rgs, .ply, .spz, .glb, .sog). "
               "The edits (--translate, --rotate, --scale, --filter-nan, --filter, --crop-box, --crop-sphere and their "
               "-outside forms, --decimate) may be repeated and act on the scene as read in the order given, before "
               "--sh-degree and everything else. Several inputs are merged into one scene: their Gaussians in the "
               "order given, at the highest SH degree (the bands an input lacks zero); inputs whose anti-aliasing "
               "flags differ are refused. With several inputs, the edits written after an input (before the next "
               "input or the output) act on that input alone, before the merge, as splat-transform's actions do "
               "(a.ply --rotate 0,180,0 b.ply out.ply turns a only); those after the output (or before the first "
               "input) act on the merged scene.",
               kTool};
  app.add_option("input", opt.inputs,
                 "Input .rgs file, or a scene in any format converter::read_scene detects (3DGS PLY, PlayCanvas "
                 "compressed PLY, SOG meta.json/.sog/folder, streamed SOG lod-meta.json, SPZ, .ksplat, .splat, "
                 "glTF/GLB); - reads a PLY or .rgs from standard input; several inputs are merged into one scene "
                 "(required)")
      ->expected(1, -1);  // takes every positional, the output too: `check` below splits it off
  app.add_option("output", opt.output,
                 "Output .rgs, .ply, .spz, .glb or .sog file, or a SOG folder's meta.json (replaced atomically on "
                 "success only; required)");
  app.add_option("--to", opt.to,
                 "Output format: rgs, ply (INRIA PLY), spz (SPZ v4), glb (KHR_gaussian_splatting) or sog (PlayCanvas "
                 "SOG v2); default: the output's extension. A name ending in another of these is a usage error")
      ->check(rgs::tools::status_check(  // the names of api's format table
          [](const std::string& name) { return rgs::api::parse_output_format(name).status(); }, ""));
  add_edit_options(app, &opt);
  app.add_option("--sh-degree", opt.convert.sh_degree,
                 "Drop the SH bands above this degree (0..3) before writing any output, after the edits")
      ->check(CLI::Range(0, 3));
  app.add_option("--scale-encoding", opt.scale_encoding,
                 "FP16 scale encoding: linear (exp applied; best quality) or log (wider range)")
      ->check(CLI::IsMember({"linear", "log"}))
      ->capture_default_str();
  app.add_option("--sh-clip-percentile", opt.convert.sh_clip_percentile,
                 "Percentile of |SH| mapped to 127 per (degree, channel); 100 = max |SH| (the paper's rule); "
                 "lower values clip the tail")
      ->check(rgs::tools::finite_number_in(0.001, 100.0))
      ->capture_default_str();
  app.add_option("--sh-dc-bits", opt.convert.sh_dc_bits,
                 "Precision of the SH DC term (the whole colour at SH degree 0): 16 stores the INT8 code and a "
                 "residual in 1/256 of its step (3 bytes a Gaussian more, format/SPEC.md 4.8); 8 the INT8 code "
                 "alone, as in the paper. The archive profile stores 8")
      ->check(CLI::IsMember({8, 16}))
      ->capture_default_str();
  app.add_option("--zstd", opt.convert.zstd_sections,
                 "Compress these sections losslessly with zstd: all, or a comma list of metadata, provenance, "
                 "means, rotations, scales, opacities, sh, sh_dc_residual (default: none, so the runtime maps the file as "
                 "is)")
      ->delimiter(',');
  app.add_option("--profile", opt.profile,
                 "Storage profile: runtime (lossless sections, mapped as is) or archive (lossy: Draco means, "
                 "quantized rotations, scales, opacities and SH; decoded at load, format/SPEC.md 3.3)")
      ->check(CLI::IsMember({"runtime", "archive"}))
      ->capture_default_str();
  app.add_option("--position-error", opt.convert.archive.position_error,
                 "Archive profile: largest position error relative to the scene extent (longest AABB side); "
                 "sets the Draco quantization bits. Default: 2^-17 (7.6e-6), or half SPZ's grid (2^-14 scene units) "
                 "where that is larger")
      ->check(rgs::tools::finite_number_in(1e-9, 0.5));
  auto* target_psnr =
      app.add_option("--target-psnr", opt.convert.target.psnr_db,
                     "Rate control: choose the archive profile's settings (bits and code steps of rotations, scales, opacities, SH "
                     "steps per degree, position error) for the fewest bytes whose mean PSNR over the views, render "
                     "against the input's render, is at least DB; implies --profile archive")
          ->check(rgs::tools::finite_number_in(1.0, 200.0));
  app.add_option_function<std::string>(
         "--target-bytes",
         [&opt](const std::string& text) {
           opt.convert.target.bytes = *rgs::tools::parse_whole_number(text, 1, std::numeric_limits<uint64_t>::max());
         },
         "Rate control: the archive profile's settings for the best mean PSNR of a file of at most N bytes "
         "(decimal digits, 1..2^64-1); implies --profile archive")
      ->type_name("UINT")
      ->check(rgs::tools::whole_number_in(1, std::numeric_limits<uint64_t>::max()))
      ->excludes(target_psnr);
  rgs::tools::add_camera_options(app, opt.convert.target.views,
                                 "Rate control's views: an INRIA cameras.json (native size by default)",
                                 "Rate control: at most N views",
                                 "Rate control: an orbit of N cameras (at 960x540); without a camera option the scene's own "
                                 "cameras.json beside it, else views guessed from its content");
  app.add_option("--width", opt.convert.target.views.width, "Rate control: image width of the views (field of view kept)")
      ->check(CLI::Range(11, 32768));
  app.add_option("--height", opt.convert.target.views.height, "Rate control: image height of the views")
      ->check(CLI::Range(11, 32768));
  app.add_option("--zstd-level", opt.convert.zstd_level,
                 "zstd level 1..22 of the --zstd sections (default 19) and of the archive profile (default 9, "
                 "quick); from 19 on, the archive's codes also try .xz (LZMA2) streams and keep the smaller: "
                 "2-7 % smaller archives in 5-21 times the time")
      ->check(CLI::Range(1, 22));
  app.add_flag("--sanitize", opt.convert.sanitize,
               "Drop Gaussians with NaN/Inf values or zero-norm quaternions instead of failing "
               "(docs/INPUT_HYGIENE.md)");
  app.add_flag("--allow-empty", opt.convert.allow_empty,
               "Write a scene with no Gaussians (an empty input, or --sanitize dropping everything) instead of "
               "failing");
  app.add_option("--json", opt.json_path,
                 "Also write the summary as JSON to this file, committed together with the output; - prints it on "
                 "standard output instead of the text summary");
  app.add_option("--lod", rgs::tools::scene_read_options().lod,
                 "Level of detail to read from a streamed SOG (lod-meta.json); 0 = finest (default)");
  rgs::tools::add_lod_levels_option(
      app, opt.lod_levels,
      "Write a .rgs with levels of detail (format/SPEC.md 4.9, docs/LOD.md): spatial chunks, each at this many "
      "levels (1..16; auto: the coarsest about 1/64 of the full detail), parents merged from their children by "
      "moment matching, for rendering under a splat and memory budget");
  app.add_option("--lod-chunk", opt.convert.lod_chunk_gaussians,
                 "With --lod-levels: most full-detail Gaussians in one chunk (what the renderer culls, selects and "
                 "streams)")
      ->check(CLI::Range(uint32_t{1}, uint32_t{1} << 30))
      ->capture_default_str()
      ->needs(app.get_option("--lod-levels"));
  app.add_option("--memory-limit", opt.convert.memory_limit,
                 "Most memory the conversion may use (e.g. 4GiB, 512MB; at least 1 byte; default: half the physical "
                 "memory). An input whose estimated peak when read whole is above the limit is built out of core when "
                 "it is a binary PLY converted with --lod-levels (the same bytes; partition files on the output's "
                 "disk, about twice its size), else refused before it is read (docs/LOD.md, scenes larger than memory); standard "
                 "input, held whole, is read up to what a file of its format read whole may have")
      ->transform(CLI::AsSizeValue(false))
      ->check(rgs::tools::whole_number_in(1, std::numeric_limits<uint64_t>::max()));
  app.add_flag("-q,--quiet", opt.quiet,
               "Print nothing on success: no summary, no notes, no progress line (which is drawn on stderr only "
               "when it is a terminal, for conversions over a second)");
  rgs::tools::add_scene_read_options(app);
  const auto check = [&]() -> std::string {
    if (opt.inputs.empty()) return "input is required";
    if (opt.inputs.size() == 1) return "output is required";
    opt.output = opt.inputs.back();
    opt.inputs.pop_back();
    return collect_edits(app, &opt);
  };
  if (auto code = rgs::tools::parse_command_line(app, argc, argv, kTool, check)) {
    return *code;
  }
  opt.profile_defaulted = app.count("--profile") == 0;
  rgs::tools::install_interrupt_cleanup();
  return rgs::tools::finish(kTool, run(opt));
}
