// rgs-render: render a scene in any format from its cameras or an orbit through the front door (api::load,
// api::Renderer), on the CUDA renderer when a device answers, else the CPU reference renderer (--backend).
//
//   rgs-render scene.rgs --cameras cameras.json -o out/      one PNG per camera, named after img_name
//   rgs-render model/point_cloud/iteration_30000/point_cloud.ply -o out/    model/cameras.json, found beside it
//   rgs-render scene.ply --orbit 8 -o out/ --exr             orbit_000.png ... (+ float RGBA .exr), around the content
//   rgs-render scene.rgs --orbit 8 -o out/ --backend cpu     the CPU reference: the same images on every machine
//   rgs-render scene.rgs --orbit 8 -o out/ --format ppm --pfm    no OpenImageIO needed (GPU-host builds)
//   rgs-render scene_lod.rgs --path 60 -o out/ --backend cuda --splat-budget 1000000 --memory-budget 1GiB
//                                                            a level-of-detail .rgs under budgets (docs/LOD.md)
//
// Exit status: 0 on success (every image written), 1 when loading, rendering or writing failed or the build
// lacks what was asked for (CUDA, OpenImageIO; message naming the cause; no image written or changed), 2 on a
// usage error, 128 + N on signal N. The images of a run are committed together (format::OutputTransaction).

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "cli_common.h"
#include "image_write.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/config.h"
#include "rgs/runtime/image_io.h"

namespace {

using namespace rgs;
using Clock = std::chrono::steady_clock;
constexpr const char* kTool = "rgs-render";

struct Options {
  std::string input;
  std::string output_dir;
  api::CameraChoice cameras;
  std::string background = "0,0,0";
  std::string image_format;  ///< "png" or "ppm"; empty: png when the build has OpenImageIO, else ppm
  bool exr = false;
  bool pfm = false;
  tools::RenderOptions render;  ///< --backend (auto by default), --device, --preset, budgets
};

/// One rendered view on the host.
struct RenderedView {
  uint32_t width = 0, height = 0;
  std::vector<float> rgba;  ///< [H, W, 4] linear, not clamped; alpha 1 − T
  std::vector<float> rgb;   ///< [H, W, 3] the same colours
  api::FrameStats stats;    ///< pairs, and the level-of-detail counts of a level-of-detail scene
  double render_ms = 0;  ///< wall time of the render, to its completion on the device
};

/// The run's scene and renderer: the front door (api::load, api::Renderer) on the device --backend names.
struct View {
  api::Scene scene;
  api::Renderer renderer;
  api::RenderSettings settings;

  /// "cpu preset fastest", "cuda preset faithful", ...
  std::string mode() const {
    return std::string(api::device_name(scene.device())) + " preset " + api::preset_name(settings.preset);
  }

