// rgs-bench: per-stage GPU frame times of the CUDA renderer (CUDA events after warm-up, median of many frames
// over several camera views: CONTRIBUTING.md#timing). Built only with RGS_WITH_CUDA; never links OpenImageIO,
// so it runs on the GPU host.
//
//   rgs-bench scene.rgs --cameras cameras.json --every 8 --resolution 1080p --resolution 4k --json bench.json
//   rgs-bench scene.ply --orbit 16 --warmup 10 --repeat 50
//   rgs-bench scene.rgs --orbit 16 --mode faithful --mode roofgs --mode only-snugbox
//   rgs-bench daffodils.rgs --orbit 8 --replicate 4 --resolution 4k --mode faithful --mode roofgs
//   rgs-bench taebak.rgs --replicate 16 --path 120 --splat-budget 3000000 --memory-budget 3GiB --scratch-budget 1GiB
//
// For every mode and resolution: W warm-up frames, then R repetitions of every view (views in turn), each
// frame timed with CUDA events per stage (GpuRenderOptions::time_stages). Reported: the median over
// views × repetitions of each stage separately (so the stage medians need not add up to the total's), FPS =
// 1000 / median total, the mean (tile, Gaussian) pair count over views, with the device, scene, Gaussian
// count and date.
//
// Roofline (docs/lab/ROOFLINE.md): the device's memory and FP32 peaks are measured first in the same run
// (lab::measure_device_peaks: a 1 GiB device-to-device copy, an FMA loop), and every stage of every mode
// and resolution is placed against them with the analytic bytes and FLOPs of lab/roofline_model.h (mean over the
// views' pair counts) and the stage's median time: GB/s, GFLOP/s, FLOP/B, % of each peak, the bounding roof.
//
// --floor adds the true floor (docs/lab/ROOFLINE.md#the-true-floor): each view counted by the CPU reference
// (lab::census_frame) and, per stage, the time the work the image needs takes at the measured roofs.
//
// --replicate K tiles the scene K times (lab::replicate, lab::replicate_scene_file) before the
// upload, keeping compact attributes, so that multi-million-Gaussian scenes can be timed; orbit cameras frame
// the replicated bounds. Exit status: 0 ok, 1 failure (no device, scene, render), 2 usage error.

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <functional>
#include <limits>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "bench_lod.h"
#include "cli_common.h"
#include "internal_gpu_scene_loading.h"
#include "internal_load.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/api/camera.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/runtime/gpu_image_metrics.h"
#include "rgs/runtime/image_io.h"
#include "rgs/runtime/image_metrics.h"
#include "rgs/config.h"
#include "rgs/lab/bench_options.h"
#include "rgs/lab/device_peaks.h"
#include "rgs/lab/frame_census.h"
#include "rgs/lab/gpu_modes.h"
#include "rgs/lab/replicated_scene.h"
#include "rgs/lab/roofline_model.h"
#include "rgs/lab/technique_options.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/gpu_renderer.h"

