// rgs-audit: what a conversion or a format costs. A thin front end of rgs::audit (audit/): sizes per section and
// per Gaussian, per-attribute errors, per-view PSNR/SSIM/max |d| of each candidate's render against the
// source's (3DGS baseline, FP32), on the GPU when one is present, else on the CPU reference; JSON always next
// to the report, and a self-contained HTML report with its figures as inline SVG (audit::report_html).
//
//   rgs-audit scene.ply scene.rgs --cameras cameras.json                 every camera, native size
//   rgs-audit scene.ply a.rgs b.rgs c.rgs --label max --label p99 ...     one run, several candidates
//   rgs-audit scene.ply a.rgs b.spz --threshold 50                       verdict: mean PSNR >= 50 dB passes
//   rgs-audit scene.ply scene.rgs --min-psnr 40 --report ci/audit.html    CI gate: exit 3 below 40 dB
// The verdict and the gate compare the foreground PSNR where the source's renders have background, else the
// whole frame's (audit::verdict_metric).
//   rgs-audit --report-from out.json --report out.html                   HTML of an earlier run
//   rgs-audit scene.ply scene.rgs --save-renders renders/ --format ppm    every render, as rgs-render writes it
// The report's image folder holds the images of the last run alone: an earlier run's are removed once this run's
// outputs are committed (and all of them with --no-report-images).
//
// Every output of a run (the HTML report, its JSON, its images, --json, --heatmap, --save-renders) is declared
// before it is written (the report's images and the renders once the views are known), may not be an input or
// another output, and is committed together at the end (format::OutputTransaction). Exit status: 0 ok, 1
// failure (no output written or changed), 2 usage error, 3 a candidate below --min-psnr (the audit itself
// succeeded: its reports are written), 128 + N on signal N. --json - prints the JSON on standard output and the
// table on standard error.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "cli_common.h"
#include "image_write.h"
#include "rgs/api/scene.h"
#include "rgs/audit/audit.h"
#include "rgs/audit/audit_report.h"
#include "rgs/audit/audit_scene.h"
#include "rgs/audit/report_html.h"
#include "rgs/api/camera.h"
#include "rgs/runtime/image_io.h"
#include "rgs/config.h"

