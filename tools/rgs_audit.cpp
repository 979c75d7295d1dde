// rgs-audit: what a conversion cost. Sizes per section, per-attribute errors, and PSNR/SSIM of the .rgs render
// against the FP32 render of the source PLY (CPU reference renderer, baseline settings).
//
//   rgs-audit scene.ply scene.rgs --cameras cameras.json --every 20 --width 1256 --json report.json
//   rgs-audit scene.ply scene.rgs --min-psnr 40          CI gate: exit 1 when a view is below 40 dB
//
// Without a camera option: --orbit 4 at 960x540. Exit status: 0 ok, 1 failure or PSNR below --min-psnr,
// 2 usage error.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli_common.h"
#include "error_stats_output.h"
#include "image_metrics.h"
#include "image_write.h"
#include "rgs/config.h"
#include "rgs/converter/attribute_errors.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/file_io.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"
#include "rgs/runtime/cpu_renderer.h"
#include "scene_loading.h"

namespace {

using namespace rgs;
using Clock = std::chrono::steady_clock;
constexpr const char* kTool = "rgs-audit";

struct Options {
  std::string ply_path;
  std::string rgs_path;
  tools::CameraChoice cameras;
  std::string json_path;
  std::string heatmap_path;
  double min_psnr = -1;
  bool min_psnr_set = false;
};

std::string db(double v) { return std::isinf(v) ? std::string("inf") : tools::fixed(v, 2); }
nlohmann::json db_json(double v) { return std::isinf(v) ? nlohmann::json("inf") : nlohmann::json(v); }

struct ViewResult {
  std::string name;
  double psnr = 0, ssim = 0, seconds = 0;
  float max_abs_diff = 0;
};

int run(Options opt) {
  const auto t_start = Clock::now();
  if (!opt.heatmap_path.empty()) {
    Status heatmap_ok = tools::check_image8_path(opt.heatmap_path, 1);
    if (!heatmap_ok.ok()) return tools::report_error(kTool, heatmap_ok);
  }
  auto ply = converter::read_ply(opt.ply_path);
  if (!ply.ok()) return tools::report_error(kTool, ply.status());
  auto file = format::RgsFile::open(opt.rgs_path, tools::read_options());
  if (!file.ok()) return tools::report_error(kTool, file.status());
  auto encoded = file->read_scene();
  if (!encoded.ok()) return tools::report_error(kTool, encoded.status());
  auto rgs_cloud = format::dequantize(*encoded);
  if (!rgs_cloud.ok()) return tools::report_error(kTool, Status(rgs_cloud.status()).prepend(opt.rgs_path));
  const format::GaussianCloud& ref = ply->cloud;
  const uint64_t n = ref.size();
  if (rgs_cloud->size() != n || rgs_cloud->sh_degree != ref.sh_degree) {
    return tools::report_error(
        kTool, Status(StatusCode::kInvalidArgument,
                      opt.rgs_path + ": " + std::to_string(rgs_cloud->size()) + " Gaussians of SH degree " +
                          std::to_string(rgs_cloud->sh_degree) + ", but " + opt.ply_path + " has " +
                          std::to_string(n) + " of degree " + std::to_string(ref.sh_degree) +
                          ": not a conversion of this file"));
  }
  auto errors = converter::measure_attribute_errors(ref, *rgs_cloud);
  if (!errors.ok()) return tools::report_error(kTool, errors.status());

  // Clipped SH coefficients: |SH| / s >= 127.5 (round-half-away would exceed 127), or s = 0 with SH != 0.
  const format::ShQuantization& shq = encoded->metadata.sh_quantization;
  uint64_t clipped[4][3] = {};
  const uint32_t k_count = ref.sh_coefficients();
  for (uint64_t i = 0; i < n; ++i) {
    for (uint32_t k = 0; k < k_count; ++k) {
      const uint32_t d = format::sh_degree_of_coefficient(k);
      for (uint32_t c = 0; c < 3; ++c) {
        const double v = std::fabs(static_cast<double>(ref.sh[(i * k_count + k) * 3 + c]));
        const double s = shq.scales[d][c];
        clipped[d][c] += (s > 0) ? (v >= 127.5 * s) : (v != 0.0);
      }
    }
  }

  // Renders: FP32 PLY vs dequantized .rgs, both baseline.
  auto cameras = tools::make_cameras(opt.cameras, file->metadata().bounds);
  if (!cameras.ok()) return tools::report_error(kTool, cameras.status());
  if (cameras->empty()) return tools::report_error(kTool, Status(StatusCode::kInvalidArgument, "no views selected"));
  runtime::RenderOptions render_options;
  std::vector<ViewResult> views;
  std::vector<uint8_t> worst_heat;
  uint32_t worst_w = 0, worst_h = 0;
  size_t worst = 0;
  for (size_t v = 0; v < cameras->size(); ++v) {
    const runtime::Camera& cam = (*cameras)[v];
    const auto t_view = Clock::now();
    auto a = runtime::render_cpu(ref, cam, render_options);
    if (!a.ok()) return tools::report_error(kTool, Status(a.status()).prepend(opt.ply_path + ", view " + cam.name));
    auto b = runtime::render_cpu(*rgs_cloud, cam, render_options);
    if (!b.ok()) return tools::report_error(kTool, Status(b.status()).prepend(opt.rgs_path + ", view " + cam.name));
    ViewResult r;
    r.name = cam.name;
    auto p = tools::psnr_rgb(a->rgb, b->rgb, cam.width, cam.height);
    if (!p.ok()) return tools::report_error(kTool, p.status());
    auto s = tools::ssim_rgb(a->rgb, b->rgb, cam.width, cam.height);
    if (!s.ok()) return tools::report_error(kTool, Status(s.status()).prepend("view " + cam.name));
    r.psnr = *p;
    r.ssim = *s;
    // |difference| per pixel, max over RGB, of the clamped images.
    const size_t pixels = size_t{cam.width} * cam.height;
    std::vector<float> diff(pixels, 0.f);
    for (size_t i = 0; i < pixels; ++i) {
      for (int c = 0; c < 3; ++c) {
        const float x = std::isnan(a->rgb[i * 3 + c]) ? 0.f : std::clamp(a->rgb[i * 3 + c], 0.f, 1.f);
        const float y = std::isnan(b->rgb[i * 3 + c]) ? 0.f : std::clamp(b->rgb[i * 3 + c], 0.f, 1.f);
        diff[i] = std::max(diff[i], std::fabs(x - y));
      }
      r.max_abs_diff = std::max(r.max_abs_diff, diff[i]);
    }
    r.seconds = tools::seconds_since(t_view);
    views.push_back(r);
    if (views.size() == 1 || r.psnr < views[worst].psnr) {
      worst = v;
      worst_w = cam.width;
      worst_h = cam.height;
      worst_heat.assign(pixels, 0);
      if (r.max_abs_diff > 0) {
        for (size_t i = 0; i < pixels; ++i) {
          worst_heat[i] = static_cast<uint8_t>(std::floor(diff[i] / r.max_abs_diff * 255.f + 0.5f));
        }
      }
    }
    std::fprintf(stderr, "view %zu/%zu %s PSNR %s dB SSIM %s %s s\n", v + 1, cameras->size(), cam.name.c_str(),
                 db(r.psnr).c_str(), tools::fixed(r.ssim, 5).c_str(), tools::fixed(r.seconds, 1).c_str());
  }
  double psnr_sum = 0, ssim_sum = 0, psnr_min = std::numeric_limits<double>::infinity(), ssim_min = 1e300;
  for (const ViewResult& r : views) {
    psnr_sum += r.psnr;
    ssim_sum += r.ssim;
    psnr_min = std::min(psnr_min, r.psnr);
    ssim_min = std::min(ssim_min, r.ssim);
  }
  const double psnr_mean = psnr_sum / static_cast<double>(views.size());
  const double ssim_mean = ssim_sum / static_cast<double>(views.size());

  if (!opt.heatmap_path.empty()) {
    Status st = tools::write_image8(opt.heatmap_path, worst_w, worst_h, 1, worst_heat);
    if (!st.ok()) return tools::report_error(kTool, st);
  }

  // Sizes.
  const double per_g = n ? 1.0 / static_cast<double>(n) : 0.0;
  const double in_bytes = static_cast<double>(ply->file_bytes);
  const double out_bytes = static_cast<double>(file->file_size());
  uint64_t section_total = 0;
  for (const auto& e : file->sections()) section_total += e.stored_size;
  const uint64_t overhead = file->file_size() - section_total;
  const uint32_t degree = ref.sh_degree;
  const char* channel_names[3] = {"R", "G", "B"};

  std::printf("%s %s vs %s\n", kTool, opt.ply_path.c_str(), opt.rgs_path.c_str());
  std::printf("  gaussians        %s (SH degree %u)\n", tools::group_digits(n).c_str(), degree);
  std::printf("  input            %s bytes  (%s B/Gaussian)\n", tools::group_digits(ply->file_bytes).c_str(),
              tools::fixed(in_bytes * per_g, 1).c_str());
  std::printf("  output           %s bytes  (%s B/Gaussian), ratio %sx\n",
              tools::group_digits(file->file_size()).c_str(), tools::fixed(out_bytes * per_g, 1).c_str(),
              tools::fixed(out_bytes > 0 ? in_bytes / out_bytes : 0.0, 2).c_str());
  std::printf("  %-22s %8s %14s %12s\n", "section", "codec", "bytes", "B/Gaussian");
  for (const auto& e : file->sections()) {
    std::printf("  %-22s %8s %14s %12s\n", format::section_name(e.id), format::codec_name(e.codec),
                tools::group_digits(e.stored_size).c_str(),
                tools::fixed(static_cast<double>(e.stored_size) * per_g, 3).c_str());
  }
  std::printf("  %-22s %8s %14s %12s\n", "header, table, padding", "", tools::group_digits(overhead).c_str(),
              tools::fixed(static_cast<double>(overhead) * per_g, 3).c_str());
  std::printf("  %-22s %12s %12s\n", "error", "max", "rms");
  converter::ErrorStats pos_mm = errors->position;
  pos_mm.max *= 1000;
  pos_mm.rms *= 1000;
  tools::print_stats_row("position x1000", pos_mm, "scene units x 1000 (mm if the scene is metric)", 22);
  tools::print_stats_row("rotation", errors->rotation_deg, "degrees", 22);
  tools::print_stats_row("scale", errors->scale_of_largest_axis, "of the Gaussian's largest axis", 22);
  tools::print_stats_row("opacity", errors->opacity, "absolute", 22);
  for (uint32_t d = 0; d <= degree; ++d) {
    tools::print_stats_row("SH degree " + std::to_string(d), errors->sh[d], "absolute (all channels)", 22);
    for (uint32_t c = 0; c < 3; ++c) {
      tools::print_stats_row("  " + std::string(channel_names[c]), errors->sh_channel[d][c],
                             "scale " + tools::sci(shq.scales[d][c]) + ", " +
                                 tools::group_digits(clipped[d][c]) + " clipped",
                             22);
    }
  }
  std::printf("  %-22s %10s %10s %10s %8s\n", "view", "PSNR dB", "SSIM", "max |d|", "s");
  for (const ViewResult& r : views) {
    std::printf("  %-22s %10s %10s %10s %8s\n", r.name.c_str(), db(r.psnr).c_str(), tools::fixed(r.ssim, 5).c_str(),
                tools::fixed(r.max_abs_diff, 4).c_str(), tools::fixed(r.seconds, 1).c_str());
  }
  const runtime::Camera& first = cameras->front();
  std::printf("  PSNR             mean %s dB, min %s dB (%zu views, %ux%u, worst %s)\n", db(psnr_mean).c_str(),
              db(psnr_min).c_str(), views.size(), first.width, first.height, views[worst].name.c_str());
  std::printf("  SSIM             mean %s, min %s\n", tools::fixed(ssim_mean, 5).c_str(), tools::fixed(ssim_min, 5).c_str());
  if (!opt.heatmap_path.empty()) {
    std::printf("  heatmap          %s (%s: |d| max over RGB, 0 black, %s white)\n", opt.heatmap_path.c_str(),
                views[worst].name.c_str(), tools::fixed(views[worst].max_abs_diff, 4).c_str());
  }
  std::printf("  time             %s s\n", tools::fixed(tools::seconds_since(t_start), 1).c_str());

  if (!opt.json_path.empty()) {
    nlohmann::json j;
    j["input"] = {{"path", opt.ply_path}, {"bytes", ply->file_bytes}};
    j["output"] = {{"path", opt.rgs_path}, {"bytes", file->file_size()}};
    j["gaussians"] = n;
    j["sh_degree"] = degree;
    j["bytes_per_gaussian"] = {{"input", in_bytes * per_g}, {"output", out_bytes * per_g}};
    j["ratio"] = out_bytes > 0 ? in_bytes / out_bytes : 0.0;
    nlohmann::json sections = nlohmann::json::array();
    for (const auto& e : file->sections()) {
      sections.push_back({{"name", format::section_name(e.id)}, {"codec", format::codec_name(e.codec)},
                          {"bytes", e.stored_size}, {"raw_bytes", e.raw_size},
                          {"bytes_per_gaussian", static_cast<double>(e.stored_size) * per_g}});
    }
    j["sections"] = sections;
    j["header_table_padding_bytes"] = overhead;
    nlohmann::json sh = nlohmann::json::array();
    for (uint32_t d = 0; d <= degree; ++d) {
      nlohmann::json ch = nlohmann::json::array();
      for (uint32_t c = 0; c < 3; ++c) {
        ch.push_back({{"channel", channel_names[c]}, {"error", tools::stats_json(errors->sh_channel[d][c])},
                      {"scale", shq.scales[d][c]}, {"clipped", clipped[d][c]}});
      }
      sh.push_back({{"degree", d}, {"error", tools::stats_json(errors->sh[d])}, {"channels", ch}});
    }
    j["errors"] = {{"position_scene_units", tools::stats_json(errors->position)},
                   {"rotation_deg", tools::stats_json(errors->rotation_deg)},
                   {"scale_relative", tools::stats_json(errors->scale_relative)},
                   {"scale_of_largest_axis", tools::stats_json(errors->scale_of_largest_axis)},
                   {"opacity", tools::stats_json(errors->opacity)},
                   {"sh", sh}};
    nlohmann::json vj = nlohmann::json::array();
    for (const ViewResult& r : views) {
      vj.push_back({{"name", r.name}, {"psnr_db", db_json(r.psnr)}, {"ssim", r.ssim},
                    {"max_abs_diff", r.max_abs_diff}, {"seconds", r.seconds}});
    }
    j["views"] = vj;
    j["resolution"] = {first.width, first.height};
    j["psnr_db"] = {{"mean", db_json(psnr_mean)}, {"min", db_json(psnr_min)}};
    j["ssim"] = {{"mean", ssim_mean}, {"min", ssim_min}};
    j["worst_view"] = views[worst].name;
    const std::string text = j.dump(2) + "\n";
    Status st = format::write_file_atomic(opt.json_path, text.data(), text.size());
    if (!st.ok()) return tools::report_error(kTool, st);
  }

  if (opt.min_psnr_set && psnr_min < opt.min_psnr) {
    std::fprintf(stderr, "%s: error: min PSNR %s dB (view %s) is below --min-psnr %s dB\n", kTool,
                 db(psnr_min).c_str(), views[worst].name.c_str(), tools::fixed(opt.min_psnr, 2).c_str());
    return tools::kExitFailure;
  }
  return tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Audit a conversion: bytes per section and per Gaussian, per-attribute errors, and PSNR/SSIM of the "
               ".rgs render against the FP32 render of the source PLY (CPU reference renderer, baseline). Without "
               "a camera option: --orbit 4 at 960x540.",
               kTool};
  app.add_option("input", opt.ply_path, "Source 3DGS .ply")->required();
  app.add_option("output", opt.rgs_path, ".rgs converted from it")->required();
  auto* cams = app.add_option("--cameras", opt.cameras.cameras_path, "INRIA cameras.json");
  app.add_option("--every", opt.cameras.every, "Use every K-th camera of --cameras")->check(CLI::PositiveNumber)->needs(cams);
  auto* orbit = app.add_option("--orbit", opt.cameras.orbit, "Orbit of N cameras (default 4, at 960x540)")
                    ->check(CLI::PositiveNumber)->excludes(cams);
  cams->excludes(orbit);
  app.add_option("--width", opt.cameras.width, "Image width (field of view kept)")->check(CLI::Range(11, 32768));
  app.add_option("--height", opt.cameras.height, "Image height")->check(CLI::Range(11, 32768));
  app.add_option("--json", opt.json_path, "Write the report as JSON");
  app.add_option("--heatmap", opt.heatmap_path,
                 "Write |difference| of the worst view as a grey image: .png (needs OpenImageIO), .pgm or .ppm");
  auto* minp = app.add_option("--min-psnr", opt.min_psnr, "Exit 1 when the lowest per-view PSNR is below DB");
  app.set_version_flag("--version", std::string(kTool) + " " + RGS_VERSION_STRING);
  rgs::tools::add_read_limit_options(app, rgs::tools::read_limits());
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? rgs::tools::kExitOk : rgs::tools::kExitUsage;
  }
  opt.min_psnr_set = minp->count() > 0;
  if (opt.cameras.cameras_path.empty() && opt.cameras.orbit == 0) opt.cameras.orbit = 4;
  opt.cameras.orbit_width = 960;
  opt.cameras.orbit_height = 540;
  return run(opt);
}