namespace {

using namespace rgs;
using Clock = std::chrono::steady_clock;
constexpr const char* kTool = "rgs-bench";

// Modes: what is benchmarked, lab::gpu_modes() (new variants go there); lab::gpu_mode_options() turns one into
// GpuRenderOptions for a scene, or says why it cannot run on it.

/// The description of the mode called `name` (names are checked at parse time against the same list).
std::string mode_description(const std::string& name) {
  for (const lab::GpuMode& m : lab::gpu_modes()) {
    if (m.name == name) return m.description;
  }
  return "";
}

struct Options {
  std::string input;
  api::CameraChoice cameras;
  std::vector<std::string> resolutions;  ///< as given; parsed (and checked) at parse time
  std::vector<std::string> modes = {"faithful", "fastest"};
  uint32_t warmup = 5;
  uint32_t repeat = 20;
  uint32_t replicate = 1;
  std::string json_path;
  std::string save_lod_path;  ///< --save-lod
  bool front_door = false;
  bool quality = false;
  /// --reference: the scene --quality compares against (faithful's render of it); empty: the benched scene.
  std::string reference;
  bool floor = false;
  /// --device; --scratch-budget: GpuRenderOptions::scratch_budget of every mode (0: none).
  tools::RenderOptions render;
  /// Streamed mode (--splat-budget, --memory-budget): a level-of-detail scene under budgets (bench_lod.h).
  uint64_t splat_budget = 0;
  uint64_t memory_budget = 0;
  float pixel_error = runtime::LodBudget{}.pixel_error;
  uint64_t stream_bytes = runtime::LodStreamOptions{}.stream_bytes_per_frame;
  std::string lod_levels = "auto";
  bool streamed() const { return splat_budget > 0 || memory_budget > 0; }
};

constexpr int kStages = 5;
constexpr const char* kStageNames[kStages] = {"preprocess", "sort", "ranges", "render", "total"};
constexpr float runtime::StageTimes::*kStageTimes[kStages] = {
    &runtime::StageTimes::preprocess_ms, &runtime::StageTimes::sort_ms, &runtime::StageTimes::ranges_ms,
    &runtime::StageTimes::render_ms, &runtime::StageTimes::total_ms};

/// Median, mean, min and max of one stage's samples.
struct Summary {
  double median = 0, mean = 0, min = 0, max = 0;
};

Summary summarize(std::vector<float> v) {
  Summary s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  s.median = (n % 2 == 1) ? v[n / 2] : 0.5 * (double(v[n / 2 - 1]) + double(v[n / 2]));
  double sum = 0;
  for (float x : v) sum += x;
  s.mean = sum / double(n);
  s.min = v.front();
  s.max = v.back();
  return s;
}

nlohmann::json summary_json(const Summary& s) {
  return {{"median", s.median}, {"mean", s.mean}, {"min", s.min}, {"max", s.max}};
}

struct ViewResult {
  std::string name;
  uint32_t width = 0, height = 0;
  runtime::GpuRenderStats stats;        ///< of the last timed frame
  std::vector<float> samples[kStages];  ///< one per repetition
};

/// One mode at one resolution.
struct RunResult {
  std::string mode;
  runtime::GpuRenderOptions options;
  std::string resolution;  ///< "1920x1080", or "native" for cameras.json sizes
  std::vector<ViewResult> views;
  Summary stages[kStages];
  double fps = 0;
  double mean_pairs = 0;
  uint32_t max_tile_groups = 1;  ///< most groups of tile rows a view was rendered in (GpuRenderStats::tile_groups)
};

/// A group of cameras at one resolution.
struct CameraSet {
  std::string label;
  std::vector<runtime::Camera> cameras;
};

Result<std::vector<CameraSet>> make_camera_sets(const Options& opt, const format::SceneBounds& bounds) {
  // Orbits and paths on the bounding sphere, as the benchmark figures were measured (docs/BENCHMARKS.md).
  const api::ContentFrame sphere = api::ContentFrame::of_sphere(bounds);
  std::vector<lab::Resolution> sizes;
  for (const std::string& text : opt.resolutions) {
    RGS_ASSIGN_OR_RETURN(lab::Resolution r, lab::parse_resolution(text));
    sizes.push_back(r);
  }
  std::vector<CameraSet> sets;
  if (!opt.cameras.cameras_path.empty()) {
    RGS_ASSIGN_OR_RETURN(std::vector<runtime::Camera> native, api::make_cameras(opt.cameras, sphere));
    RGS_RETURN_ERROR_IF(native.empty(), StatusCode::kInvalidArgument,
                        opt.cameras.cameras_path + ": no views selected");
    if (sizes.empty()) {
      sets.push_back({"native", std::move(native)});
      return sets;
    }
    for (const lab::Resolution& r : sizes) {
      CameraSet set{lab::resolution_string(r), {}};
      for (const runtime::Camera& c : native) set.cameras.push_back(runtime::resize_camera(c, r.width, r.height));
      sets.push_back(std::move(set));
    }
    return sets;
  }
  if (sizes.empty()) sizes.push_back({opt.cameras.orbit_width, opt.cameras.orbit_height});
  for (const lab::Resolution& r : sizes) {
    api::CameraChoice choice = opt.cameras;
    choice.width = r.width;
    choice.height = r.height;
    RGS_ASSIGN_OR_RETURN(std::vector<runtime::Camera> cams, api::make_cameras(choice, sphere));
    sets.push_back({lab::resolution_string(r), std::move(cams)});
  }
  return sets;
}

/// Runs one mode over one camera set: warm-up, then `repeat` rounds over the views.
Result<RunResult> run_one(const Options& opt, const std::string& mode, const runtime::GpuRenderOptions& base_options,
                          const api::LoadedGpuScene& scene, const CameraSet& set, runtime::GpuRenderer& renderer,
                          runtime::DeviceImage& image) {
  runtime::GpuRenderOptions options = base_options;
  options.time_stages = true;
  options.scratch_budget = opt.render.scratch_budget;
  const size_t n = set.cameras.size();
  for (uint32_t i = 0; i < opt.warmup; ++i) {
    const runtime::Camera& cam = set.cameras[i % n];
    auto stats = renderer.render(scene.scene, cam, options, &image);
    if (!stats.ok()) return Status(stats.status()).prepend("warm-up, view " + cam.name);
  }
  RunResult run;
  run.mode = mode;
  run.options = base_options;
  run.resolution = set.label;
  for (const runtime::Camera& cam : set.cameras) run.views.push_back({cam.name, cam.width, cam.height, {}, {}});
  for (uint32_t r = 0; r < opt.repeat; ++r) {
    for (size_t v = 0; v < n; ++v) {
      const runtime::Camera& cam = set.cameras[v];
      auto stats = renderer.render(scene.scene, cam, options, &image);
      if (!stats.ok()) return Status(stats.status()).prepend("view " + cam.name);
      RGS_RETURN_ERROR_IF(!stats->timed, StatusCode::kCudaError, "view " + cam.name + ": the frame was not timed");
      ViewResult& vr = run.views[v];
      vr.stats = *stats;
      for (int s = 0; s < kStages; ++s) vr.samples[s].push_back(stats->times.*kStageTimes[s]);
    }
  }
  for (int s = 0; s < kStages; ++s) {
    std::vector<float> all;
    for (const ViewResult& vr : run.views) all.insert(all.end(), vr.samples[s].begin(), vr.samples[s].end());
    run.stages[s] = summarize(std::move(all));
  }
  for (const ViewResult& vr : run.views) {
    run.mean_pairs += double(vr.stats.pairs);
    run.max_tile_groups = std::max(run.max_tile_groups, vr.stats.tile_groups);
  }
  run.mean_pairs /= double(n);
  run.fps = run.stages[4].median > 0 ? 1000.0 / run.stages[4].median : 0.0;
  return run;
}

// Roofline: the model's bytes and FLOPs (lab/roofline_model.h) per stage, against the measured peaks.

/// The model's inputs for one view of a run. The renderer does not report how many Gaussians survive
/// culling, so `visible` is N (an upper bound, docs/lab/ROOFLINE.md).
lab::FrameWorkInputs work_inputs(const runtime::GpuRenderOptions& o, const runtime::GpuScene& scene,
                                   const ViewResult& v) {
  lab::FrameWorkInputs in;
  const runtime::GpuTechniques t = lab::planned_techniques(o, scene.has_compact());
  in.roofgs = t.pipeline == runtime::GpuPipeline::kRoofgs;
  if (in.roofgs) {
    in.compact = t.roofgs.compact_attributes;
    in.dc_residual = scene.has_compact() && scene.compact().sh_dc_residual != nullptr;
    in.fused = t.roofgs.fused_preprocess;
    in.key32 = t.roofgs.techniques.key32;
    in.snugbox = t.roofgs.techniques.snugbox_accutile;
    in.folded = t.roofgs.techniques.folded_coefficients;
    in.fast_exp = t.roofgs.techniques.fast_exp;
    in.depth_order = t.roofgs.techniques.depth_order;
  }
  in.depth_plane = false;  // rgs-bench's DeviceImage has no depth plane
  in.gaussians = scene.size();
  in.visible = scene.size();
  in.large_chunks = v.stats.large_chunks;
  in.sh_degree = scene.sh_degree();
  in.pairs = v.stats.pairs;
  in.sort_bits = v.stats.sort_bits;
  in.tiles = uint64_t(v.stats.tiles_x) * v.stats.tiles_y;
  in.pixels = uint64_t(v.width) * v.height;
  return in;
}

/// One run on the roofline: the model's work per frame (mean over views) and each stage's point.
struct RunRoofline {
  lab::FrameWorkInputs inputs;  ///< of the first view (for the JSON; mean_pairs is over all views)
  double mean_pairs = 0;
  lab::StageWork work[lab::kRooflineStages];
  lab::RooflinePoint points[lab::kRooflineStages];
};

RunRoofline roofline_of(const RunResult& r, const runtime::GpuScene& scene, const lab::RooflinePeaks& peaks) {
  RunRoofline out;
  for (const ViewResult& v : r.views) {
    const lab::FrameWork w = lab::frame_work(work_inputs(r.options, scene, v));
    for (int s = 0; s < lab::kRooflineStages; ++s) {
      out.work[s].bytes += w.stages[s].bytes / double(r.views.size());
      out.work[s].flops += w.stages[s].flops / double(r.views.size());
    }
  }
  if (!r.views.empty()) out.inputs = work_inputs(r.options, scene, r.views.front());
  out.mean_pairs = r.mean_pairs;
  for (int s = 0; s < lab::kRooflineStages; ++s) {
    out.points[s] = lab::roofline_point(out.work[s], r.stages[s].median, peaks);
  }
  return out;
}

nlohmann::json peaks_json(const lab::DevicePeaks& p) {
  return {{"memory",
           {{"method", "cudaMemcpyAsync device to device, CUDA events, median; bytes = read + write"},
            {"copy_bytes", p.copy_bytes},
            {"samples_ms", p.copy_ms},
            {"median_ms", p.copy_median_ms},
            {"gbps", p.memory_gbps}}},
          {"compute",
           {{"method", "FP32 FMA loop (lab/src/peak_kernels.cu), 2 FLOPs per FMA, CUDA events, median"},
            {"blocks", p.fma_blocks},
            {"blocks_per_sm", p.fma_blocks_per_sm},
            {"threads_per_block", p.fma_threads_per_block},
            {"iterations", p.fma_iterations},
            {"chains_per_thread", p.fma_chains_per_thread},
            {"flops_per_launch", p.fma_flops},
            {"samples_ms", p.fma_ms},
            {"median_ms", p.fma_median_ms},
            {"gflops", p.fp32_gflops}}},
          {"half2",
           {{"method", "the FMA loop on half2 pairs (__hfma2), 4 FLOPs per instruction, same grid, median"},
            {"flops_per_launch", p.hfma2_flops},
            {"samples_ms", p.hfma2_ms},
            {"median_ms", p.hfma2_median_ms},
            {"gflops", p.half_gflops}}},
          {"ridge_flop_per_byte", p.ridge_flop_per_byte()}};
}

nlohmann::json roofline_json(const RunRoofline& rl) {
  const lab::FrameWorkInputs& in = rl.inputs;
  nlohmann::json inputs = {{"pipeline", in.roofgs ? "roofgs" : "baseline"},
                           {"attributes", in.compact ? "compact" : "fp32"},
                           {"fused", in.fused},
                           {"key_bits", in.roofgs && in.key32 ? 32 : 64},
                           {"snugbox_accutile", in.snugbox},
                           {"folded", in.folded},
                           {"fast_exp", in.fast_exp},
                           {"depth_order", in.depth_order},
                           {"depth_plane", in.depth_plane},
                           {"gaussians", in.gaussians},
                           {"visible_assumed", in.visible},
                           {"large_chunks", in.large_chunks},
                           {"sh_degree", in.sh_degree},
                           {"mean_pairs", rl.mean_pairs},
                           {"sort_bits", in.sort_bits},
                           {"radix_passes", lab::radix_passes(in.sort_bits)},
                           {"tiles", in.tiles},
                           {"pixels", in.pixels}};
  nlohmann::json stages;
  for (int s = 0; s < lab::kRooflineStages; ++s) {
    const lab::RooflinePoint& p = rl.points[s];
    stages[lab::roofline_stage_name(lab::RooflineStage(s))] = {
        {"median_ms", p.ms},          {"bytes", p.bytes},
        {"flops", p.flops},           {"gbps", p.gbps},
        {"gflops", p.gflops},         {"flop_per_byte", p.intensity},
        {"pct_memory_peak", p.pct_bandwidth}, {"pct_compute_peak", p.pct_compute},
        {"bound", p.bound},           {"attainable_gflops", p.attainable_gflops},
        {"pct_of_roof", p.pct_of_roof}, {"floor_ms", p.floor_ms},
        {"times_floor", p.times_floor}};
  }
  return {{"model", "docs/lab/ROOFLINE.md: bytes requested from global memory and FP32 FLOPs per frame (mean over "
                    "views), visible = all Gaussians, render FLOPs without early termination (upper bounds)"},
          {"inputs", inputs},
          {"stages", stages}};
}


/// One way of rendering a frame for the front-door comparison: ms per frame, host wall clock from the call to
/// the device's completion (each path waits once per frame for its pair count anyway).
struct FrontDoorRow {
  std::string path;
  std::string resolution;
  double median_ms = 0;
};

/// Quality of one mode at one resolution against the baseline render of the same scene and views.
struct QualityRow {
  std::string mode;
  std::string resolution;
  double psnr_mean = 0, psnr_min = 0;  ///< dB over the clamped RGB of each view (+inf when equal)
  /// dB over the 8-bit images of each view (rgs-render's rule, runtime::to_8bit): what a viewer or a PNG shows
  double psnr8_mean = 0, psnr8_min = 0;
  double ssim_mean = 0;
  float max_abs_diff = 0;  ///< largest over the views
  size_t views = 0;
};

/// PSNR in dB of the 8-bit images (runtime::to_8bit) of two RGBA images of one size (runtime::psnr_rgb of the
/// levels / 255); +inf when they are equal.
Result<double> psnr_8bit(const runtime::HostImage& a, const runtime::HostImage& b) {
  const auto levels = [](const runtime::HostImage& image) {
    const std::vector<uint8_t> rgba8 = runtime::to_8bit(image.rgba);
    std::vector<float> rgb;
    rgb.reserve(rgba8.size() / 4 * 3);
    for (size_t i = 0; i < rgba8.size(); ++i) {
      if (i % 4 != 3) rgb.push_back(float(rgba8[i]) / 255.f);
    }
    return rgb;
  };
  return runtime::psnr_rgb(levels(a), levels(b), a.width, a.height);
}

/// --quality: every view of every camera set rendered once by the baseline and once by each other mode,
/// compared on the GPU (runtime::GpuImageComparer: PSNR, SSIM and max |Δ| of the clamped RGB, the audit's
/// definitions), and their 8-bit images on the host. The baseline renders `reference` (the benched scene, or
/// --reference: e.g. the source the .rgs was converted from, so that faithful's own row is what the conversion
/// costs) and reads its FP32 arrays.
Result<std::vector<QualityRow>> measure_quality(const Options& opt, const api::LoadedGpuScene& scene,
                                                const api::LoadedGpuScene& reference_scene,
                                                const std::vector<CameraSet>& sets, runtime::GpuRenderer& renderer) {
  RGS_ASSIGN_OR_RETURN(const runtime::GpuRenderOptions reference,
                       lab::gpu_mode_options("faithful", reference_scene.scene.has_compact()));
  std::vector<QualityRow> rows;
  runtime::GpuImageComparer comparer;
  runtime::DeviceImage expected, image;
  for (const std::string& mode_name : opt.modes) {
    if (mode_name == "faithful" && opt.reference.empty()) continue;
    RGS_ASSIGN_OR_RETURN(const runtime::GpuRenderOptions options,
                         lab::gpu_mode_options(mode_name, scene.scene.has_compact()));
    for (const CameraSet& set : sets) {
      QualityRow row;
      row.mode = mode_name;
      row.resolution = set.label;
      row.psnr_min = row.psnr8_min = std::numeric_limits<double>::infinity();
      for (const runtime::Camera& cam : set.cameras) {
        auto base = renderer.render(reference_scene.scene, cam, reference, &expected);
        if (!base.ok()) return Status(base.status()).prepend("faithful, view " + cam.name);
        auto frame = renderer.render(scene.scene, cam, options, &image);
        if (!frame.ok()) return Status(frame.status()).prepend(mode_name + ", view " + cam.name);
        RGS_ASSIGN_OR_RETURN(const runtime::ImageMetrics m,
                             comparer.compare(expected.rgba(), image.rgba(), cam.width, cam.height, 4));
        row.psnr_mean += m.psnr_db;
        row.psnr_min = std::min(row.psnr_min, m.psnr_db);
        RGS_ASSIGN_OR_RETURN(const runtime::HostImage expected8, runtime::download(expected));
        RGS_ASSIGN_OR_RETURN(const runtime::HostImage image8, runtime::download(image));
        RGS_ASSIGN_OR_RETURN(const double psnr8, psnr_8bit(expected8, image8));
        row.psnr8_mean += psnr8;
        row.psnr8_min = std::min(row.psnr8_min, psnr8);
        row.ssim_mean += m.ssim;
        row.max_abs_diff = std::max(row.max_abs_diff, m.max_abs_diff);
        ++row.views;
      }
      if (row.views > 0) {
        row.psnr_mean /= double(row.views);
        row.psnr8_mean /= double(row.views);
        row.ssim_mean /= double(row.views);
      }
      rows.push_back(row);
    }
  }
  return rows;
}

/// The front door (api::Renderer, preset fastest, into a caller buffer on the caller's stream) against the
/// expert path (runtime::GpuRenderer with fastest's options into its own DeviceImage), the same views and
/// frames, interleaved per frame so that clocks and caches treat both alike.
Result<std::vector<FrontDoorRow>> compare_front_door(const Options& opt, const api::LoadedGpuScene& expert_scene,
                                                      const std::vector<CameraSet>& sets,
                                                      runtime::GpuRenderer& renderer) {
  api::LoadOptions load = tools::load_options(opt.render, api::Device::kCuda);
  load.presets = {api::Preset::kFastest};
  load.lod.enabled = false;  // the expert path renders a level-of-detail file's full detail too
  RGS_ASSIGN_OR_RETURN(api::Scene scene, api::load(opt.input, load));
  RGS_ASSIGN_OR_RETURN(api::Renderer front, api::Renderer::create(api::Device::kCuda, opt.render.device));
  RGS_ASSIGN_OR_RETURN(runtime::GpuRenderOptions expert_options,
                       lab::gpu_mode_options("fastest", expert_scene.scene.has_compact()));
  std::vector<FrontDoorRow> rows;
  runtime::DeviceImage image;
  for (const CameraSet& set : sets) {
    const runtime::Camera& first = set.cameras.front();
    runtime::DeviceBuffer<uint8_t> buffer;
    RGS_RETURN_IF_ERROR(buffer.reserve(size_t(first.width) * first.height * 16, "front-door target"));
    const api::PixelFormat formats[2] = {api::PixelFormat::kRgba32f, api::PixelFormat::kRgba8};
    std::vector<float> samples[3];
    for (uint32_t round = 0; round < opt.warmup + opt.repeat; ++round) {
      for (const runtime::Camera& cam : set.cameras) {
        for (int path = 0; path < 3; ++path) {
          const auto t0 = std::chrono::steady_clock::now();
          if (path == 0) {
            RGS_RETURN_IF_ERROR(renderer.render(expert_scene.scene, cam, expert_options, &image).status());
          } else {
            api::ImageTarget target;
            target.width = cam.width;
            target.height = cam.height;
            target.format = formats[path - 1];
            target.color = buffer.data();
            target.color_pitch = size_t(cam.width) * api::bytes_per_pixel(target.format);
            RGS_RETURN_IF_ERROR(front.render(scene, cam, api::RenderSettings{}, target, nullptr).status());
          }
          const cudaError_t synced = cudaDeviceSynchronize();
          RGS_RETURN_ERROR_IF(synced != cudaSuccess, StatusCode::kCudaError,
                              std::string("cudaDeviceSynchronize: ") + cudaGetErrorString(synced));
          const float ms = float(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                                     .count());
          if (round >= opt.warmup) samples[path].push_back(ms);
        }
      }
    }
    const char* names[3] = {"GpuRenderer fastest (own image)", "api fastest, caller RGBA32F",
                            "api fastest, caller RGBA8"};
    for (int path = 0; path < 3; ++path) rows.push_back({names[path], set.label, summarize(samples[path]).median});
  }
  return rows;
}

/// --floor: every view of one camera set counted by the CPU reference, and the floor's work per frame.
struct FloorSet {
  std::string resolution;
  std::vector<std::string> view_names;
  std::vector<lab::FrameCensus> census;          ///< per view
  lab::StageWork work[lab::kRooflineStages];  ///< lab::floor_work, mean over the views
};

Result<std::vector<FloorSet>> count_floor(const Options& opt, const std::vector<CameraSet>& sets) {
  RGS_ASSIGN_OR_RETURN(const converter::InputScene host, converter::read_scene(opt.input, tools::scene_read_options()));
  std::vector<FloorSet> out;
  for (const CameraSet& set : sets) {
    FloorSet f;
    f.resolution = set.label;
    const double n = double(set.cameras.size());
    for (const runtime::Camera& cam : set.cameras) {
      std::fprintf(stderr, "floor %s: counting view %s on the CPU ...\n", set.label.c_str(), cam.name.c_str());
      auto census = lab::census_frame(host.cloud, cam);
      if (!census.ok()) return Status(census.status()).prepend("view " + cam.name);
      const lab::FrameWork w = lab::floor_work(*census, host.cloud.sh_degree);
      for (int s = 0; s < lab::kRooflineStages; ++s) {
        f.work[s].bytes += w.stages[s].bytes / n;
        f.work[s].flops += w.stages[s].flops / n;
        f.work[s].half_flops += w.stages[s].half_flops / n;
      }
      f.view_names.push_back(cam.name);
      f.census.push_back(*census);
    }
    out.push_back(std::move(f));
  }
  return out;
}

/// The floor of each stage of run `r` (0 where --floor was not given).
std::vector<lab::RooflinePoint> floor_points(const RunResult& r, const std::vector<FloorSet>& floors,
                                                 const lab::RooflinePeaks& peaks) {
  for (const FloorSet& f : floors) {
    if (f.resolution != r.resolution) continue;
    std::vector<lab::RooflinePoint> points;
    for (int s = 0; s < lab::kRooflineStages; ++s) {
      points.push_back(lab::roofline_point(f.work[s], r.stages[s].median, peaks));
    }
    return points;
  }
  return {};
}

/// Smallest and largest of the views' median totals: how much the frame time moves from view to view.
std::pair<double, double> view_spread(const RunResult& r) {
  double lo = std::numeric_limits<double>::infinity(), hi = 0;
  for (const ViewResult& v : r.views) {
    const double m = summarize(v.samples[4]).median;
    lo = std::min(lo, m);
    hi = std::max(hi, m);
  }
  return {r.views.empty() ? 0.0 : lo, hi};
}

/// Loads `path` onto the current device: a .rgs file's sections as stored (api::upload_rgs_file), any other
/// format converter::read_scene detects as FP32 arrays (GpuScene::from_cloud). Errors name `path`.
Result<api::LoadedGpuScene> load_gpu_scene(const std::string& path, const runtime::GpuSceneOptions& options) {
  const converter::SceneReadOptions& read_options = tools::scene_read_options();
  if (format::is_rgs_path(path)) {
    RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(path, converter::rgs_read_options(read_options)));
    return api::upload_rgs_file(file, file.file_size(), path, options);
  }
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(path, read_options));
  auto scene = runtime::GpuScene::from_cloud(input.cloud, input.bounds);
  if (!scene.ok()) return rgs::naming(scene.status(), path);
  return api::LoadedGpuScene{std::move(scene).value(), input.bounds, false, input.file_bytes, input.description,
                             std::move(input.notes)};
}