namespace {

using namespace rgs;
using Clock = std::chrono::steady_clock;
constexpr const char* kTool = "rgs-audit";
/// Exit code of a completed audit in which a candidate's lowest PSNR is below --min-psnr (reports written).
constexpr int kExitBelowMinPsnr = 3;

struct Options {
  std::vector<std::string> scenes;  // source, then candidates
  std::vector<std::string> labels;
  api::CameraChoice cameras;
  tools::RenderOptions render;  ///< --backend, --device, --threads
  std::string report_path;
  bool no_report = false;
  bool no_report_images = false;  ///< --no-report-images: no _files/ folder (the HTML holds the images anyway)
  std::string report_from;
  std::string json_path;
  std::string heatmap_path;
  std::string renders_dir;   ///< --save-renders: every render as an 8-bit image, one folder per scene
  std::string image_format;  ///< of --save-renders: "png" or "ppm"; empty: png when the build has OpenImageIO
  uint32_t worst = 3;
  uint32_t image_size = 1024;
  double min_psnr = -1;
  bool min_psnr_set = false;
  double threshold = audit::kDefaultVerdictThresholdDb;
  bool quiet = false;
  bool attribution = false;
  std::string command_line;
};

std::string db(double v) { return std::isinf(v) ? std::string(v > 0 ? "inf" : "-inf") : tools::fixed(v, 2); }

/// "out.html" -> "out.json"; "out_files/" for the images.
std::string with_suffix(const std::string& html, const std::string& suffix) {
  std::filesystem::path p(html);
  return (p.parent_path() / (p.stem().string() + suffix)).string();
}

void print_candidate(std::FILE* out, const audit::AuditResult& r, const audit::CandidateResult& c) {
  const char* channel_names[3] = {"R", "G", "B"};
  // Bytes per Gaussian of the source: the candidates are files of one scene, some storing fewer Gaussians.
  const double per_g = r.source.gaussians ? 1.0 / double(r.source.gaussians) : 0.0;
  std::fprintf(out, "candidate %s (%s, %s)\n", tools::escape_text(c.scene.label).c_str(),
               tools::escape_text(c.scene.path).c_str(), tools::escape_text(c.scene.format).c_str());
  std::fprintf(out, "  gaussians        %s (SH degree %u)\n", rgs::group_digits(c.scene.gaussians).c_str(),
               c.scene.sh_degree);
  if (!c.reference.empty()) std::fprintf(out, "  compared with    %s\n", tools::escape_text(c.reference).c_str());
  if (c.scene.file_bytes > 0) {
    std::fprintf(out, "  load             %s s\n", tools::fixed(c.scene.load_seconds, 2).c_str());
  }
  std::fprintf(out, "  render           %s s (sum over the views)\n", tools::fixed(c.summary.render_seconds, 2).c_str());
  if (c.scene.file_bytes == 0) {
    std::fprintf(out, "  size             none: an attribution scene (--attribution), not a file\n");
  } else {
    std::fprintf(out, "  size             %s bytes  (%s B/Gaussian), ratio %sx\n",
                 rgs::group_digits(c.scene.file_bytes).c_str(),
                 tools::fixed(double(c.scene.file_bytes) * per_g, 1).c_str(),
                 tools::fixed(double(r.source.file_bytes) / double(c.scene.file_bytes), 2).c_str());
  }
  if (!c.scene.sections.empty()) {
    std::fprintf(out, "  %-22s %8s %14s %12s\n", "section", "codec", "bytes", "B/Gaussian");
    for (const auto& s : c.scene.sections) {
      std::fprintf(out, "  %-22s %8s %14s %12s\n", s.name.c_str(), s.codec.c_str(),
                   rgs::group_digits(s.stored_bytes).c_str(),
                   tools::fixed(double(s.stored_bytes) * per_g, 3).c_str());
    }
    std::fprintf(out, "  %-22s %8s %14s %12s\n", "header, table, padding", "",
                 rgs::group_digits(c.scene.overhead_bytes).c_str(),
                 tools::fixed(double(c.scene.overhead_bytes) * per_g, 3).c_str());
  }
  if (c.attributes) {
    const converter::AttributeErrors& e = c.attributes->errors;
    auto row = [&](const std::string& name, const converter::ErrorStats& s, const std::string& unit) {
      std::fprintf(out, "  %-22s %12s %12s  %s\n", name.c_str(), tools::sci(s.max).c_str(), tools::sci(s.rms).c_str(),
                   unit.c_str());
    };
    if (c.attributes->pairing == converter::PairingMethod::kIndex) {
      std::fprintf(out, "  paired           index by index (the source's Gaussians in its order)\n");
    } else {
      std::fprintf(out, "  paired           by content: each Gaussian with a source Gaussian within %s scene units\n",
                   tools::sci(c.attributes->position_tolerance).c_str());
    }
    if (c.attributes->source_unpaired > 0) {
      std::fprintf(out, "  not in candidate %s source Gaussians (left out of the errors)\n",
                   rgs::group_digits(c.attributes->source_unpaired).c_str());
    }
    std::fprintf(out, "  %-22s %12s %12s\n", "error", "max", "rms");
    converter::ErrorStats pos = e.position;
    pos.max *= 1000;
    pos.rms *= 1000;
    row("position x1000", pos, "scene units x 1000 (mm if the scene is metric)");
    row("rotation", e.rotation_deg, "degrees");
    row("scale", e.scale_of_largest_axis, "of the Gaussian's largest axis");
    row("opacity", e.opacity, "absolute");
    for (uint32_t d = 0; d <= c.scene.sh_degree && d < 4; ++d) {
      row("SH degree " + std::to_string(d), e.sh[d], "absolute (all channels)");
      for (uint32_t ch = 0; ch < 3; ++ch) {
        std::string note;
        if (c.attributes->sh_quantization) {
          note = "scale " + tools::sci(c.attributes->sh_quantization->scales[d][ch]) + ", " +
                 rgs::group_digits(c.attributes->clipped[d][ch]) + " clipped";
        }
        row("  " + std::string(channel_names[ch]), e.sh_channel[d][ch], note);
      }
    }
  } else {
    std::fprintf(out, "  %s\n", tools::escape_text(c.attributes_note).c_str());
  }
}

int run_report_only(const Options& opt) {
  if (opt.report_path.empty()) {
    return tools::report_usage_error(kTool,
                                     Status(StatusCode::kInvalidArgument, "--report-from needs --report OUT.html"));
  }
  format::OutputTransaction outputs;
  if (int code = tools::declare_input(kTool, outputs, opt.report_from); code != tools::kExitOk) return code;
  if (int code = tools::declare_output(kTool, outputs, opt.report_path); code != tools::kExitOk) return code;
  tools::report_notes(kTool, outputs.remove_stale_temporaries());
  auto html = audit::report_html_from_file(opt.report_from);
  if (!html.ok()) return tools::report_error(kTool, html.status());
  Status st = outputs.write(opt.report_path, html->data(), html->size());
  if (!st.ok()) return tools::report_error(kTool, st);
  tools::report_note(kTool, "report " + opt.report_path);
  return tools::commit_outputs(kTool, outputs);
}

/// `path` with its symbolic links followed, also to a file that does not exist yet (a dangling link).
std::filesystem::path link_target(const std::filesystem::path& path) {
  std::filesystem::path p = path;
  std::error_code ec;
  for (int hops = 0; hops < 40 && std::filesystem::is_symlink(p, ec); ++hops) {
    const std::filesystem::path target = std::filesystem::read_symlink(p, ec);
    if (ec) break;
    p = target.is_absolute() ? target : p.parent_path() / target;
  }
  return p;
}

/// True when --json names the report's own JSON (through any spelling or symbolic link): the report then uses
/// that file, written once.
bool json_is_report_json(const Options& opt, const std::string& report_json) {
  if (report_json.empty() || opt.json_path.empty() || opt.json_path == "-") return false;
  format::OutputTransaction probe;
  if (probe.add_output(report_json).ok() && probe.has_output(opt.json_path)) return true;
  std::error_code ec1, ec2;
  const auto a = std::filesystem::weakly_canonical(report_json, ec1);
  const auto b = std::filesystem::weakly_canonical(link_target(opt.json_path), ec2);
  return !ec1 && !ec2 && a == b;
}

/// After a committed run: removes the images an earlier run left in the report's image folder (the names
/// audit::report_images gives) that this run did not write, `written`, then the folder if that left it empty; so
/// the folder holds the images its JSON names and no others. Files of other names are never touched.
void remove_stale_report_images(const std::string& folder, const std::set<std::string>& written) {
  static const std::regex kImageName(R"(c[0-9]+_v[0-9]+_(source|candidate)\.ppm|c[0-9]+_v[0-9]+_diff\.pgm)");
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_regular_file(ec) && std::regex_match(name, kImageName) && written.count(name) == 0) {
      std::filesystem::remove(entry.path(), ec);
    }
  }
  std::filesystem::remove(folder, ec);  // fails, as it should, unless empty
}