  Result<RenderedView> render(const runtime::Camera& camera) {
    const auto start = Clock::now();
    RGS_ASSIGN_OR_RETURN(api::Image image, renderer.render_image(scene, camera, settings));
    RGS_RETURN_IF_ERROR(image.synchronize());
    RenderedView view;
    view.render_ms = tools::seconds_since(start) * 1e3;
    view.stats = image.frame_stats();
    view.width = image.width();
    view.height = image.height();
    const size_t n = size_t{view.width} * view.height;
    view.rgba.resize(n * 4);
    RGS_RETURN_IF_ERROR(image.copy_to_host(view.rgba.data(), nullptr));
    view.rgb.resize(n * 3);
    for (size_t i = 0; i < n * 3; ++i) view.rgb[i] = view.rgba[i / 3 * 4 + i % 3];
    return view;
  }
};

/// Opens the renderer first (so that a missing device fails before any loading), then loads the scene with
/// what the settings read, as api::load does for every caller (a file other than .rgs quantized in memory
/// as rgs-convert writes it, so that a PLY and its .rgs give the same image), FP32 arrays on the GPU for the
/// faithful preset.
Result<View> open_view(const Options& opt, const std::array<float, 3>& background) {
  const tools::RenderOptions& render = opt.render;
  RGS_ASSIGN_OR_RETURN(const api::Device device, api::parse_device(render.backend));
  auto renderer = api::Renderer::create(device, render.device);
  if (!renderer.ok()) return Status(renderer.status()).prepend("--backend " + render.backend);
  api::RenderSettings settings;
  RGS_ASSIGN_OR_RETURN(settings.preset, api::parse_preset(render.preset));
  settings.background = background;
  settings.gpu_scratch_budget = render.scratch_budget;
  settings.lod_settle = true;  // each image shows its own selection (docs/LOD.md#a-frame-under-a-budget)
  api::LoadOptions load = tools::load_options(render, device);
  load.presets = {settings.preset};
  RGS_ASSIGN_OR_RETURN(api::Scene scene, api::load(opt.input, load));
  return View{std::move(scene), std::move(renderer).value(), settings};
}

/// Checks the requested image files against what this build can write, before any work is done.
Status check_outputs(const Options& opt) {
  if (tools::have_openimageio()) return Status::ok_status();
  const char* why = " needs OpenImageIO, and this build has none (RGS_WITH_OPENIMAGEIO=OFF); ";
  RGS_RETURN_ERROR_IF(opt.image_format == "png", StatusCode::kUnsupportedFeature,
                      std::string("--format png") + why + "use --format ppm");
  RGS_RETURN_ERROR_IF(opt.exr, StatusCode::kUnsupportedFeature, std::string("--exr") + why + "use --pfm");
  return Status::ok_status();
}

/// The files of one view: "<base>.png" or ".ppm", and ".exr", ".pfm" when asked for.
std::vector<std::string> view_files(const Options& opt, const std::string& base) {
  std::vector<std::string> files{base + (opt.image_format == "png" ? ".png" : ".ppm")};
  if (opt.exr) files.push_back(base + ".exr");
  if (opt.pfm) files.push_back(base + ".pfm");
  return files;
}

Status write_view(format::OutputTransaction& outputs, const Options& opt, const std::string& base, const RenderedView& view) {
  const std::string image8 = base + (opt.image_format == "png" ? ".png" : ".ppm");
  RGS_RETURN_IF_ERROR(tools::write_image8(outputs, image8, view.width, view.height, 3, runtime::to_8bit(view.rgb)));
  if (opt.exr) RGS_RETURN_IF_ERROR(tools::write_exr_rgba(outputs, base + ".exr", view.width, view.height, view.rgba));
  if (opt.pfm) RGS_RETURN_IF_ERROR(tools::write_pfm_rgb(outputs, base + ".pfm", view.width, view.height, view.rgb));
  return Status::ok_status();
}

/// The level-of-detail counts of a run's views, for the summary.
struct LodTotals {
  uint64_t splats = 0, max_splats = 0, bytes_streamed = 0, max_resident = 0;
  uint64_t chunks_drawn = 0, chunks_coarsened = 0, chunks_not_resident = 0;