/// Loads the scene: as stored, or tiled opt.replicate times (host work done before, in `replicated`), uploaded
/// from the bytes of its .rgs file. The FP32 arrays are kept on the device only when `fp32` (a mode that reads
/// them was asked for).
Result<api::LoadedGpuScene> load_bench_scene(const Options& opt, lab::ReplicatedScene* replicated, bool fp32) {
  runtime::GpuSceneOptions scene_options;
  scene_options.fp32_attributes = fp32;
  if (opt.replicate <= 1) return load_gpu_scene(opt.input, scene_options);
  const std::string name = opt.input + " x" + std::to_string(opt.replicate);
  const std::vector<uint8_t>& bytes = replicated->rgs_bytes;
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::from_bytes(bytes.data(), bytes.size(), {}, name));
  auto scene = api::upload_rgs_file(file, replicated->source_file_bytes, name, scene_options);
  replicated->rgs_bytes = std::vector<uint8_t>();  // uploaded: free the host copy
  return scene;
}

/// What a run measured, for the table and the JSON.
struct BenchReport {
  runtime::CudaDeviceInfo device;
  lab::DevicePeaks peaks;
  std::string date;
  double load_ms = 0;
  /// Per-frame device buffers: the renderer's scratch (pairs, keys, sort and scan storage, ranges,
  /// per-Gaussian projections), grown to the largest frame of the run, and the output image.
  uint64_t scratch_bytes = 0, image_bytes = 0;
  size_t view_count = 0;
  std::vector<RunResult> results;
  std::vector<RunRoofline> rooflines;
  std::vector<QualityRow> quality;
  std::vector<FrontDoorRow> front_door;
  std::vector<FloorSet> floors;
  lab::RooflinePeaks roofs;
};