/// Declares the scenes and cameras as inputs and the outputs known before the audit runs (report HTML and
/// JSON, --json, --heatmap); sets the report's JSON path and image folder (empty with --no-report).
/// @return tools::kExitOk, or the exit code of the error reported.
int declare_files(const Options& opt, format::OutputTransaction& outputs, std::string* report_json, std::string* report_files) {
  if (int code = tools::declare_inputs(kTool, outputs, opt.scenes, opt.cameras.cameras_path); code != tools::kExitOk) {
    return code;
  }
  if (!opt.no_report) {
    *report_json = with_suffix(opt.report_path, ".json");
    *report_files = with_suffix(opt.report_path, "_files");
  }
  const bool json_declared = opt.json_path == "-" || json_is_report_json(opt, *report_json);
  for (const std::string& output :
       {opt.report_path, *report_json, json_declared ? std::string() : opt.json_path, opt.heatmap_path}) {
    if (output.empty()) continue;
    if (int code = tools::declare_output(kTool, outputs, output); code != tools::kExitOk) return code;
  }
  if (!report_files->empty()) {
    std::error_code ec;
    const auto kind = std::filesystem::status(*report_files, ec).type();
    if (kind != std::filesystem::file_type::not_found && kind != std::filesystem::file_type::directory) {
      return tools::report_usage_error(
          kTool, Status(StatusCode::kInvalidArgument,
                        *report_files + ": the report's image folder exists and is not a directory (choose another "
                                        "--report, or --no-report)"));
    }
  }
  return tools::kExitOk;
}

/// --save-renders: creates the folder of each scene's renders in opt.renders_dir, "source" and then each
/// candidate's label (tools::file_safe_names).
Result<std::vector<std::string>> render_folders(const Options& opt, const std::vector<audit::AuditScene>& candidates,
                                                format::OutputTransaction& outputs) {
  RGS_RETURN_IF_ERROR(outputs.create_folder(opt.renders_dir));
  std::vector<std::string> folders{"source"};
  for (const audit::AuditScene& candidate : candidates) folders.push_back(candidate.info.label);
  folders = tools::file_safe_names(folders);
  for (std::string& folder : folders) {
    folder = (std::filesystem::path(opt.renders_dir) / folder).string();
    RGS_RETURN_IF_ERROR(outputs.create_folder(folder));
  }
  return folders;
}

