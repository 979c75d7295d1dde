// rgs-render: render a scene (.rgs or PLY) from its cameras or an orbit, with the CPU reference renderer or
// the CUDA renderer.
//
//   rgs-render scene.rgs --cameras cameras.json -o out/      one PNG per camera, named after img_name
//   rgs-render scene.ply --orbit 8 -o out/ --exr             orbit_000.png ... (+ float RGBA .exr)
//   rgs-render scene.rgs --orbit 8 -o out/ --backend cuda    the same on the GPU (baseline pipeline)
//   rgs-render scene.rgs --orbit 8 -o out/ --format ppm --pfm    no OpenImageIO needed (GPU-host builds)
//
// Exit status: 0 on success (every image written), 1 when loading, rendering or writing failed or the build
// lacks what was asked for (CUDA, OpenImageIO; message naming the cause; no image written or changed), 2 on a
// usage error, 128 + N on signal N. The images of a run are committed together (format::OutputSet).

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "cli_common.h"
#include "created_directory.h"
#include "image_write.h"
#include "rgs/config.h"
#include "rgs/format/file_io.h"
#include "rgs/runtime/cpu_renderer.h"
#include "scene_read_options.h"
#include "rgs/api/scene_loading.h"
#include "rgs/runtime/image_io.h"
#if RGS_HAS_CUDA
#include "rgs/api/gpu_scene_loading.h"
#include "rgs/runtime/gpu_renderer.h"
#endif

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
  std::string backend = "cpu";
  int device = 0;
  bool key32 = false, accutile = false, folded = false, fast_exp = false, half_blend = false;
  float fast_exp_sigma = kernels::kFastExpSigmaMinMax;

  bool any_roofgs() const { return key32 || accutile || folded || fast_exp || half_blend; }
  runtime::RoofgsOptions roofgs() const {
    runtime::RoofgsOptions r;
    r.key32 = key32;
    r.snugbox_accutile = accutile;
    r.folded_coefficients = folded;
    r.fast_exp = fast_exp;
    r.fast_exp_sigma = fast_exp_sigma;
    r.half_blend = half_blend;
    return r;
  }
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

/// One rendered view on the host, whatever the backend.
struct RenderedView {
  uint32_t width = 0, height = 0;
  std::vector<float> rgb;    ///< [H, W, 3] linear, not clamped
  std::vector<float> alpha;  ///< [H, W] 1 − T
  uint64_t pairs = 0;
  double render_ms = 0;  ///< CPU: wall time of render_cpu; CUDA: CUDA-event time of the frame
};

/// What a backend tells the summary about the scene it holds.
struct SceneSummary {
  uint64_t gaussians = 0;
  uint32_t sh_degree = 0;
  std::string source;  ///< ".rgs dequantized", "PLY", ".rgs on the GPU", ...
  format::SceneBounds bounds;
  std::vector<std::string> notes;  ///< what the reader noted (the SPZ axes assumed, ...)
};

/// A renderer behind rgs-render: loads the scene once, then renders views.
class Backend {
 public:
  virtual ~Backend() = default;
  virtual Status load(const std::string& path) = 0;
  virtual const SceneSummary& scene() const = 0;
  virtual Result<RenderedView> render(const runtime::Camera& camera) = 0;
  /// "cpu", "cpu key32 accutile", "cuda baseline", "cuda roofgs key32 ..."
  virtual std::string mode() const = 0;
  /// Unit of RenderedView::render_ms in the summary line ("render", "GPU").
  virtual const char* time_label() const = 0;
};

std::string technique_names(const runtime::RoofgsOptions& r) {
  std::string s;
  if (r.key32) s += " key32";
  if (r.snugbox_accutile) s += " accutile";
  if (r.folded_coefficients) s += " folded";
  if (r.fast_exp) s += " fast-exp(σ=" + tools::fixed(r.fast_exp_sigma, 6) + ")";
  if (r.half_blend && r.folded_coefficients && r.fast_exp) s += " half-blend";
  return s;
}