/// The tables on stdout: scene, stage times, roofline, quality, front door.
void print_report(const Options& opt, const api::LoadedGpuScene& scene, const lab::ReplicatedScene& replicated,
                  const BenchReport& report) {
  std::printf("%s %s\n", kTool, opt.input.c_str());
  std::printf("  device           %s (sm_%d%d, %d SMs), %s\n", report.device.name.c_str(), report.device.compute_major,
              report.device.compute_minor, report.device.multiprocessors, report.date.c_str());
  if (opt.replicate > 1) {
    std::printf("  gaussians        %s = %u copies of %s (SH degree %u, %s source, %s MB on the device)\n",
                rgs::group_digits(scene.scene.size()).c_str(), opt.replicate,
                rgs::group_digits(replicated.source_gaussians).c_str(), scene.scene.sh_degree(),
                replicated.source_is_rgs ? ".rgs" : "PLY",
                tools::fixed(double(scene.scene.device_bytes()) / 1e6, 1).c_str());
    std::printf("  replicated       %s\n", replicated.quantization.c_str());
    std::printf("  load             %s ms (upload of the replicated scene, built on the host before)\n",
                tools::fixed(report.load_ms, 1).c_str());
  } else {
    std::printf("  gaussians        %s (SH degree %u, %s, %s MB on the device)\n",
                rgs::group_digits(scene.scene.size()).c_str(), scene.scene.sh_degree(),
                scene.is_rgs ? ".rgs" : "PLY", tools::fixed(double(scene.scene.device_bytes()) / 1e6, 1).c_str());
    std::printf("  load             %s ms (file of %s bytes: read, decode, upload)\n",
                tools::fixed(report.load_ms, 1).c_str(), rgs::group_digits(scene.file_bytes).c_str());
  }
  std::printf("  frame buffers    %s MB renderer scratch (grown to the run's largest frame%s) + %s MB image\n",
              tools::fixed(double(report.scratch_bytes) / 1e6, 1).c_str(),
              opt.render.scratch_budget == 0
                  ? ""
                  : (", budget " + tools::fixed(double(opt.render.scratch_budget) / 1e6, 1) + " MB").c_str(),
              tools::fixed(double(report.image_bytes) / 1e6, 1).c_str());
  std::printf("  views            %zu (%s), %u warm-up frames, %u repetitions; medians in ms\n", report.view_count,
              !opt.cameras.cameras_path.empty() ? "cameras.json" : opt.cameras.path > 0 ? "path" : "orbit",
              opt.warmup, opt.repeat);
  std::printf("  %-12s %-10s %10s %8s %8s %8s %8s %15s %8s %14s %6s\n", "mode", "resolution", "preprocess", "sort",
              "ranges", "render", "total", "views min-max", "FPS", "mean pairs", "groups");
  for (const RunResult& r : report.results) {
    const auto [lo, hi] = view_spread(r);
    std::printf("  %-12s %-10s %10s %8s %8s %8s %8s %15s %8s %14s %6u\n", r.mode.c_str(), r.resolution.c_str(),
                tools::fixed(r.stages[0].median, 3).c_str(), tools::fixed(r.stages[1].median, 3).c_str(),
                tools::fixed(r.stages[2].median, 3).c_str(), tools::fixed(r.stages[3].median, 3).c_str(),
                tools::fixed(r.stages[4].median, 3).c_str(),
                (tools::fixed(lo, 3) + "-" + tools::fixed(hi, 3)).c_str(), tools::fixed(r.fps, 1).c_str(),
                rgs::group_digits(static_cast<uint64_t>(r.mean_pairs + 0.5)).c_str(), r.max_tile_groups);
  }

  std::printf("  peaks            memory %s GB/s (device-to-device copy of %s MiB, read + write, median of %zu); "
              "FP32 %s GFLOP/s (FMA loop, median of %zu); half2 %s GFLOP/s; ridge %s FLOP/B\n",
              tools::fixed(report.peaks.memory_gbps, 1).c_str(), rgs::group_digits(report.peaks.copy_bytes >> 20).c_str(),
              report.peaks.copy_ms.size(), tools::fixed(report.peaks.fp32_gflops, 0).c_str(), report.peaks.fma_ms.size(),
              tools::fixed(report.peaks.half_gflops, 0).c_str(), tools::fixed(report.peaks.ridge_flop_per_byte(), 2).c_str());
  std::printf("  roofline         model: docs/lab/ROOFLINE.md (requested bytes and FP32 FLOPs per frame, upper bounds)\n");
  std::printf("  %-12s %-10s %-10s %8s %8s %7s %10s %10s %9s %9s %8s %6s %6s %-7s\n", "mode", "resolution", "stage",
              "ms", "floor ms", "x floor", "MB", "MFLOP", "GB/s", "GFLOP/s", "FLOP/B", "%BW", "%FP32", "bound");
  for (size_t i = 0; i < report.results.size(); ++i) {
    for (int s = 0; s < lab::kRooflineStages; ++s) {
      const lab::RooflinePoint& p = report.rooflines[i].points[s];
      std::printf("  %-12s %-10s %-10s %8s %8s %7s %10s %10s %9s %9s %8s %6s %6s %-7s\n", report.results[i].mode.c_str(),
                  report.results[i].resolution.c_str(), lab::roofline_stage_name(lab::RooflineStage(s)),
                  tools::fixed(p.ms, 3).c_str(), tools::fixed(p.floor_ms, 3).c_str(),
                  tools::fixed(p.times_floor, 1).c_str(), tools::fixed(p.bytes / 1e6, 2).c_str(),
                  tools::fixed(p.flops / 1e6, 1).c_str(), tools::fixed(p.gbps, 1).c_str(),
                  tools::fixed(p.gflops, 1).c_str(), tools::fixed(p.intensity, 2).c_str(),
                  tools::fixed(p.pct_bandwidth, 1).c_str(), tools::fixed(p.pct_compute, 1).c_str(), p.bound);
    }
  }

  if (!report.floors.empty()) {
    std::printf("  true floor       the work the image needs at the measured roofs (docs/lab/ROOFLINE.md#the-true-floor); "
                "per frame, mean over the views\n");
    std::printf("  %-10s %10s %10s %13s %13s %13s %13s %13s %13s %12s %12s\n", "resolution", "blended/px",
                "skipped/px", "contributing", "3DGS pairs", "pairs 16x16", "pairs 8x8", "pairs 4x4", "reach 16x16",
                "hidden 3DGS", "hidden reach");
    for (const FloorSet& f : report.floors) {
      double blended = 0, skipped = 0, pixels = 0, contributing = 0, rect = 0, p16 = 0, p8 = 0, p4 = 0, reach = 0;
      double hidden_rect = 0, hidden_reach = 0;
      for (const lab::FrameCensus& c : f.census) {
        blended += double(c.blended);
        skipped += double(c.skipped);
        pixels += double(c.pixels());
        contributing += double(c.contributing);
        rect += double(c.rect_pairs);
        p16 += double(c.blending_pairs[0]);
        p8 += double(c.blending_pairs[1]);
        p4 += double(c.blending_pairs[2]);
        reach += double(c.reaching_pairs[0]);
        hidden_rect += double(c.hidden_rect_pairs);
        hidden_reach += double(c.hidden_reaching_pairs);
      }
      const auto share = [](double part, double whole) { return tools::fixed(whole > 0 ? 100 * part / whole : 0, 1) + " %"; };
      const double n = double(std::max<size_t>(f.census.size(), 1));
      const auto count = [&](double v) { return rgs::group_digits(uint64_t(v / n + 0.5)); };
      std::printf("  %-10s %10s %10s %13s %13s %13s %13s %13s %13s %12s %12s\n", f.resolution.c_str(),
                  tools::fixed(blended / pixels, 2).c_str(), tools::fixed(skipped / pixels, 2).c_str(),
                  count(contributing).c_str(), count(rect).c_str(), count(p16).c_str(), count(p8).c_str(),
                  count(p4).c_str(), count(reach).c_str(), share(hidden_rect, rect).c_str(),
                  share(hidden_reach, reach).c_str());
    }
    std::printf("  %-12s %-10s %-10s %8s %9s %8s\n", "mode", "resolution", "stage", "ms", "floor ms", "x floor");
    for (const RunResult& r : report.results) {
      const std::vector<lab::RooflinePoint> points = floor_points(r, report.floors, report.roofs);
      double floor_total = 0;
      for (int s = 0; s < int(points.size()); ++s) {
        floor_total += points[s].floor_ms;
        std::printf("  %-12s %-10s %-10s %8s %9s %8s\n", r.mode.c_str(), r.resolution.c_str(),
                    lab::roofline_stage_name(lab::RooflineStage(s)), tools::fixed(points[s].ms, 3).c_str(),
                    tools::fixed(points[s].floor_ms, 4).c_str(), tools::fixed(points[s].times_floor, 1).c_str());
      }
      if (!points.empty()) {
        std::printf("  %-12s %-10s %-10s %8s %9s %8s\n", r.mode.c_str(), r.resolution.c_str(), "total",
                    tools::fixed(r.stages[4].median, 3).c_str(), tools::fixed(floor_total, 4).c_str(),
                    tools::fixed(floor_total > 0 ? r.stages[4].median / floor_total : 0.0, 1).c_str());
      }
    }
  }
  if (!report.quality.empty()) {
    std::printf("  quality          against faithful's render of the same views of %s (clamped RGB; PSNR dB, SSIM)\n",
                opt.reference.empty() ? "the same scene" : opt.reference.c_str());
    std::printf("  %-12s %-10s %10s %10s %10s %10s %10s %9s %6s\n", "mode", "resolution", "PSNR mean", "PSNR min",
                "8-bit mean", "8-bit min", "SSIM mean", "max |d|", "views");
    for (const QualityRow& r : report.quality) {
      std::printf("  %-12s %-10s %10s %10s %10s %10s %10s %9s %6zu\n", r.mode.c_str(), r.resolution.c_str(),
                  tools::fixed(r.psnr_mean, 2).c_str(), tools::fixed(r.psnr_min, 2).c_str(),
                  tools::fixed(r.psnr8_mean, 2).c_str(), tools::fixed(r.psnr8_min, 2).c_str(),
                  tools::fixed(r.ssim_mean, 5).c_str(), tools::fixed(r.max_abs_diff, 4).c_str(), r.views);
    }
  }
  if (!report.front_door.empty()) {
    std::printf("  front door       ms per frame, host wall clock to device completion, median (same views, "
                "interleaved)\n");
    for (const FrontDoorRow& r : report.front_door) {
      std::printf("  %-34s %-10s %8s\n", r.path.c_str(), r.resolution.c_str(), tools::fixed(r.median_ms, 3).c_str());
    }
  }
}