/// --save-renders: stages one render as "<base>.png" or ".ppm", named as rgs-render names its views, with
/// rgs-render's 8-bit rule (runtime::to_8bit), so that the two can be compared byte for byte.
Status save_render(const Options& opt, format::OutputTransaction& outputs, const std::string& base,
                   const runtime::ImageRef& rgba) {
  const std::string path = base + "." + opt.image_format;
  RGS_RETURN_IF_ERROR(outputs.add_output(path));
  std::vector<float> rgb(size_t(rgba.width) * rgba.height * 3);
  for (size_t i = 0; i < rgb.size(); ++i) rgb[i] = rgba.data[i / 3 * 4 + i % 3];
  return tools::write_image8(outputs, path, rgba.width, rgba.height, 3, runtime::to_8bit(rgb));
}

/// Audits the files (audit::audit_files, the one place that loads, pairs and chooses the views), their reader notes
/// printed, on the backend --backend chooses: an explicit --backend cuda without a device fails before any loading.
Result<audit::AuditResult> measure(const Options& opt, format::OutputTransaction& outputs) {
  audit::AuditOptions options;
  std::string why;
  const bool have_cuda = api::cuda_available(&why);
  if (opt.render.backend == "cuda" || (opt.render.backend == "auto" && have_cuda)) {
    RGS_RETURN_ERROR_IF(!have_cuda, StatusCode::kUnsupportedFeature, "--backend cuda: " + why);
    options.backend = audit::Backend::kCuda;
  }
  options.cuda_device = opt.render.device;
  options.worst_views = opt.worst;
  options.image_max_side = opt.image_size;
  options.keep_worst_heatmap = !opt.heatmap_path.empty();
  options.cpu_threads = opt.render.cpu_threads;

  audit::AuditFiles files;
  files.source = opt.scenes[0];
  files.candidates.assign(opt.scenes.begin() + 1, opt.scenes.end());
  files.labels = opt.labels;
  files.read = tools::scene_read_options();
  files.attribution = opt.attribution;
  files.views = opt.cameras;
  files.on_notes = [&](const std::vector<std::string>& notes) { tools::report_notes(kTool, notes, opt.quiet); };
  auto last_print = Clock::now() - std::chrono::hours(1);
  options.progress = [&](const audit::AuditProgress& p) {
    const auto now = Clock::now();
    if (p.views_done != p.views_total && now - last_print < std::chrono::seconds(1)) return;
    last_print = now;
    std::string psnrs;
    for (double v : p.psnr_db) psnrs += " " + db(v);
    std::fprintf(stderr, "view %zu/%zu %s PSNR%s dB | %s s elapsed, ~%s s left\n", p.views_done, p.views_total,
                 tools::escape_text(p.view).c_str(), psnrs.c_str(), tools::fixed(p.elapsed_s, 1).c_str(),
                 tools::fixed(p.remaining_s, 0).c_str());
  };
  std::vector<std::string> folders, names;  // --save-renders: a folder per scene (the source's first), a name per view
  files.before_render = [&](const std::vector<audit::AuditScene>& candidates,
                            const std::vector<runtime::Camera>& cameras, audit::AuditOptions& run_options) -> Status {
    std::fprintf(stderr, "%s: backend %s%s, %zu views x %zu candidate%s\n", kTool,
                 audit::backend_name(run_options.backend),
                 run_options.backend == audit::Backend::kCpu && opt.render.backend == "auto"
                     ? (" (no CUDA device: " + tools::escape_text(why) + ")").c_str() : "",
                 cameras.size(), candidates.size(), candidates.size() == 1 ? "" : "s");
    if (opt.renders_dir.empty()) return Status();
    RGS_ASSIGN_OR_RETURN(folders, render_folders(opt, candidates, outputs));
    for (const runtime::Camera& camera : cameras) names.push_back(camera.name);
    names = tools::file_safe_names(names);
    run_options.on_render = [&](size_t view, size_t scene, const runtime::ImageRef& rgba) {
      return save_render(opt, outputs, (std::filesystem::path(folders[scene]) / names[view]).string(), rgba);
    };
    return Status();
  };
  return audit::audit_files(files, std::move(options));
}