class CpuBackend final : public Backend {
 public:
  CpuBackend(const Options& opt, const std::array<float, 3>& background) {
    options_.background = background;
    options_.roofgs = opt.roofgs();
  }
  Status load(const std::string& path) override {
    RGS_ASSIGN_OR_RETURN(scene_, api::load_host_scene(path, tools::scene_read_options()));
    options_.scene_bounds = scene_.bounds;
    summary_ = {scene_.cloud.size(), scene_.cloud.sh_degree, scene_.is_rgs ? ".rgs dequantized" : scene_.description,
                scene_.bounds, scene_.notes};
    return Status::ok_status();
  }
  const SceneSummary& scene() const override { return summary_; }
  Result<RenderedView> render(const runtime::Camera& camera) override {
    const auto start = Clock::now();
    RGS_ASSIGN_OR_RETURN(runtime::RenderResult result, runtime::render_cpu(scene_.cloud, camera, options_));
    RenderedView view;
    view.render_ms = tools::seconds_since(start) * 1e3;
    view.width = result.width;
    view.height = result.height;
    view.rgb = std::move(result.rgb);
    view.alpha = std::move(result.alpha);
    view.pairs = result.stats.pairs;
    return view;
  }
  std::string mode() const override { return "cpu" + technique_names(options_.roofgs); }
  const char* time_label() const override { return "render"; }

 private:
  api::HostScene scene_;
  runtime::RenderOptions options_;
  SceneSummary summary_;
};

#if RGS_HAS_CUDA
class CudaBackend final : public Backend {
 public:
  CudaBackend(const Options& opt, const std::array<float, 3>& background) : device_(opt.device) {
    options_.background = background;
    options_.time_stages = true;  // per-view GPU time from CUDA events
    if (opt.any_roofgs()) {
      options_.pipeline = runtime::GpuPipeline::kRoofgs;
      options_.roofgs.techniques = opt.roofgs();
    }
  }
  Status load(const std::string& path) override {
    Status device = api::require_cuda_device(device_);
    if (!device.ok()) return device.prepend("--backend cuda");
    auto renderer = runtime::GpuRenderer::create();
    if (!renderer.ok()) return renderer.status();
    renderer_ = std::make_unique<runtime::GpuRenderer>(std::move(renderer).value());
    // The FP32 arrays of a .rgs scene only for the baseline pipeline: the RoofGS one reads the compact
    // sections. Other formats are uploaded as FP32 arrays (GpuScene::from_cloud) either way.
    runtime::GpuSceneOptions scene_options;
    scene_options.fp32_attributes = options_.pipeline == runtime::GpuPipeline::kBaseline;
    auto loaded = api::load_gpu_scene(path, scene_options, nullptr, tools::scene_read_options());
    if (!loaded.ok()) return loaded.status();
    scene_ = std::make_unique<api::LoadedGpuScene>(std::move(loaded).value());
    // Compact sections exist only for .rgs input; other formats render the RoofGS techniques from FP32 arrays.
    options_.roofgs.compact_attributes = scene_->scene.has_compact();
    summary_ = {scene_->scene.size(), scene_->scene.sh_degree(),
                scene_->is_rgs ? ".rgs on the GPU" : scene_->description + " on the GPU", scene_->bounds,
                scene_->notes};
    return Status::ok_status();
  }
  const SceneSummary& scene() const override { return summary_; }
  Result<RenderedView> render(const runtime::Camera& camera) override {
    RGS_ASSIGN_OR_RETURN(runtime::GpuRenderStats stats, renderer_->render(scene_->scene, camera, options_, &image_));
    RGS_ASSIGN_OR_RETURN(runtime::HostImage host, runtime::download(image_));
    RenderedView view;
    view.width = host.width;
    view.height = host.height;
    const size_t n = size_t{host.width} * host.height;
    view.rgb.resize(n * 3);
    view.alpha.resize(n);
    for (size_t i = 0; i < n; ++i) {
      view.rgb[i * 3 + 0] = host.rgba[i * 4 + 0];
      view.rgb[i * 3 + 1] = host.rgba[i * 4 + 1];
      view.rgb[i * 3 + 2] = host.rgba[i * 4 + 2];
      view.alpha[i] = host.rgba[i * 4 + 3];
    }
    view.pairs = stats.pairs;
    view.render_ms = stats.times.total_ms;
    return view;
  }
  std::string mode() const override {
    if (options_.pipeline == runtime::GpuPipeline::kBaseline) return "cuda baseline";
    return std::string("cuda roofgs") + (options_.roofgs.compact_attributes ? " compact" : "") +
           technique_names(options_.roofgs.techniques);
  }
  const char* time_label() const override { return "GPU"; }

