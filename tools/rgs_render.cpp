// rgs-render: render a scene (.rgs or PLY) with the CPU reference renderer from its cameras or an orbit.
//
//   rgs-render scene.rgs --cameras cameras.json -o out/      one PNG per camera, named after img_name
//   rgs-render scene.ply --orbit 8 -o out/ --exr             orbit_000.png ... (+ float RGBA .exr)
//
// Exit status: 0 on success, 1 when loading, rendering or writing failed (message naming the file), 2 on a
// usage error.

#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.h"
#include "image_write.h"
#include "rgs/config.h"
#include "rgs/runtime/cpu_renderer.h"
#include "rgs/runtime/image_io.h"
#include "scene_loading.h"

namespace {

using namespace rgs;
using Clock = std::chrono::steady_clock;
constexpr const char* kTool = "rgs-render";

struct Options {
  std::string input;
  std::string output_dir;
  tools::CameraChoice cameras;
  std::string background = "0,0,0";
  bool exr = false;
  std::string backend = "cpu";
  bool key32 = false, accutile = false, folded = false, fast_exp = false;
  float fast_exp_sigma = kernels::kFastExpSigmaMinMax;
};

Result<std::array<float, 3>> parse_background(const std::string& text) {
  std::array<float, 3> bg{};
  std::istringstream in(text);
  std::string part;
  int i = 0;
  while (std::getline(in, part, ',')) {
    RGS_RETURN_ERROR_IF(i >= 3, StatusCode::kInvalidArgument, "--background: expected r,g,b, got '" + text + "'");
    try {
      size_t used = 0;
      bg[i] = std::stof(part, &used);
      RGS_RETURN_ERROR_IF(used != part.size(), StatusCode::kInvalidArgument,
                          "--background: '" + part + "' is not a number");
    } catch (const std::exception&) {
      return Status(StatusCode::kInvalidArgument, "--background: '" + part + "' is not a number");
    }
    ++i;
  }
  RGS_RETURN_ERROR_IF(i != 3, StatusCode::kInvalidArgument, "--background: expected r,g,b, got '" + text + "'");
  return bg;
}

int run(const Options& opt) {
  if (opt.backend == "cuda") {
    return tools::report_error(kTool, Status(StatusCode::kUnsupportedFeature,
                                             "--backend cuda: rgs-render is not built with CUDA (use --backend cpu)"));
  }
  auto background = parse_background(opt.background);
  if (!background.ok()) return tools::report_error(kTool, background.status());

  const auto t_start = Clock::now();
  auto scene = tools::load_scene(opt.input);
  if (!scene.ok()) return tools::report_error(kTool, scene.status());
  auto cameras = tools::make_cameras(opt.cameras, scene->bounds);
  if (!cameras.ok()) return tools::report_error(kTool, cameras.status());
  if (cameras->empty()) {
    return tools::report_error(kTool, Status(StatusCode::kInvalidArgument, "no views selected"));
  }

  std::error_code ec;
  std::filesystem::create_directories(opt.output_dir, ec);
  if (ec || !std::filesystem::is_directory(opt.output_dir)) {
    return tools::report_error(kTool, Status(StatusCode::kIoError, opt.output_dir + ": cannot create output directory" +
                                                                       (ec ? ": " + ec.message() : std::string())));
  }

  runtime::RenderOptions render_options;
  render_options.background = *background;
  render_options.scene_bounds = scene->bounds;
  render_options.roofgs.key32 = opt.key32;
  render_options.roofgs.snugbox_accutile = opt.accutile;
  render_options.roofgs.folded_coefficients = opt.folded;
  render_options.roofgs.fast_exp = opt.fast_exp;
  render_options.roofgs.fast_exp_sigma = opt.fast_exp_sigma;

  const size_t count = cameras->size();
  double render_seconds = 0;
  uint64_t total_pairs = 0;
  for (size_t i = 0; i < count; ++i) {
    const runtime::Camera& cam = (*cameras)[i];
    const auto t_view = Clock::now();
    auto result = runtime::render_cpu(scene->cloud, cam, render_options);
    if (!result.ok()) return tools::report_error(kTool, Status(result.status()).prepend(opt.input + ", view " + cam.name));
    const double seconds = tools::seconds_since(t_view);
    render_seconds += seconds;
    total_pairs += result->stats.pairs;
    const std::string base =
        (std::filesystem::path(opt.output_dir) / tools::file_safe_name(cam.name, i)).string();
    Status s = tools::write_png8(base + ".png", result->width, result->height, 3, runtime::to_8bit(result->rgb));
    if (!s.ok()) return tools::report_error(kTool, s);
    if (opt.exr) {
      s = tools::write_exr_rgba(base + ".exr", result->width, result->height, result->rgb, result->alpha);
      if (!s.ok()) return tools::report_error(kTool, s);
    }
    std::fprintf(stderr, "view %zu/%zu %s %s s\n", i + 1, count, cam.name.c_str(), tools::fixed(seconds, 1).c_str());
  }

  const runtime::Camera& first = cameras->front();
  std::printf("%s %s -> %s\n", kTool, opt.input.c_str(), opt.output_dir.c_str());
  std::printf("  views            %zu (%s%s)\n", count, opt.exr ? "PNG + EXR" : "PNG",
              opt.cameras.cameras_path.empty() ? ", orbit" : ", cameras.json");
  std::printf("  resolution       %ux%u\n", first.width, first.height);
  std::printf("  gaussians        %s (SH degree %u, %s)\n", tools::group_digits(scene->cloud.size()).c_str(),
              scene->cloud.sh_degree, scene->is_rgs ? ".rgs dequantized" : "PLY");
  std::printf("  mean pairs       %s\n", tools::group_digits(total_pairs / count).c_str());
  std::printf("  mode             %s%s%s%s%s\n", "cpu", opt.key32 ? " key32" : "", opt.accutile ? " accutile" : "",
              opt.folded ? " folded" : "", opt.fast_exp ? (" fast-exp(σ=" + tools::fixed(opt.fast_exp_sigma, 6) + ")").c_str() : "");
  std::printf("  time             %s s/frame (render), %s s total\n",
              tools::fixed(render_seconds / static_cast<double>(count), 3).c_str(),
              tools::fixed(tools::seconds_since(t_start), 2).c_str());
  return tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  CLI::App app{"Render a .rgs or PLY scene with the CPU reference renderer (docs/RENDERER.md) from an INRIA "
               "cameras.json or an orbit around the scene, writing one 8-bit PNG per view (3DGS rule "
               "floor(clamp(v,0,1)*255+0.5), no gamma) and optionally a float RGBA EXR.",
               kTool};
  app.add_option("scene", opt.input, "Scene: .rgs (dequantized) or 3DGS .ply")->required();
  auto* cams = app.add_option("--cameras", opt.cameras.cameras_path, "INRIA cameras.json");
  app.add_option("--every", opt.cameras.every, "Use every K-th camera of --cameras")
      ->check(CLI::PositiveNumber)->needs(cams);
  app.add_option("--limit", opt.cameras.limit, "Render at most N views")->check(CLI::PositiveNumber);
  auto* orbit = app.add_option("--orbit", opt.cameras.orbit, "Orbit of N cameras around the scene's bounding sphere "
                                                            "(default size 1920x1080)")
                    ->check(CLI::PositiveNumber)->excludes(cams);
  cams->excludes(orbit);
  app.add_option("-o,--output", opt.output_dir, "Output directory (created if missing)")->required();
  app.add_option("--width", opt.cameras.width, "Image width; the field of view is kept (height follows the aspect "
                                               "ratio if not given)")->check(CLI::Range(1, 32768));
  app.add_option("--height", opt.cameras.height, "Image height")->check(CLI::Range(1, 32768));
  app.add_option("--background", opt.background, "Background colour r,g,b (linear)")->capture_default_str();
  app.add_flag("--exr", opt.exr, "Also write <view>.exr (float RGBA: linear RGB not clamped, alpha = 1 - T)");
  app.add_option("--backend", opt.backend, "Renderer")->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.add_flag("--roofgs-key", opt.key32, "RoofGS: 32-bit sort keys with per-camera depth range");
  app.add_flag("--accutile", opt.accutile, "RoofGS: SnugBox + AccuTile tile sets");
  app.add_flag("--folded", opt.folded, "RoofGS: folded coefficients C1..C6 with the dual-pixel update");
  app.add_flag("--fast-exp", opt.fast_exp, "RoofGS: Schraudolph fast exp");
  app.add_option("--fast-exp-sigma", opt.fast_exp_sigma, "sigma of the fast exp")->capture_default_str();
  app.set_version_flag("--version", std::string(kTool) + " " + RGS_VERSION_STRING);
  try {
    app.parse(argc, argv);
    if (opt.cameras.cameras_path.empty() && opt.cameras.orbit == 0) {
      throw CLI::ValidationError("one of --cameras or --orbit is required");
    }
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? rgs::tools::kExitOk : rgs::tools::kExitUsage;
  }
  return run(opt);
}