/// The run as JSON (docs/BENCHMARKS.md "Reproducing"; scripts/bench_tables.py reads it).
std::string bench_json(const Options& opt, const api::LoadedGpuScene& scene, const lab::ReplicatedScene& replicated,
                       const BenchReport& report) {
  nlohmann::json j;
  j["tool"] = kTool;
  j["version"] = RGS_VERSION_STRING;
  j["date"] = report.date;
  j["timestamp_utc"] = lab::format_time("%Y-%m-%dT%H:%M:%SZ", true);
  j["device"] = {{"ordinal", report.device.ordinal},
                 {"name", report.device.name},
                 {"compute_capability", std::to_string(report.device.compute_major) + "." +
                                            std::to_string(report.device.compute_minor)},
                 {"multiprocessors", report.device.multiprocessors},
                 {"global_memory_bytes", report.device.global_memory_bytes},
                 {"l2_cache_bytes", report.device.l2_cache_bytes},
                 {"driver_version", report.device.driver_version},
                 {"runtime_version", report.device.runtime_version}};
  j["device_peaks"] = peaks_json(report.peaks);
  j["scene"] = {{"path", opt.input},
                {"format", scene.is_rgs ? "rgs" : "ply"},
                {"file_bytes", scene.file_bytes},
                {"gaussians", scene.scene.size()},
                {"sh_degree", scene.scene.sh_degree()},
                {"device_bytes", scene.scene.device_bytes()},
                {"load_ms", report.load_ms},
                {"renderer_scratch_bytes", report.scratch_bytes},
                {"scratch_budget_bytes", opt.render.scratch_budget},
                {"image_bytes", report.image_bytes},
                {"replicate", opt.replicate}};
  if (opt.replicate > 1) {
    j["scene"]["format"] = replicated.source_is_rgs ? "rgs" : "ply";
    j["scene"]["source_gaussians"] = replicated.source_gaussians;
    j["scene"]["replicated_quantization"] = replicated.quantization;
    const format::SceneBounds& b = scene.bounds;
    j["scene"]["bounds"] = {{"aabb_min", b.aabb_min}, {"aabb_max", b.aabb_max},
                            {"sphere_center", b.sphere_center}, {"sphere_radius", b.sphere_radius}};
  }
  j["cameras"] = {{"source", !opt.cameras.cameras_path.empty() ? "cameras.json"
                             : opt.cameras.path > 0           ? "path"
                                                              : "orbit"},
                  {"path", opt.cameras.cameras_path},
                  {"every", opt.cameras.every},
                  {"views", report.view_count}};
  j["warmup_frames"] = opt.warmup;
  j["repetitions"] = opt.repeat;
  j["statistic"] = "median over views x repetitions, per stage separately; fps = 1000 / median total_ms";
  nlohmann::json runs = nlohmann::json::array();
  for (size_t i = 0; i < report.results.size(); ++i) {
    const RunResult& r = report.results[i];
    nlohmann::json stages, views = nlohmann::json::array();
    nlohmann::json median;
    for (int s = 0; s < kStages; ++s) {
      stages[std::string(kStageNames[s]) + "_ms"] = summary_json(r.stages[s]);
      median[std::string(kStageNames[s]) + "_ms"] = r.stages[s].median;
    }
    for (const ViewResult& v : r.views) {
      nlohmann::json samples;
      for (int s = 0; s < kStages; ++s) samples[std::string(kStageNames[s]) + "_ms"] = v.samples[s];
      views.push_back({{"name", v.name},
                       {"width", v.width},
                       {"height", v.height},
                       {"pairs", v.stats.pairs},
                       {"large_pairs", v.stats.large_pairs},
                       {"subtile_culling", v.stats.subtile_culling},
                       {"sort_bits", v.stats.sort_bits},
                       {"tile_groups", v.stats.tile_groups},
                       {"median_total_ms", summarize(v.samples[4]).median},
                       {"samples", samples}});
    }
    const auto [lo, hi] = view_spread(r);
    nlohmann::json floor;
    const std::vector<lab::RooflinePoint> points = floor_points(r, report.floors, report.roofs);
    for (int s = 0; s < int(points.size()); ++s) {
      floor[lab::roofline_stage_name(lab::RooflineStage(s))] = {{"floor_ms", points[s].floor_ms},
                                                                          {"times_floor", points[s].times_floor}};
    }
    runs.push_back({{"mode", r.mode},
                    {"mode_description", mode_description(r.mode)},
                    {"resolution", r.resolution},
                    {"views", r.views.size()},
                    {"frames", r.views.size() * opt.repeat},
                    {"median_ms", median},
                    {"stages", stages},
                    {"fps", r.fps},
                    {"mean_pairs", r.mean_pairs},
                    {"max_tile_groups", r.max_tile_groups},
                    {"roofline", roofline_json(report.rooflines[i])},
                    {"view_total_ms", {{"min", lo}, {"max", hi}}},
                    {"per_view", views}});
    if (!points.empty()) runs.back()["floor"] = floor;
  }
  j["results"] = runs;
  for (const FloorSet& f : report.floors) {
    nlohmann::json views = nlohmann::json::array(), work;
    for (size_t v = 0; v < f.census.size(); ++v) {
      const lab::FrameCensus& c = f.census[v];
      views.push_back({{"name", f.view_names[v]},
                       {"pixels", c.pixels()},
                       {"gaussians", c.gaussians},
                       {"visible", c.visible},
                       {"contributing", c.contributing},
                       {"rect_pairs", c.rect_pairs},
                       {"blended", c.blended},
                       {"skipped", c.skipped},
                       {"max_blended", c.max_blended},
                       {"blending_pairs", {{"16x16", c.blending_pairs[0]}, {"8x8", c.blending_pairs[1]},
                                           {"4x4", c.blending_pairs[2]}}},
                       {"reaching_pairs", {{"16x16", c.reaching_pairs[0]}, {"8x8", c.reaching_pairs[1]},
                                           {"4x4", c.reaching_pairs[2]}}},
                       {"saturated_tiles", c.saturated_tiles},
                       {"hidden_rect_pairs", c.hidden_rect_pairs},
                       {"hidden_reaching_pairs", c.hidden_reaching_pairs}});
    }
    for (int s = 0; s < lab::kRooflineStages; ++s) {
      work[lab::roofline_stage_name(lab::RooflineStage(s))] = {
          {"bytes", f.work[s].bytes}, {"flops", f.work[s].flops}, {"half_flops", f.work[s].half_flops}};
    }
    j["floor_census"].push_back({{"resolution", f.resolution}, {"work", work}, {"views", views}});
  }
  for (const QualityRow& r : report.quality) {
    j["quality"].push_back({{"mode", r.mode},
                            {"resolution", r.resolution},
                            {"psnr_mean_db", r.psnr_mean},
                            {"psnr_min_db", r.psnr_min},
                            {"psnr8_mean_db", r.psnr8_mean},
                            {"psnr8_min_db", r.psnr8_min},
                            {"ssim_mean", r.ssim_mean},
                            {"max_abs_diff", r.max_abs_diff},
                            {"views", r.views}});
  }
  for (const FrontDoorRow& r : report.front_door) {
    j["front_door"].push_back({{"path", r.path}, {"resolution", r.resolution}, {"median_ms", r.median_ms}});
  }
  return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

/// Measures, prints the report and stages the JSON in `outputs`.
Status bench(const Options& opt, format::OutputTransaction& outputs, Clock::time_point t_start) {
  // Replication is host work and checks the Gaussian count before the device is touched.
  lab::ReplicatedScene replicated;
  if (opt.replicate > 1) {
    std::fprintf(stderr, "replicating %s x%u ...\n", opt.input.c_str(), opt.replicate);
    auto r = lab::replicate_scene_file(opt.input, opt.replicate, tools::scene_read_options());
    if (!r.ok()) return Status(r.status()).prepend("--replicate " + std::to_string(opt.replicate));
    replicated = std::move(r).value();
  }
  // Which modes read the FP32 arrays: the scene keeps them on the device only for those. A .rgs scene (or a
  // replicated one) has the compact sections; other formats are uploaded as FP32 arrays only.
  const bool compact_scene = opt.replicate > 1 || format::is_rgs_path(opt.input);
  bool fp32 = !compact_scene || opt.quality;  // --quality renders the baseline, which reads the FP32 arrays
  for (const std::string& mode : opt.modes) {
    auto options = lab::gpu_mode_options(mode, compact_scene);
    if (!options.ok()) return Status(options.status()).prepend(opt.input);
    fp32 = fp32 || lab::planned_techniques(*options, compact_scene).reads_fp32();
  }
  RGS_RETURN_IF_ERROR(api::require_cuda_device(opt.render.device));
  RGS_ASSIGN_OR_RETURN(runtime::CudaDeviceInfo device, runtime::cuda_device_info(opt.render.device));

  // Peaks first, while the device memory is free.
  std::fprintf(stderr, "measuring device peaks (device-to-device copy, FP32 FMA loop) ...\n");
  auto peaks = lab::measure_device_peaks();
  if (!peaks.ok()) return Status(peaks.status()).prepend("device peaks");
  const lab::RooflinePeaks roofs{peaks->memory_gbps, peaks->fp32_gflops, peaks->half_gflops};

  RGS_ASSIGN_OR_RETURN(runtime::GpuRenderer renderer, runtime::GpuRenderer::create());
  // Load time: read, decode (an archive .rgs decodes its Draco and quantized sections here) and upload, to the
  // device's completion (the uploads are synchronous copies).
  const auto load_start = Clock::now();
  RGS_ASSIGN_OR_RETURN(const api::LoadedGpuScene scene, load_bench_scene(opt, &replicated, fp32));
  tools::report_notes(kTool, opt.replicate > 1 ? replicated.notes : scene.notes);
  const double load_ms = std::chrono::duration<double, std::milli>(Clock::now() - load_start).count();
  RGS_ASSIGN_OR_RETURN(const std::vector<CameraSet> sets, make_camera_sets(opt, scene.bounds));

  const std::string date = lab::format_time("%Y-%m-%d", false);
  runtime::DeviceImage image;
  std::vector<RunResult> results;
  for (const std::string& mode : opt.modes) {
    auto options = lab::gpu_mode_options(mode, scene.scene.has_compact());
    if (!options.ok()) return Status(options.status()).prepend("mode " + mode);
    for (const CameraSet& set : sets) {
      std::fprintf(stderr, "%s %s: %u warm-up + %zu views x %u ...\n", mode.c_str(), set.label.c_str(), opt.warmup,
                   set.cameras.size(), opt.repeat);
      auto result = run_one(opt, mode, *options, scene, set, renderer, image);
      if (!result.ok()) return Status(result.status()).prepend(opt.input + ", mode " + mode + ", " + set.label);
      results.push_back(std::move(result).value());
    }
  }
  std::vector<RunRoofline> rooflines;
  for (const RunResult& r : results) rooflines.push_back(roofline_of(r, scene.scene, roofs));
  std::vector<QualityRow> quality;
  if (opt.quality) {
    std::fprintf(stderr, "quality against faithful (the 3DGS baseline): every view once per mode ...\n");
    std::optional<api::LoadedGpuScene> reference_scene;
    if (!opt.reference.empty()) {
      runtime::GpuSceneOptions fp32_arrays;
      fp32_arrays.fp32_attributes = true;
      auto loaded = load_gpu_scene(opt.reference, fp32_arrays);
      if (!loaded.ok()) return Status(loaded.status()).prepend("--reference");
      RGS_RETURN_ERROR_IF(loaded->scene.size() != scene.scene.size(), StatusCode::kInvalidArgument,
                          "--reference " + opt.reference + " holds " + std::to_string(loaded->scene.size()) +
                              " Gaussians, the benched scene " + std::to_string(scene.scene.size()));
      reference_scene.emplace(std::move(loaded).value());
    }
    auto rows = measure_quality(opt, scene, reference_scene ? *reference_scene : scene, sets, renderer);
    if (!rows.ok()) return Status(rows.status()).prepend("--quality");
    quality = std::move(rows).value();
  }
  std::vector<FloorSet> floors;
  if (opt.floor) {
    auto counted = count_floor(opt, sets);
    if (!counted.ok()) return Status(counted.status()).prepend("--floor");
    floors = std::move(counted).value();
  }
  std::vector<FrontDoorRow> front_door;
  if (opt.front_door && opt.replicate <= 1) {
    std::fprintf(stderr, "front door against GpuRenderer: %u warm-up + %u rounds ...\n", opt.warmup, opt.repeat);
    auto rows = compare_front_door(opt, scene, sets, renderer);
    if (!rows.ok()) return Status(rows.status()).prepend("--front-door");
    front_door = std::move(rows).value();
  }

  BenchReport report{std::move(device), std::move(peaks).value(), date, load_ms, renderer.scratch_bytes(),
                     uint64_t(image.width()) * image.height() * (16 + (image.has_depth() ? 4 : 0)),
                     sets.front().cameras.size(), std::move(results), std::move(rooflines), std::move(quality),
                     std::move(front_door), std::move(floors), roofs};
  print_report(opt, scene, replicated, report);
  if (!opt.json_path.empty()) {
    const std::string text = bench_json(opt, scene, replicated, report);
    RGS_RETURN_IF_ERROR(outputs.write(opt.json_path, text.data(), text.size()));
    std::printf("  json             %s\n", tools::escape_text(opt.json_path).c_str());
  }
  std::printf("  time             %s s\n", tools::fixed(tools::seconds_since(t_start), 1).c_str());
  return Status();
}

/// The streamed mode: bench_lod() with the options and cameras of this run.
Status bench_streamed(const Options& opt, format::OutputTransaction& outputs) {
  RGS_RETURN_IF_ERROR(api::require_cuda_device(opt.render.device));
  tools::LodBenchOptions o;
  o.input = opt.input;
  o.replicate = opt.replicate;
  o.lod_levels = *tools::parse_lod_levels(opt.lod_levels);  // CLI11 checked it
  o.stream.budget.max_splats = opt.splat_budget;
  o.stream.budget.pixel_error = opt.pixel_error;
  o.stream.memory_budget = opt.memory_budget;
  o.stream.stream_bytes_per_frame = opt.stream_bytes;
  o.scratch_budget = opt.render.scratch_budget;
  o.json_path = opt.json_path;
  o.save_path = opt.save_lod_path;
  return tools::bench_lod(o, [&](const format::SceneBounds& bounds) -> Result<std::vector<runtime::Camera>> {
    RGS_ASSIGN_OR_RETURN(std::vector<CameraSet> sets, make_camera_sets(opt, bounds));
    return sets.front().cameras;
  }, outputs);
}

int run(const Options& opt) {
  const auto t_start = Clock::now();
  // The JSON report may not replace an input; inputs are checked without blocking (a FIFO is refused at once).
  format::OutputTransaction outputs;
  if (int code = tools::declare_inputs(kTool, outputs, {opt.input}, opt.cameras.cameras_path); code != tools::kExitOk) {
    return code;
  }
  if (!opt.json_path.empty()) {
    if (int code = tools::declare_output(kTool, outputs, opt.json_path); code != tools::kExitOk) return code;
    tools::report_notes(kTool, outputs.remove_stale_temporaries());
  }
  if (!opt.save_lod_path.empty()) {
    if (int code = tools::declare_output(kTool, outputs, opt.save_lod_path); code != tools::kExitOk) return code;
  }
  Status measured = opt.streamed() ? bench_streamed(opt, outputs) : bench(opt, outputs, t_start);
  if (!measured.ok()) return tools::report_error(kTool, measured);
  return tools::commit_outputs(kTool, outputs);
}

}  // namespace