/// "foreground PSNR" or "whole-frame PSNR": what a verdict compares.
std::string metric_text(audit::VerdictMetric metric) {
  return metric == audit::VerdictMetric::kForeground ? "foreground PSNR" : "whole-frame PSNR";
}

/// "verdict          PASS a: mean foreground PSNR 62.8 dB >= 40 dB (whole frame 75.1 dB); worst view orbit_002
/// 61.9 dB; saves 3,360,261 bytes (54%)"
void print_verdict(std::FILE* out, const audit::AuditResult& r, size_t candidate, double threshold) {
  const audit::Verdict v = audit::verdict(r, candidate, threshold);
  const bool foreground = v.metric == audit::VerdictMetric::kForeground;
  const std::string beside = foreground ? " (whole frame " + db(v.whole_frame_psnr_mean_db) + " dB)" : "";
  std::string saved = "no file size";
  if (v.bytes_saved) {
    saved = *v.bytes_saved >= 0 ? "saves " + rgs::group_digits(*v.bytes_saved) + " bytes"
                                : "adds " + rgs::group_digits(-*v.bytes_saved) + " bytes";
    saved += " (" + tools::fixed(100.0 * std::fabs(v.bytes_saved_fraction), 0) + "% of the source)";
  }
  const std::string lost = v.content_lost.empty() ? "" : "lost its content (" + v.content_lost + "); ";
  std::fprintf(out, "  verdict          %s %s: %smean %s %s dB %s %s dB%s; worst view %s %s dB; %s\n",
               v.passed ? "PASS" : "FAIL", tools::escape_text(r.candidates[candidate].scene.label).c_str(),
               lost.c_str(),
               metric_text(v.metric).c_str(), db(v.psnr_mean_db).c_str(), v.psnr_mean_db >= threshold ? ">=" : "<",
               tools::fixed(threshold, 2).c_str(), beside.c_str(), tools::escape_text(v.worst_view).c_str(),
               db(v.worst_psnr_db).c_str(), saved.c_str());
}

/// The summary table: the source, each candidate's sizes and quality, the worst views, the files written.
void print_table(std::FILE* out, const Options& opt, const audit::AuditResult& r, const std::string& report_json,
                 Clock::time_point t_start) {
  std::fprintf(out, "%s %s (%s, %s Gaussians, %s bytes)\n", kTool,
               tools::escape_text(r.source.path).c_str(), tools::escape_text(r.source.format).c_str(),
               rgs::group_digits(r.source.gaussians).c_str(), rgs::group_digits(r.source.file_bytes).c_str());
  std::fprintf(out, "  backend          %s (%s)\n", audit::backend_name(r.backend),
               tools::escape_text(r.device).c_str());
  std::fprintf(out, "  load             source %s s\n", tools::fixed(r.source.load_seconds, 2).c_str());
  for (const auto& c : r.candidates) print_candidate(out, r, c);
  // Labels are printed whole: the columns widen to the longest one.
  size_t label_width = 0;
  for (const auto& c : r.candidates) label_width = std::max(label_width, tools::escape_text(c.scene.label).size());
  const int view_column = int(std::max<size_t>(12, label_width));
  const int candidate_column = int(std::max<size_t>(16, label_width));
  std::fprintf(out, "  %-22s", "view");
  for (const auto& c : r.candidates) std::fprintf(out, " %*s", view_column, tools::escape_text(c.scene.label).c_str());
  std::fprintf(out, "   PSNR dB\n");
  for (size_t v = 0; v < r.views.size(); ++v) {
    std::fprintf(out, "  %-22s", tools::escape_text(r.views[v].name).c_str());
    for (const auto& c : r.candidates) std::fprintf(out, " %*s", view_column, db(c.views[v].psnr_db).c_str());
    std::fprintf(out, "\n");
  }
  std::fprintf(out, "  %-*s %8s %14s %8s %9s %9s %10s %10s %9s\n", candidate_column, "candidate", "format", "bytes",
               "B/G", "ratio", "PSNR mean", "PSNR min", "SSIM mean", "max |d|");
  for (const auto& c : r.candidates) {
    const double per_g = r.source.gaussians ? double(c.scene.file_bytes) / double(r.source.gaussians) : 0.0;
    std::fprintf(
        out, "  %-*s %8s %14s %8s %8sx %9s %10s %10s %9s\n", candidate_column,
        tools::escape_text(c.scene.label).c_str(),
        tools::escape_text(c.scene.format).c_str(), rgs::group_digits(c.scene.file_bytes).c_str(),
        tools::fixed(per_g, 1).c_str(),
        tools::fixed(c.scene.file_bytes ? double(r.source.file_bytes) / double(c.scene.file_bytes) : 0.0, 2).c_str(),
        db(c.summary.psnr_mean_db).c_str(), db(c.summary.psnr_min_db).c_str(),
        tools::fixed(c.summary.ssim_mean, 5).c_str(), tools::fixed(c.summary.max_abs_diff, 4).c_str());
  }
  const audit::ViewInfo& first = r.views.front();
  for (const auto& c : r.candidates) {
    const std::string suffix = r.candidates.size() > 1 ? "  [" + tools::escape_text(c.scene.label) + "]" : "";
    std::fprintf(out, "  PSNR             mean %s dB, min %s dB (%zu views, %ux%u; worst view: the verdict's)%s\n",
                 db(c.summary.psnr_mean_db).c_str(), db(c.summary.psnr_min_db).c_str(), r.views.size(), first.width,
                 first.height, suffix.c_str());
    std::fprintf(out, "  SSIM             mean %s, min %s%s\n", tools::fixed(c.summary.ssim_mean, 5).c_str(),
                 tools::fixed(c.summary.ssim_min, 5).c_str(), suffix.c_str());
  }
  if (!opt.heatmap_path.empty()) {
    std::fprintf(out,
                 "  heatmap          %s (%s: |d| max over RGB, 0 black, %s and above white: the report's scale of "
                 "this candidate; its largest |d| %s)\n",
                 tools::escape_text(opt.heatmap_path).c_str(),
                 tools::escape_text(r.views[r.candidates[0].summary.worst_view].name).c_str(),
                 tools::fixed(r.candidates[0].heat_scale, 4).c_str(),
                 tools::fixed(r.candidates[0].summary.max_abs_diff, 4).c_str());
  }
  for (size_t i = 0; i < r.candidates.size(); ++i) print_verdict(out, r, i, opt.threshold);
  if (!report_json.empty()) std::fprintf(out, "  json             %s\n", tools::escape_text(report_json).c_str());
  std::fprintf(out, "  time             %s s (views %s s)\n", tools::fixed(tools::seconds_since(t_start), 1).c_str(),
               tools::fixed(r.render_seconds, 1).c_str());
}