  void add(const api::LodFrameCounts& c) {
    splats += c.splats;
    max_splats = std::max(max_splats, c.splats);
    bytes_streamed += c.bytes_streamed;
    max_resident = std::max(max_resident, c.bytes_resident);
    chunks_drawn += c.chunks_drawn;
    chunks_coarsened += c.chunks_coarsened;
    chunks_not_resident += c.chunks_not_resident;
  }
};

/// ", 123,456 splats, 40 chunks (12 coarser for the budget, 3 behind), 1,234,567 B streamed" for a view's line
/// (the CPU streams nothing: no "behind" and no bytes).
std::string lod_view_text(const api::LodFrameCounts& c, bool gpu) {
  std::string text = ", " + rgs::group_digits(c.splats) + " splats, " + std::to_string(c.chunks_drawn) +
                     " chunks (" + std::to_string(c.chunks_coarsened) + " coarser for the budget";
  if (!gpu) return text + ")";
  return text + ", " + std::to_string(c.chunks_not_resident) + " behind), " + rgs::group_digits(c.bytes_streamed) +
         " B streamed";
}

/// The summary lines of a level-of-detail scene: its index and budgets, and the views' counts.
std::string lod_summary(const api::SceneInfo& scene, const LodTotals& t, size_t views) {
  const api::SceneLodInfo& lod = scene.lod;
  const api::LodSettings& s = lod.settings;
  const bool gpu = scene.device == api::Device::kCuda;
  std::string text = "  level of detail  " + std::to_string(lod.chunks) + " chunks x " + std::to_string(lod.levels) +
                     " levels (" + rgs::group_digits(lod.stored_gaussians) + " Gaussians in all); budget " +
                     (s.splat_budget ? rgs::group_digits(s.splat_budget) : std::string("unlimited")) +
                     " splats, " + tools::fixed(s.pixel_error, 2) + " px of error";
  if (gpu) {
    text += ", " + (s.memory_budget ? rgs::group_digits(s.memory_budget) + " B" : std::string("unbounded")) +
            " of device memory (pool " + rgs::group_digits(lod.pool_bytes) + " B)";
  } else {
    text += ", every level in host memory";
  }
  text += "\n  splats           mean " + rgs::group_digits(t.splats / views) + ", max " +
          rgs::group_digits(t.max_splats) + " a view; chunks drawn " + rgs::group_digits(t.chunks_drawn) +
          ", coarser for the budget " + rgs::group_digits(t.chunks_coarsened);
  if (gpu) {
    text += ", behind (streaming) " + rgs::group_digits(t.chunks_not_resident) + "\n  streamed         " +
            rgs::group_digits(t.bytes_streamed) + " B in all, at most " + rgs::group_digits(t.max_resident) +
            " B resident";
  }
  return text + "\n";
}

std::string output_kinds(const Options& opt) {
  std::string s = opt.image_format == "png" ? "PNG" : "PPM";
  if (opt.exr) s += " + EXR";
  if (opt.pfm) s += " + PFM";
  return s;
}

int run(Options opt) {
  if (opt.image_format.empty()) opt.image_format = tools::have_openimageio() ? "png" : "ppm";
  auto background = tools::parse_background(opt.background);
  if (!background.ok()) return tools::report_usage_error(kTool, background.status());
  if (Status supported = check_outputs(opt); !supported.ok()) return tools::report_error(kTool, supported);

  if (opt.cameras.cameras_path.empty() && opt.cameras.orbit == 0 && opt.cameras.path == 0) {
    auto found = api::find_scene_cameras(opt.input);
    if (!found.ok()) return tools::report_error(kTool, found.status());
    if (found->empty()) {
      return tools::report_usage_error(kTool, Status(StatusCode::kInvalidArgument,
                                                     "one of --cameras, --orbit or --path is required: no "
                                                     "cameras.json beside " + opt.input));
    }
    opt.cameras.cameras_path = *found;
    tools::report_note(kTool, "views: the scene's own cameras, " + *found + " (found beside the scene)");
  }
  // Inputs are checked without blocking (a FIFO is refused at once) and declared, so that no image replaces
  // them. The output directory is removed again if the run fails after creating it.
  format::OutputTransaction outputs;
  if (int code = tools::declare_inputs(kTool, outputs, {opt.input}, opt.cameras.cameras_path); code != tools::kExitOk) {
    return code;
  }

  const auto t_start = Clock::now();
  auto opened = open_view(opt, *background);
  if (!opened.ok()) return tools::report_error(kTool, opened.status());
  View& view_door = *opened;
  const api::SceneInfo& scene = view_door.scene.info();
  tools::report_notes(kTool, scene.notes);
  auto cameras = api::make_cameras(opt.cameras, scene.content);
  if (!cameras.ok()) return tools::report_error(kTool, cameras.status());
  if (cameras->empty()) {
    return tools::report_error(kTool, Status(StatusCode::kInvalidArgument, "no views selected"));
  }

  if (Status created = outputs.create_folder(opt.output_dir); !created.ok()) return tools::report_error(kTool, created);
  // One file base per view (tools::file_safe_names: a camera name used twice gets its index, so that no view
  // replaces another).
  const size_t count = cameras->size();
  std::vector<std::string> bases;
  for (const runtime::Camera& camera : *cameras) bases.push_back(camera.name);
  bases = tools::file_safe_names(bases);
  for (std::string& base : bases) {
    base = (std::filesystem::path(opt.output_dir) / base).string();
    for (const std::string& file : view_files(opt, base)) {
      if (int code = tools::declare_output(kTool, outputs, file); code != tools::kExitOk) return code;
    }
  }
  tools::report_notes(kTool, outputs.remove_stale_temporaries());

  double render_ms = 0;
  uint64_t total_pairs = 0;
  LodTotals lod_totals;
  for (size_t i = 0; i < count; ++i) {
    const runtime::Camera& cam = (*cameras)[i];
    auto view = view_door.render(cam);
    if (!view.ok()) return tools::report_error(kTool, Status(view.status()).prepend(opt.input + ", view " + cam.name));
    render_ms += view->render_ms;
    total_pairs += view->stats.pairs;
    Status s = write_view(outputs, opt, bases[i], *view);
    if (!s.ok()) return tools::report_error(kTool, s);
    std::string lod_text;
    if (scene.lod.active) {
      lod_totals.add(view->stats.lod);
      lod_text = lod_view_text(view->stats.lod, scene.device == api::Device::kCuda);
    }
    std::fprintf(stderr, "view %zu/%zu %s %s ms (%s), %s pairs%s\n", i + 1, count,
                 tools::escape_text(cam.name).c_str(),
                 tools::fixed(view->render_ms, view->render_ms < 100 ? 3 : 0).c_str(), "render",
                 rgs::group_digits(view->stats.pairs).c_str(), lod_text.c_str());
  }

  const runtime::Camera& first = cameras->front();
  const double ms_per_frame = render_ms / static_cast<double>(count);
  std::printf("%s %s -> %s\n", kTool, tools::escape_text(opt.input).c_str(),
              tools::escape_text(opt.output_dir).c_str());
  std::printf("  views            %zu (%s, %s)\n", count, output_kinds(opt).c_str(),
              !opt.cameras.cameras_path.empty() ? "cameras.json" : opt.cameras.path > 0 ? "path" : "orbit");
  std::printf("  resolution       %ux%u\n", first.width, first.height);
  std::printf("  gaussians        %s (SH degree %u, %s%s)\n", rgs::group_digits(scene.gaussians).c_str(),
              scene.sh_degree, scene.description.c_str(), scene.device == api::Device::kCuda ? ", on the GPU" : "");
  std::printf("  mean pairs       %s\n", rgs::group_digits(total_pairs / count).c_str());
  if (scene.lod.active) {
    std::printf("%s", lod_summary(scene, lod_totals, count).c_str());
  } else if (scene.lod.levels > 0) {
    std::printf("  level of detail  off (--no-lod): the full detail of %u chunks x %u levels\n", scene.lod.chunks,
                scene.lod.levels);
  }
  std::printf("  mode             %s\n", view_door.mode().c_str());
  std::printf("  time             %s ms/frame (%s), %s s total\n",
              tools::fixed(ms_per_frame, ms_per_frame < 100 ? 3 : 0).c_str(), "render",
              tools::fixed(tools::seconds_since(t_start), 2).c_str());
  return tools::commit_outputs(kTool, outputs);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  const bool oiio = rgs::tools::have_openimageio();
  CLI::App app{std::string("Render a scene (.rgs, PLY, SOG, SPZ, GLB: any format rgs-convert reads) with the CPU "
                           "reference renderer or the CUDA renderer (docs/RENDERER.md) from an INRIA cameras.json or "
                           "an orbit around the scene, writing one 8-bit image per view (3DGS rule "
                           "floor(clamp(v,0,1)*255+0.5), no gamma) and optionally float images. This build ") +
                   (oiio ? "writes PNG/EXR (OpenImageIO) and PPM/PFM." : "has no OpenImageIO: PPM/PFM only.") +
                   (RGS_HAS_CUDA ? " CUDA: yes." : " CUDA: no (--backend cpu only)."),
               kTool};
  app.add_option("scene", opt.input,
                 "Scene in any format, " + rgs::tools::scene_formats_help() +
                     "; a file other than .rgs is quantized in memory as rgs-convert writes it, so it renders as its .rgs does")
      ->required();
  rgs::tools::add_camera_options(app, opt.cameras, "INRIA cameras.json", "Render at most N views",
                                 "Orbit of N cameras around the scene's content (centred and sized on where its Gaussians "
                                 "are, not on floaters; default size 1920x1080)");
  app.add_option("-o,--output", opt.output_dir, "Output directory (created if missing)")->required();
  app.add_option("--width", opt.cameras.width, "Image width; the field of view is kept (height follows the aspect "
                                               "ratio if not given)")->check(CLI::Range(1, 32768));
  app.add_option("--height", opt.cameras.height, "Image height")->check(CLI::Range(1, 32768));
  app.add_option("--background", opt.background, "Background colour r,g,b (linear)")->capture_default_str();
  app.add_option("--format", opt.image_format,
                 std::string("8-bit image format: png (needs OpenImageIO) or ppm (binary P6); default ") +
                     (oiio ? "png" : "ppm"))
      ->check(CLI::IsMember({"png", "ppm"}));
  app.add_flag("--exr", opt.exr, "Also write <view>.exr (float RGBA: linear RGB not clamped, alpha = 1 - T; needs "
                                 "OpenImageIO)");
  app.add_flag("--pfm", opt.pfm, "Also write <view>.pfm (float RGB PFM, linear, not clamped, no alpha)");
  rgs::tools::add_render_options(app, opt.render,
                                 rgs::tools::kBackendOption | rgs::tools::kPresetOption |
                                     rgs::tools::kScratchBudgetOption | rgs::tools::kLodOptions);
  rgs::tools::add_scene_read_options(app);
  if (auto code = rgs::tools::parse_command_line(app, argc, argv, kTool)) return *code;
  rgs::tools::install_interrupt_cleanup();
  return rgs::tools::finish(kTool, run(opt));
}