int main(int argc, char** argv) {
  Options opt;
  std::string mode_help = "Mode to benchmark (repeatable; default faithful and fastest):";
  std::vector<std::string> mode_names;
  for (const lab::GpuMode& m : lab::gpu_modes()) {
    mode_help += "\n  " + m.name + ": " + m.description + (m.lab ? " [lab kernel variant]" : "");
    mode_names.push_back(m.name);
  }
  CLI::App app{"Benchmark the CUDA renderer: per-stage GPU times (CUDA events) after warm-up, median over views x "
               "repetitions, FPS, pair counts, per mode and resolution, and a per-stage roofline (analytic bytes "
               "and FLOPs, docs/lab/ROOFLINE.md, against the device's memory and FP32 peaks measured in the same "
               "run); a table on stdout and the full results as JSON.",
               kTool};
  app.add_option(
         "scene", opt.input,
         "Scene: .rgs (uploaded as stored), or any format converter::read_scene detects (uploaded as FP32 arrays)")
      ->required();
  rgs::tools::add_camera_options(app, opt.cameras, "INRIA cameras.json", "Use at most N views",
                                 "Orbit of N cameras around the scene's bounding sphere");
  app.add_option("--resolution", opt.resolutions,
                 "WIDTHxHEIGHT or 720p/1080p/1440p/4k (repeatable). Cameras are resized keeping the field of view; "
                 "default: the cameras' own size, or 1920x1080 for --orbit")
      ->check(rgs::tools::status_check([](const std::string& text) { return lab::parse_resolution(text).status(); },
                                       "RESOLUTION"));
  app.add_option("--warmup", opt.warmup, "Warm-up frames per mode and resolution (views in turn), not timed")
      ->capture_default_str();
  app.add_option("--repeat", opt.repeat, "Timed repetitions of every view")->check(CLI::Range(1, 1000000))
      ->capture_default_str();
  app.add_option("--mode", opt.modes, mode_help)->check(CLI::IsMember(mode_names));
  app.add_option("--replicate", opt.replicate,
                 "Tile the scene K times on a grid in the x-z plane (lab::replicate) before timing, keeping "
                 "compact attributes: a .rgs as stored, a PLY quantized with rgs-convert's defaults. Orbit cameras "
                 "frame the replicated scene; --cameras views are used as they are. K x Gaussians must stay "
                 "<= 2^31 - 1")
      ->check(CLI::Range(uint32_t{1}, uint32_t{0x7fffffff}))
      ->capture_default_str();
  rgs::tools::add_render_options(app, opt.render, rgs::tools::kScratchBudgetOption);
  app.add_option("--splat-budget", opt.splat_budget,
                 "Streamed mode: render a level-of-detail .rgs (rgs-convert --lod-levels) along the views as a "
                 "fly-through, drawing at most N Gaussians a frame (docs/LOD.md); per view the frame time, splats, "
                 "bytes streamed and resident, and where the full detail fits its PSNR and SSIM against the full detail "
                 "2x2 supersampled, the plain full render's (the floor) and the popping (docs/LOD.md#measuring-quality)")
      ->check(CLI::Range(uint64_t{1}, uint64_t{0x7fffffff}));
  app.add_option("--memory-budget", opt.memory_budget,
                 "Streamed mode: device memory for the scene's pool, frame arrays and upload buffer (e.g. 3GiB); 0: a "
                 "pool that holds the whole file. The renderer's scratch is bounded by --scratch-budget")
      ->transform(CLI::AsSizeValue(false));
  app.add_option("--pixel-error", opt.pixel_error,
                 "Streamed mode: largest projected error of a level, in pixels (format/SPEC.md 4.9.1)")
      ->check(CLI::Range(0.0f, 1000.0f))
      ->capture_default_str();
  app.add_option("--stream-bytes", opt.stream_bytes,
                 "Streamed mode: most bytes read and uploaded per frame (the bound on a frame's wait for the disk)")
      ->transform(CLI::AsSizeValue(false))
      ->capture_default_str();
  rgs::tools::add_lod_levels_option(
      app, opt.lod_levels,
      "Streamed mode with --replicate K: levels of detail built in memory for the tiled scene (auto or 1..16; "
      "default auto)");
  app.add_option("--json", opt.json_path, "Write the full results (every sample) as JSON");
  app.add_option("--save-lod", opt.save_lod_path,
                 "Streamed mode with --replicate K: also write the level-of-detail .rgs built in memory to this "
                 "path (a scene for rgs-view and rgs-view-bench)");
  app.add_flag("--front-door", opt.front_door,
               "Also time the front door (api::Renderer, preset fastest, into a caller RGBA32F and RGBA8 buffer) "
               "against GpuRenderer with fastest's options, per frame, same views (needs --replicate 1)");
  app.add_flag("--quality", opt.quality,
               "Also compare every view of every mode but faithful with faithful's render (the 3DGS baseline) (PSNR, SSIM, max |d| "
               "of the clamped RGB, on the GPU; keeps the FP32 arrays on the device)");
  app.add_option("--reference", opt.reference,
                 "With --quality: compare with faithful's render of this scene instead of the benched one's, e.g. "
                 "the source the .rgs was converted from (any format; same Gaussian count); faithful then gets a "
                 "row too: what the conversion alone costs")
      ->needs("--quality");
  app.add_flag("--floor", opt.floor,
               "Also count every view with the CPU reference (what each pixel blends and tests in vain, the pairs "
               "the image needs per 16x16, 8x8 and 4x4 cell) and print each stage's true floor: the time the work "
               "the image needs takes at the measured roofs (docs/lab/ROOFLINE.md#the-true-floor; needs --replicate 1)");
  rgs::tools::add_scene_read_options(app);
  const auto check = [&]() -> std::string {
    if (opt.floor && opt.replicate > 1) return "--floor counts the scene as stored: it needs --replicate 1";
    if (opt.streamed() && (opt.quality || opt.floor || opt.front_door)) {
      return "the streamed mode (--splat-budget, --memory-budget) measures its own quality; drop --quality, --floor "
             "and --front-door";
    }
    if (!opt.save_lod_path.empty() && !(opt.streamed() && opt.replicate > 1)) {
      return "--save-lod writes the levels of detail the streamed mode builds for --replicate K > 1: it needs "
             "--replicate and --splat-budget or --memory-budget";
    }
    return opt.cameras.cameras_path.empty() && opt.cameras.orbit == 0 && opt.cameras.path == 0
               ? "one of --cameras, --orbit or --path is required"
               : "";
  };
  if (auto code = rgs::tools::parse_command_line(app, argc, argv, kTool, check)) return *code;
  rgs::tools::install_interrupt_cleanup();
  return rgs::tools::finish(kTool, run(opt));
}