int run(const Options& opt) {
  const auto t_start = Clock::now();
  const bool json_stdout = opt.json_path == "-";
  if (!opt.heatmap_path.empty()) {
    Status heatmap_ok = tools::check_image8_path(opt.heatmap_path, 1);
    if (!heatmap_ok.ok()) return tools::report_error(kTool, heatmap_ok);
  }
  if (!opt.renders_dir.empty()) {
    Status format_ok = tools::check_image8_path("render." + opt.image_format, 3);
    if (!format_ok.ok()) return tools::report_error(kTool, format_ok.prepend("--save-renders"));
  }

  // Every identity is checked before any work: no output may replace an input or another output. The report's
  // image files are named by the audit's worst views, so they are declared once it has run (before writing).
  format::OutputTransaction outputs;
  std::string report_json, report_files;
  if (int code = declare_files(opt, outputs, &report_json, &report_files); code != tools::kExitOk) return code;
  tools::report_notes(kTool, outputs.remove_stale_temporaries());

  auto result = measure(opt, outputs);
  if (!result.ok()) return tools::report_error(kTool, result.status());
  const audit::AuditResult& r = *result;

  // Outputs, all staged in `outputs`: images and JSON next to the report, the JSON also at --json (or stdout),
  // the heatmap; the HTML below.
  audit::ReportOptions ro;
  ro.tool_version = RGS_VERSION_STRING;
  ro.command_line = opt.command_line;
  if (opt.min_psnr_set) ro.min_psnr_db = opt.min_psnr;
  ro.threshold_db = opt.threshold;
  std::set<std::string> images_written;
  if (!opt.no_report && !opt.no_report_images) {
    ro.image_dir = std::filesystem::path(report_files).filename().string() + "/";
    for (const auto& [path, image] : audit::report_images(r, report_files)) {
      if (int code = tools::declare_output(kTool, outputs, path); code != tools::kExitOk) return code;
      images_written.insert(std::filesystem::path(path).filename().string());
    }
    if (Status created = outputs.create_folder(report_files); !created.ok()) return tools::report_error(kTool, created);
    tools::report_notes(kTool, outputs.remove_stale_temporaries());
    Status st = audit::write_report_images(r, report_files, outputs);
    if (!st.ok()) return tools::report_error(kTool, st);
  }
  if (!opt.heatmap_path.empty()) {
    const audit::Image8& h = r.candidates[0].worst_heatmap;
    Status st = tools::write_image8(outputs, opt.heatmap_path, h.width, h.height, 1, h.pixels);
    if (!st.ok()) return tools::report_error(kTool, st);
  }
  ro.total_seconds = tools::seconds_since(t_start);
  const std::string text = audit::audit_json(r, ro);
  if (!report_json.empty()) {
    Status st = outputs.write(report_json, text.data(), text.size());
    if (!st.ok()) return tools::report_error(kTool, st);
    auto html = audit::report_html(r, ro);
    if (html.ok()) st = outputs.write(opt.report_path, html->data(), html->size());
    if (!st.ok() || !html.ok()) return tools::report_error(kTool, html.ok() ? st : html.status());
  }
  if (!opt.json_path.empty() && !json_stdout && !json_is_report_json(opt, report_json)) {
    ro.image_dir.clear();  // image paths are relative to the report's JSON
    const std::string plain = audit::audit_json(r, ro);
    Status st = outputs.write(opt.json_path, plain.data(), plain.size());
    if (!st.ok()) return tools::report_error(kTool, st);
  }

  // The table (stderr when stdout carries the JSON).
  std::FILE* out = json_stdout ? stderr : stdout;
  if (!opt.quiet) {
    print_table(out, opt, r, report_json, t_start);
    if (!opt.no_report) std::fprintf(out, "  report           %s\n", tools::escape_text(opt.report_path).c_str());
  }
  if (json_stdout) {
    std::fwrite(text.data(), 1, text.size(), stdout);
    std::fflush(stdout);
  }

  const bool below_gate = opt.min_psnr_set && !audit::passes_gate(r, opt.min_psnr);
  if (below_gate) {
    for (size_t i = 0; i < r.candidates.size(); ++i) {
      const audit::Verdict v = audit::verdict(r, i, opt.min_psnr);
      if (v.worst_psnr_db < opt.min_psnr) {
        std::fprintf(stderr, "%s: error: %s: min %s %s dB (view %s) is below --min-psnr %s dB\n", kTool,
                     tools::escape_text(r.candidates[i].scene.label).c_str(), metric_text(v.metric).c_str(),
                     db(v.worst_psnr_db).c_str(), tools::escape_text(v.worst_view).c_str(),
                     tools::fixed(opt.min_psnr, 2).c_str());
      }
    }
  }
  if (int code = tools::commit_outputs(kTool, outputs, opt.quiet); code != tools::kExitOk) return code;
  if (!report_files.empty()) remove_stale_report_images(report_files, images_written);
  return below_gate ? kExitBelowMinPsnr : tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  for (int i = 0; i < argc; ++i) opt.command_line += (i ? " " : "") + std::string(argv[i]);
  CLI::App app{
      "Audit conversions and formats: bytes per section and per Gaussian, per-attribute errors, and per-view "
      "PSNR/SSIM/max |d| of each candidate's render against the source's (3DGS baseline, FP32). Renders on the "
      "GPU when a CUDA device is present (--backend), else on the CPU reference. Writes a JSON next to an "
      "HTML report (default <first candidate>.audit.html), all committed together at the end. Without a camera "
      "option: the source's own cameras.json of the 3DGS output layout beside it, else views guessed from its "
      "content. Exit status: 0 ok, 1 failure (nothing written), 2 usage error, 3 below "
      "--min-psnr (reports written).",
      kTool};
  app.add_option("scenes", opt.scenes, "SOURCE CANDIDATE [CANDIDATE...]: scenes in any format, " + rgs::tools::scene_formats_help());
  app.add_option("--label", opt.labels, "Name of a candidate in tables and plots (repeat, in candidate order)");
  app.add_flag("--attribution", opt.attribution,
               "Also audit, for each candidate, the source with one attribute group at a time taken from the "
               "candidate (means, rotations, scales, opacities, SH DC, SH bands 1+): what each attribute's "
               "encoding alone costs (needs every candidate Gaussian paired with a source Gaussian, in any order: "
               "docs/AUDITS.md#how-gaussians-are-paired)");
  rgs::tools::add_camera_options(app, opt.cameras, "INRIA cameras.json (native size by default)", "At most N views",
                                 "Orbit of N cameras (at 960x540)");
  app.add_option("--width", opt.cameras.width, "Image width (field of view kept)")->check(CLI::Range(11, 32768));
  app.add_option("--height", opt.cameras.height, "Image height")->check(CLI::Range(11, 32768));
  rgs::tools::add_render_options(app, opt.render, rgs::tools::kBackendOption, "--threads");
  rgs::tools::add_scene_read_options(app);
  auto* report = app.add_option("--report", opt.report_path,
                                "HTML report; its JSON (.json) and images (_files/) go next to it");
  auto* no_report = app.add_flag("--no-report", opt.no_report, "Write no report, JSON or images (see --json)");
  report->excludes(no_report);
  app.add_flag("--no-report-images", opt.no_report_images,
               "Write the report and its JSON without the image folder (_files/: the worst views' raw images, "
               "which only --report-from reads; the HTML holds them anyway)")
      ->excludes(no_report);
  app.add_option("--report-from", opt.report_from, "Only make the HTML (--report) from the JSON of an earlier run");
  app.add_option("--json", opt.json_path, "Also write the JSON here ('-': stdout; the table then goes to stderr)");
  app.add_option(
      "--heatmap", opt.heatmap_path,
      "Full-size |difference| of the first candidate's worst view as a grey image: .png (OpenImageIO), .pgm, .ppm");
  app.add_option("--save-renders", opt.renders_dir,
                 "Also write every render as an 8-bit image, as rgs-render writes them (same names and 8-bit rule): "
                 "DIR/source/<view> and DIR/<candidate label>/<view>");
  app.add_option("--format", opt.image_format,
                 std::string("8-bit image format of --save-renders: png (needs OpenImageIO) or ppm (binary P6); "
                             "default ") + (rgs::tools::have_openimageio() ? "png" : "ppm"))
      ->check(CLI::IsMember({"png", "ppm"}));
  app.add_option("--worst", opt.worst, "Worst views per candidate shown in the report (default 3)");
  app.add_option("--image-size", opt.image_size, "Largest side of the report's images (default 1024)")
      ->check(CLI::Range(16, 32768));
  auto* minp = app.add_option("--min-psnr", opt.min_psnr,
                              "CI gate: exit 3 when any candidate's lowest per-view PSNR is below DB (the reports are "
                              "still written); the verdict's metric: foreground PSNR where the source's renders "
                              "have background, else the whole frame's");
  auto* threshold = app.add_option("--threshold", opt.threshold,
                 "The report's verdict: a candidate passes when its mean PSNR over the views is at least DB "
                 "(default 40; foreground PSNR where the source's renders have background, else the whole "
                 "frame's; the exit status is --min-psnr's)")
      ->check(CLI::Range(-1000.0, 1000.0));
  app.add_flag("-q,--quiet", opt.quiet, "No table");
  const auto check = [&]() -> std::string {
    if (!opt.report_from.empty() && !opt.scenes.empty()) {
      return "--report-from makes the HTML of an earlier run and takes no scenes";
    }
    if (!opt.report_from.empty() && threshold->count() > 0) {
      return "--report-from draws the earlier run's verdict; --threshold needs a new audit";
    }
    if (!opt.report_from.empty()) return {};
    if (std::isnan(opt.threshold)) return "--threshold: a PSNR in dB, not NaN";
    if (opt.scenes.size() < 2) return "give a source and at least one candidate scene";
    if (opt.labels.size() > opt.scenes.size() - 1) {
      return std::to_string(opt.labels.size()) + " --label for " + std::to_string(opt.scenes.size() - 1) +
             " candidates";
    }
    return {};
  };
  if (auto code = rgs::tools::parse_command_line(app, argc, argv, kTool, check)) return *code;
  rgs::tools::install_interrupt_cleanup();
  if (!opt.report_from.empty()) return rgs::tools::finish(kTool, run_report_only(opt));
  opt.min_psnr_set = minp->count() > 0;
  if (opt.image_format.empty()) opt.image_format = rgs::tools::have_openimageio() ? "png" : "ppm";
  if (opt.report_path.empty() && !opt.no_report) {
    const std::filesystem::path first(opt.scenes[1]);
    opt.report_path = (first.parent_path() / (first.stem().string() + ".audit.html")).string();
  }
  opt.cameras.orbit_width = 960;
  opt.cameras.orbit_height = 540;
  return rgs::tools::finish(kTool, run(opt));
}