 private:
  int device_ = 0;
  runtime::GpuRenderOptions options_;
  std::unique_ptr<runtime::GpuRenderer> renderer_;
  std::unique_ptr<api::LoadedGpuScene> scene_;
  runtime::DeviceImage image_;
  SceneSummary summary_;
};
#endif

/// The backend named by --backend, or why this build cannot give it.
Result<std::unique_ptr<Backend>> make_backend(const Options& opt, const std::array<float, 3>& background) {
  if (opt.backend == "cpu") return std::unique_ptr<Backend>(std::make_unique<CpuBackend>(opt, background));
#if RGS_HAS_CUDA
  if (opt.backend == "cuda") return std::unique_ptr<Backend>(std::make_unique<CudaBackend>(opt, background));
#else
  if (opt.backend == "cuda") {
    return Status(StatusCode::kUnsupportedFeature,
                  "--backend cuda: this build has no CUDA support (configured with RGS_WITH_CUDA=OFF or without "
                  "nvcc); use --backend cpu");
  }
#endif
  return Status(StatusCode::kInvalidArgument, "--backend: unknown backend '" + opt.backend + "'");
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

Status write_view(const Options& opt, const std::string& base, const RenderedView& view) {
  const std::vector<uint8_t> rgb8 = runtime::to_8bit(view.rgb);
  if (opt.image_format == "png") {
    RGS_RETURN_IF_ERROR(tools::write_png8(base + ".png", view.width, view.height, 3, rgb8));
  } else {
    RGS_RETURN_IF_ERROR(tools::write_netpbm8(base + ".ppm", view.width, view.height, 3, rgb8));
  }
  if (opt.exr) RGS_RETURN_IF_ERROR(tools::write_exr_rgba(base + ".exr", view.width, view.height, view.rgb, view.alpha));
  if (opt.pfm) RGS_RETURN_IF_ERROR(tools::write_pfm_rgb(base + ".pfm", view.width, view.height, view.rgb));
  return Status::ok_status();
}

std::string output_kinds(const Options& opt) {
  std::string s = opt.image_format == "png" ? "PNG" : "PPM";
  if (opt.exr) s += " + EXR";
  if (opt.pfm) s += " + PFM";
  return s;
}

int run(Options opt) {
  if (opt.image_format.empty()) opt.image_format = tools::have_openimageio() ? "png" : "ppm";
  auto background = parse_background(opt.background);
  if (!background.ok()) return tools::report_usage_error(kTool, background.status());
  Status supported = check_outputs(opt);
  if (!supported.ok()) return tools::report_error(kTool, supported);

  // Inputs are checked without blocking (a FIFO is refused at once) and declared, so that no image replaces
  // them. The output directory is removed again if the run fails after creating it (declared first, so it
  // is destroyed after the OutputSet has removed the temporaries).
  tools::CreatedDirectory created_directory;
  format::OutputSet outputs;
  for (const std::string& input : {opt.input, opt.cameras.cameras_path}) {
    if (input.empty()) continue;
    const bool scene = input == opt.input;  // a scene may be a SOG folder; the cameras are a file
    if (int code = tools::declare_input(kTool, outputs, input, scene); code != tools::kExitOk) return code;
  }

  auto backend_or = make_backend(opt, *background);
  if (!backend_or.ok()) return tools::report_error(kTool, backend_or.status());
  Backend& backend = **backend_or;

  const auto t_start = Clock::now();
  Status loaded = backend.load(opt.input);
  if (!loaded.ok()) return tools::report_error(kTool, loaded);
  const SceneSummary& scene = backend.scene();
  tools::report_notes(kTool, scene.notes);
  auto cameras = api::make_cameras(opt.cameras, scene.bounds);
  if (!cameras.ok()) return tools::report_error(kTool, cameras.status());
  if (cameras->empty()) {
    return tools::report_error(kTool, Status(StatusCode::kInvalidArgument, "no views selected"));
  }

  Status created = created_directory.create(opt.output_dir, "output directory");
  if (!created.ok()) return tools::report_error(kTool, created);
  // One file base per view; a camera name used twice gets its index, so that no view replaces another.
  const size_t count = cameras->size();
  std::vector<std::string> bases;
  for (size_t i = 0; i < count; ++i) {
    std::string name = api::file_safe_name((*cameras)[i].name, i);
    std::string base = (std::filesystem::path(opt.output_dir) / name).string();
    if (std::find(bases.begin(), bases.end(), base) != bases.end()) base += "_" + std::to_string(i);
    for (const std::string& file : view_files(opt, base)) {
      Status declared = outputs.add_output(file);
      if (!declared.ok()) {
        return declared.code() == StatusCode::kInvalidArgument ? tools::report_usage_error(kTool, declared)
                                                               : tools::report_error(kTool, declared);
      }
    }
    bases.push_back(base);
  }
  for (const std::string& note : outputs.remove_stale_temporaries()) tools::report_note(kTool, note);

  double render_ms = 0;
  uint64_t total_pairs = 0;
  for (size_t i = 0; i < count; ++i) {
    const runtime::Camera& cam = (*cameras)[i];
    auto view = backend.render(cam);
    if (!view.ok()) return tools::report_error(kTool, Status(view.status()).prepend(opt.input + ", view " + cam.name));
    render_ms += view->render_ms;
    total_pairs += view->pairs;
    Status s = write_view(opt, bases[i], *view);  // staged in `outputs`
    if (!s.ok()) return tools::report_error(kTool, s);
    std::fprintf(stderr, "view %zu/%zu %s %s ms (%s), %s pairs\n", i + 1, count, tools::escape_text(cam.name).c_str(),
                 tools::fixed(view->render_ms, view->render_ms < 100 ? 3 : 0).c_str(), backend.time_label(),
                 tools::group_digits(view->pairs).c_str());
  }

  const runtime::Camera& first = cameras->front();
  const double ms_per_frame = render_ms / static_cast<double>(count);
  std::printf("%s %s -> %s\n", kTool, tools::escape_text(opt.input).c_str(),
              tools::escape_text(opt.output_dir).c_str());
  std::printf("  views            %zu (%s, %s)\n", count, output_kinds(opt).c_str(),
              opt.cameras.cameras_path.empty() ? "orbit" : "cameras.json");
  std::printf("  resolution       %ux%u\n", first.width, first.height);
  std::printf("  gaussians        %s (SH degree %u, %s)\n", tools::group_digits(scene.gaussians).c_str(),
              scene.sh_degree, scene.source.c_str());
  std::printf("  mean pairs       %s\n", tools::group_digits(total_pairs / count).c_str());
  std::printf("  mode             %s\n", backend.mode().c_str());
  std::printf("  time             %s ms/frame (%s), %s s total\n",
              tools::fixed(ms_per_frame, ms_per_frame < 100 ? 3 : 0).c_str(), backend.time_label(),
              tools::fixed(tools::seconds_since(t_start), 2).c_str());
  // The report must have reached stdout before the images appear (a failed report leaves none).
  Status flushed = tools::flush_standard_streams();
  if (!flushed.ok()) return tools::report_error(kTool, flushed);
  Status committed = outputs.commit();
  if (!committed.ok()) return tools::report_error(kTool, committed);
  created_directory.keep();
  return tools::kExitOk;
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  const bool oiio = rgs::tools::have_openimageio();
  CLI::App app{std::string("Render a .rgs or PLY scene with the CPU reference renderer or the CUDA renderer "
                           "(docs/RENDERER.md) from an INRIA cameras.json or an orbit around the scene, writing one "
                           "8-bit image per view (3DGS rule floor(clamp(v,0,1)*255+0.5), no gamma) and optionally "
                           "float images. This build ") +
                   (oiio ? "writes PNG/EXR (OpenImageIO) and PPM/PFM." : "has no OpenImageIO: PPM/PFM only.") +
                   (RGS_HAS_CUDA ? " CUDA: yes." : " CUDA: no (--backend cpu only)."),
               kTool};
  app.add_option("scene", opt.input,
                 "Scene in any format, " + rgs::tools::scene_formats_help() +
                     ". cpu: read into host memory; cuda: a .rgs uploaded as stored, others as FP32 arrays")
      ->required();
  auto* cams = app.add_option("--cameras", opt.cameras.cameras_path, "INRIA cameras.json");
  app.add_option("--every", opt.cameras.every, "Use every K-th camera of --cameras")
      ->check(CLI::Range(1, 2147483647))->needs(cams);
  app.add_option("--limit", opt.cameras.limit, "Render at most N views")->check(CLI::Range(1, 2147483647));
  auto* orbit = app.add_option("--orbit", opt.cameras.orbit, "Orbit of N cameras around the scene's bounding sphere "
                                                            "(default size 1920x1080)")
                    ->check(CLI::Range(1, 100000))->excludes(cams);
  cams->excludes(orbit);
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
  app.add_option("--backend", opt.backend, "Renderer: cpu (reference) or cuda")
      ->check(CLI::IsMember({"cpu", "cuda"}))->capture_default_str();
  app.add_option("--device", opt.device, "CUDA device ordinal (--backend cuda)")->check(CLI::Range(0, 1023))
      ->capture_default_str();
  app.add_flag("--roofgs-key", opt.key32, "RoofGS: 32-bit sort keys with per-camera depth range");
  app.add_flag("--accutile", opt.accutile, "RoofGS: SnugBox + AccuTile tile sets");
  app.add_flag("--folded", opt.folded, "RoofGS: folded coefficients C1..C6 with the dual-pixel update");
  app.add_flag("--fast-exp", opt.fast_exp, "RoofGS: Schraudolph fast exp");
  app.add_option("--fast-exp-sigma", opt.fast_exp_sigma, "sigma of the fast exp")->capture_default_str();
  app.add_flag("--half-blend", opt.half_blend,
               "Blend in binary16, two pixels per half2 instruction on the GPU (beyond the paper; needs --folded and "
               "--fast-exp)");
  app.footer("With --backend cuda, any RoofGS flag selects the RoofGS pipeline with those techniques (compact "
             "attributes read on the GPU for .rgs input); without one, the 3DGS baseline pipeline.");
  app.set_version_flag("--version", std::string(kTool) + " " + RGS_VERSION_STRING);
  rgs::tools::add_scene_read_options(app);
  try {
    app.parse(argc, argv);
    if (opt.cameras.cameras_path.empty() && opt.cameras.orbit == 0) {
      throw CLI::ValidationError("one of --cameras or --orbit is required");
    }
    if (opt.half_blend && !(opt.folded && opt.fast_exp)) {
      throw CLI::ValidationError("--half-blend needs --folded and --fast-exp");
    }
  } catch (const CLI::ParseError& e) {
    return rgs::tools::finish(kTool, rgs::tools::exit_for_parse_error(app, e, kTool));
  }
  rgs::tools::install_interrupt_cleanup();
  return rgs::tools::finish(kTool, run(opt));
}
