// rgs-bench's streamed mode (bench_lod.h): LodStreamer + GpuRenderer along a camera path.
#include "bench_lod.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>

#include "cli_common.h"
#include "rgs/lab/bench_options.h"
#include "rgs/lab/gpu_modes.h"
#include "rgs/lab/lod_quality.h"
#include "rgs/lab/replicated_scene.h"
#include "rgs/api/camera.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/runtime/gpu_image_metrics.h"
#include "rgs/runtime/image_metrics.h"
#include "rgs/converter/lod_builder.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/gpu_renderer.h"

namespace rgs::tools {
namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

/// The level-of-detail file: mapped from disk, or (replicate > 1) built in memory from the tiled input.
struct LodSource {
  std::vector<uint8_t> bytes;  // the in-memory file, when built
  std::unique_ptr<format::RgsFile> file;
  std::string description;
};

Result<LodSource> open_source(const LodBenchOptions& o) {
  LodSource s;
  if (o.replicate <= 1) {
    RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(o.input, read_options()));
    RGS_RETURN_ERROR_IF(file.lod() == nullptr, StatusCode::kInvalidArgument,
                        o.input + ": no levels of detail; write them with rgs-convert --lod-levels auto, or pass "
                                  "--replicate K to build them in memory");
    s.file = std::make_unique<format::RgsFile>(std::move(file));
    s.description = o.input;
    return s;
  }
  std::fprintf(stderr, "replicating %s x%u and building its levels of detail ...\n", o.input.c_str(), o.replicate);
  const auto t0 = Clock::now();
  RGS_ASSIGN_OR_RETURN(lab::ReplicatedScene replicated, lab::replicate_scene_file(o.input, o.replicate,
                                                                                    scene_read_options()));
  format::ReadOptions unlimited = read_options();
  unlimited.limits.max_gaussians = uint64_t{1} << 31;
  RGS_ASSIGN_OR_RETURN(format::RgsFile tiled, format::RgsFile::from_bytes(replicated.rgs_bytes.data(),
                                                                          replicated.rgs_bytes.size(), unlimited,
                                                                          o.input));
  RGS_ASSIGN_OR_RETURN(format::EncodedScene scene, tiled.read_scene());
  replicated.rgs_bytes = {};
  const auto t_build = Clock::now();
  converter::LodBuildOptions build;
  build.levels = o.lod_levels;
  RGS_ASSIGN_OR_RETURN(converter::LodScene lod, converter::build_lod(scene, build));
  const double build_s = ms_since(t_build) / 1e3;
  scene = {};
  format::WriteOptions write;
  write.lod = &lod.index;
  RGS_ASSIGN_OR_RETURN(s.bytes, format::serialize_scene(lod.scene, write));
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::from_bytes(s.bytes.data(), s.bytes.size(), unlimited,
                                                                         o.input + " x" + std::to_string(o.replicate)));
  s.file = std::make_unique<format::RgsFile>(std::move(file));
  s.description = o.input + " x" + std::to_string(o.replicate) + " (" + group_digits(lod.index.full_detail_count()) +
                  " Gaussians, levels of detail built in " + fixed(build_s, 1) + " s, " +
                  fixed(ms_since(t0) / 1e3, 1) + " s in all)";
  return s;
}

/// One view's quality (docs/LOD.md#measuring-quality). The reference is the full detail rendered at twice the
/// width and height (resize_camera: fx, fy, cx, cy doubled) and area-downsampled 2×2; the floor is the plain
/// full render's score against it. The frame changes are mean |I_t − I_{t−1}| over pixels and R, G, B, in [0, 1],
/// against the previous view of the path (NaN for the first view).
struct ViewQuality {
  double psnr = std::numeric_limits<double>::quiet_NaN(), ssim = psnr;
  double floor_psnr = psnr, floor_ssim = psnr;
  double change_lod = psnr, change_full = psnr;
};

/// Renders the full detail of each view at 1× and 2×, builds the supersampled reference (lab::area_downsample_2x
/// on the host) and scores a level-of-detail render and the plain full render against it on the device.
class QualityMeter {
 public:
  QualityMeter(const runtime::GpuScene& full, runtime::GpuRenderer& renderer, const runtime::GpuRenderOptions& options)
      : full_(full), renderer_(renderer), options_(options) {}

  /// `lod` holds the level-of-detail render of `cam`; views come in path order.
  Result<ViewQuality> measure(const runtime::Camera& cam, const runtime::DeviceImage& lod) {
    auto a = renderer_.render(full_, cam, options_, &plain_);
    if (!a.ok()) return Status(a.status()).prepend("full render, view " + cam.name);
    auto b = renderer_.render(full_, runtime::resize_camera(cam, 2 * cam.width, 2 * cam.height), options_, &fine_);
    if (!b.ok()) return Status(b.status()).prepend("2x full render, view " + cam.name);
    RGS_ASSIGN_OR_RETURN(const runtime::HostImage fine, runtime::download(fine_));
    RGS_ASSIGN_OR_RETURN(const std::vector<float> reference,
                         lab::area_downsample_2x({fine.rgba.data(), fine.width, fine.height, 4}));
    RGS_RETURN_IF_ERROR(reference_.reserve_exact(reference.size(), "supersampled reference"));
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpy(reference_.data(), reference.data(), reference.size() * sizeof(float),
                                        cudaMemcpyHostToDevice),
                             "reference upload");
    ViewQuality q;
    RGS_ASSIGN_OR_RETURN(const runtime::ImageMetrics m,
                         comparer_.compare(reference_.data(), lod.rgba(), cam.width, cam.height, 4));
    RGS_ASSIGN_OR_RETURN(const runtime::ImageMetrics f,
                         comparer_.compare(reference_.data(), plain_.rgba(), cam.width, cam.height, 4));
    q.psnr = m.psnr_db;
    q.ssim = m.ssim;
    q.floor_psnr = f.psnr_db;
    q.floor_ssim = f.ssim;
    RGS_ASSIGN_OR_RETURN(runtime::HostImage lod_frame, runtime::download(lod));
    RGS_ASSIGN_OR_RETURN(runtime::HostImage full_frame, runtime::download(plain_));
    if (lod_frame.rgba.size() == previous_lod_.size()) {
      auto frame = [&](const std::vector<float>& v) { return runtime::ImageRef{v.data(), cam.width, cam.height, 4}; };
      RGS_ASSIGN_OR_RETURN(q.change_lod, lab::mean_abs_difference(frame(lod_frame.rgba), frame(previous_lod_)));
      RGS_ASSIGN_OR_RETURN(q.change_full,
                           lab::mean_abs_difference(frame(full_frame.rgba), frame(previous_full_)));
    }
    previous_lod_ = std::move(lod_frame.rgba);
    previous_full_ = std::move(full_frame.rgba);
    return q;
  }

 private:
  const runtime::GpuScene& full_;
  runtime::GpuRenderer& renderer_;
  runtime::GpuRenderOptions options_;
  runtime::GpuImageComparer comparer_;
  runtime::DeviceImage plain_, fine_;
  runtime::DeviceBuffer<float> reference_;
  std::vector<float> previous_lod_, previous_full_;  // the previous view's frames, [H, W, 4]
};

std::string dash_or(double v, int digits) { return std::isnan(v) ? "-" : fixed(v, digits); }

/// JSON has no NaN or infinity: null for NaN, a string for ±inf (identical images).
nlohmann::json json_or_null(double v) {
  if (std::isnan(v)) return nlohmann::json();
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  return v;
}

double mean_of(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : sum / double(v.size());
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(std::ceil(p / 100.0 * double(v.size())) - 1));
  return v[i];
}

/// The quality pass: the path flown again by a second streamer from the same cold pool, each view scored by a
/// QualityMeter, where the full detail fits the device next to the pool. Returns a note when it does not.
Result<std::string> measure_quality(const format::RgsFile& file, const LodBenchOptions& o,
                                    const std::vector<runtime::Camera>& cameras,
                                    const runtime::GpuRenderOptions& options, runtime::GpuRenderer& renderer,
                                    std::vector<ViewQuality>* quality) {
  size_t free_bytes = 0, total_bytes = 0;
  RGS_RETURN_IF_CUDA_ERROR(cudaMemGetInfo(&free_bytes, &total_bytes), "device memory");
  // The full detail's runtime sections; the renderer's per-Gaussian buffers take a few times more, and the 2x
  // render's pairs about four times the 1x render's.
  const uint64_t k3 = 3 * format::sh_coefficient_count(file.metadata().sh_degree);
  const bool residual = file.find(format::SectionId::kShDcResidual) != nullptr;
  const uint64_t full_bytes = file.lod()->full_detail_count() * (12 + 8 + 6 + 2 + k3 + (residual ? 3 : 0));
  if (full_bytes * 8 >= free_bytes) {
    return "full detail (" + group_digits(full_bytes) + " bytes) does not fit next to the pool: no quality";
  }
  runtime::GpuSceneOptions compact_only;
  compact_only.fp32_attributes = false;
  RGS_ASSIGN_OR_RETURN(runtime::GpuScene full, runtime::GpuScene::from_rgs(file, compact_only));
  // A second streamer flies the same path from the same cold pool: streaming is deterministic, so its frames
  // are those of the timed fly-through, which the full renders would have slowed.
  RGS_ASSIGN_OR_RETURN(runtime::LodStreamer replay, runtime::LodStreamer::open(file, o.stream));
  // The full detail is rendered without a scratch budget, by a renderer of its own: the budgeted renderer's
  // per-Gaussian buffers stay sized by the frames it draws.
  runtime::GpuRenderOptions full_options = options;
  full_options.scratch_budget = 0;
  RGS_ASSIGN_OR_RETURN(runtime::GpuRenderer full_renderer, runtime::GpuRenderer::create());
  QualityMeter meter(full, full_renderer, full_options);
  runtime::DeviceImage image;
  quality->resize(cameras.size());
  for (size_t v = 0; v < cameras.size(); ++v) {
    const runtime::Camera& cam = cameras[v];
    RGS_RETURN_IF_ERROR(replay.prepare(cam).status());
    auto b = renderer.render(replay.scene(), cam, options, &image);
    if (!b.ok()) return Status(b.status()).prepend("view " + cam.name);
    RGS_ASSIGN_OR_RETURN((*quality)[v], meter.measure(cam, image));
  }
  return std::string();
}

/// One timed frame of the fly-through.
struct Frame {
  std::string name;
  double ms = 0, wait_ms = 0;
  double prepare_ms = 0;  // host time of LodStreamer::prepare (select, stream, gather launch)
  double select_ms = 0;   // runtime::select_lod alone, timed again after the frame (not part of ms)
  runtime::LodFrameStats stats;
  runtime::GpuRenderStats render;
  ViewQuality quality;
};

nlohmann::json frame_json(const Frame& f) {
  return {{"view", f.name}, {"frame_ms", f.ms}, {"wait_ms", f.wait_ms}, {"read_ms", f.stats.read_ms},
          {"prepare_ms", f.prepare_ms}, {"select_ms", f.select_ms}, {"pairs", f.render.pairs},
          {"tile_groups", f.render.tile_groups}, {"splats", f.stats.splats},
          {"chunks_drawn", f.stats.chunks_drawn}, {"chunks_coarsened", f.stats.chunks_coarsened},
          {"chunks_not_resident", f.stats.chunks_not_resident}, {"bytes_streamed", f.stats.bytes_streamed},
          {"bytes_resident", f.stats.bytes_resident}, {"psnr_db", json_or_null(f.quality.psnr)},
          {"ssim", json_or_null(f.quality.ssim)}, {"floor_psnr_db", json_or_null(f.quality.floor_psnr)},
          {"floor_ssim", json_or_null(f.quality.floor_ssim)},
          {"frame_change_8bit", json_or_null(255 * f.quality.change_lod)},
          {"full_frame_change_8bit", json_or_null(255 * f.quality.change_full)}};
}

}  // namespace

Status bench_lod(const LodBenchOptions& o,
                 const std::function<Result<std::vector<runtime::Camera>>(const format::SceneBounds&)>& make_cameras,
                 format::OutputTransaction& outputs) {
  RGS_ASSIGN_OR_RETURN(LodSource source, open_source(o));
  if (!o.save_path.empty() && !source.bytes.empty()) {
    RGS_RETURN_IF_ERROR(outputs.write(o.save_path, source.bytes.data(), source.bytes.size()));
    std::printf("  saved            %s (%s bytes)\n", escape_text(o.save_path).c_str(),
                group_digits(source.bytes.size()).c_str());
  }
  const format::RgsFile& file = *source.file;
  const format::LodIndex& index = *file.lod();
  RGS_ASSIGN_OR_RETURN(const std::vector<runtime::Camera> cameras, make_cameras(file.metadata().bounds));
  RGS_ASSIGN_OR_RETURN(runtime::CudaDeviceInfo device, runtime::cuda_device_info(0));
  RGS_ASSIGN_OR_RETURN(runtime::GpuRenderOptions options, lab::gpu_mode_options("fastest", true));
  options.scratch_budget = o.scratch_budget;
  RGS_ASSIGN_OR_RETURN(runtime::GpuRenderer renderer, runtime::GpuRenderer::create());

  const auto t_open = Clock::now();
  RGS_ASSIGN_OR_RETURN(runtime::LodStreamer streamer, runtime::LodStreamer::open(file, o.stream));
  const double open_ms = ms_since(t_open);

  std::vector<Frame> frames;
  runtime::DeviceImage image;
  std::fprintf(stderr, "fly-through: %zu views, splat budget %s, memory budget %s bytes ...\n", cameras.size(),
               group_digits(o.stream.budget.max_splats).c_str(), group_digits(o.stream.memory_budget).c_str());
  for (const runtime::Camera& cam : cameras) {
    const auto t0 = Clock::now();
    RGS_ASSIGN_OR_RETURN(runtime::LodFrameStats stats, streamer.prepare(cam));
    const double prepare_ms = ms_since(t0);
    auto rendered = renderer.render(streamer.scene(), cam, options, &image);
    if (!rendered.ok()) return Status(rendered.status()).prepend("view " + cam.name);
    RGS_RETURN_IF_CUDA_ERROR(cudaDeviceSynchronize(), "view " + cam.name);
    const double ms = ms_since(t0);
    const auto t_select = Clock::now();
    (void)runtime::select_lod(index, cam, o.stream.budget);
    frames.push_back({cam.name, ms, stats.wait_ms, prepare_ms, ms_since(t_select), stats, *rendered, {}});
  }

  std::string quality_note;
  if (o.quality) {
    std::vector<ViewQuality> quality;
    RGS_ASSIGN_OR_RETURN(quality_note, measure_quality(file, o, cameras, options, renderer, &quality));
    for (size_t v = 0; v < quality.size(); ++v) frames[v].quality = quality[v];
  }

  std::vector<double> ms, psnr, ssim, floor_psnr, floor_ssim, change_lod, change_full;
  uint64_t streamed = 0, max_splats = 0, max_resident = 0;
  for (const Frame& f : frames) {
    ms.push_back(f.ms);
    if (!std::isnan(f.quality.psnr)) {
      psnr.push_back(f.quality.psnr);
      ssim.push_back(f.quality.ssim);
      floor_psnr.push_back(f.quality.floor_psnr);
      floor_ssim.push_back(f.quality.floor_ssim);
    }
    if (!std::isnan(f.quality.change_lod)) {
      change_lod.push_back(255 * f.quality.change_lod);
      change_full.push_back(255 * f.quality.change_full);
    }
    streamed += f.stats.bytes_streamed;
    max_splats = std::max(max_splats, f.stats.splats);
    max_resident = std::max(max_resident, f.stats.bytes_resident);
  }
  const double psnr_mean = mean_of(psnr), floor_mean = mean_of(floor_psnr);
  const double popping = mean_of(change_lod) - mean_of(change_full);
  std::printf("rgs-bench %s (streamed, levels of detail)\n", source.description.c_str());
  std::printf("  device           %s, %s\n", device.name.c_str(), lab::format_time("%Y-%m-%d", false).c_str());
  std::printf("  scene            %s Gaussians in %u chunks x %u levels (%s at full detail), SH degree %u\n",
              group_digits(file.gaussian_count()).c_str(), index.chunk_count, index.level_count,
              group_digits(index.full_detail_count()).c_str(), file.metadata().sh_degree);
  std::printf("  budgets          %s splats, %s pixels of error, %s bytes of device memory (pool %s), %s bytes "
              "streamed per frame at most; scratch %s\n",
              group_digits(o.stream.budget.max_splats).c_str(), fixed(o.stream.budget.pixel_error, 2).c_str(),
              group_digits(o.stream.memory_budget).c_str(), group_digits(streamer.pool_bytes()).c_str(),
              group_digits(o.stream.stream_bytes_per_frame).c_str(),
              o.scratch_budget ? group_digits(o.scratch_budget).c_str() : "unbounded");
  std::printf("  open             %s ms (the coarsest level of every chunk)\n", fixed(open_ms, 1).c_str());
  std::printf("  %-10s %9s %8s %8s %11s %6s %6s %6s %13s %13s %8s %6s %8s\n", "view", "frame ms", "wait ms", "read ms",
              "splats", "drawn", "coarse", "behind", "streamed B", "resident B", "PSNR dB", "SSIM", "floor dB");
  for (const Frame& f : frames) {
    std::printf("  %-10s %9s %8s %8s %11s %6u %6u %6u %13s %13s %8s %6s %8s\n", f.name.c_str(), fixed(f.ms, 3).c_str(),
                fixed(f.wait_ms, 3).c_str(), fixed(f.stats.read_ms, 3).c_str(), group_digits(f.stats.splats).c_str(),
                f.stats.chunks_drawn,
                f.stats.chunks_coarsened, f.stats.chunks_not_resident, group_digits(f.stats.bytes_streamed).c_str(),
                group_digits(f.stats.bytes_resident).c_str(), dash_or(f.quality.psnr, 2).c_str(),
                dash_or(f.quality.ssim, 4).c_str(), dash_or(f.quality.floor_psnr, 2).c_str());
  }
  std::printf("  frame time       median %s ms, p95 %s ms, max %s ms over %zu views (host clock: select, stream, "
              "gather, render, synchronize)\n",
              fixed(percentile(ms, 50), 3).c_str(), fixed(percentile(ms, 95), 3).c_str(),
              fixed(percentile(ms, 100), 3).c_str(), ms.size());
  std::printf("  splats           at most %s; %s bytes streamed in all, at most %s resident\n",
              group_digits(max_splats).c_str(), group_digits(streamed).c_str(), group_digits(max_resident).c_str());
  if (!psnr.empty()) {
    std::printf("  quality          against the full detail 2x2 supersampled (docs/LOD.md#measuring-quality): PSNR "
                "mean %s dB, min %s dB, SSIM %s over %zu views; floor (the plain full render) PSNR mean %s dB, min %s "
                "dB, SSIM %s\n",
                fixed(psnr_mean, 2).c_str(), fixed(percentile(psnr, 0.0001), 2).c_str(),
                fixed(mean_of(ssim), 4).c_str(), psnr.size(), fixed(floor_mean, 2).c_str(),
                fixed(percentile(floor_psnr, 0.0001), 2).c_str(), fixed(mean_of(floor_ssim), 4).c_str());
    if (!change_lod.empty()) {
      std::printf("  quality popping  %s 8-bit levels: frame-to-frame change %s (levels of detail) - %s (full "
                  "detail) over %zu steps\n",
                  fixed(popping, 3).c_str(), fixed(mean_of(change_lod), 3).c_str(),
                  fixed(mean_of(change_full), 3).c_str(), change_lod.size());
    }
  } else if (!quality_note.empty()) {
    std::printf("  quality          %s\n", quality_note.c_str());
  }
  if (o.json_path.empty()) return Status();
  nlohmann::json j;
  j["scene"] = source.description;
  j["device"] = device.name;
  j["gaussians"] = file.gaussian_count();
  j["full_detail"] = index.full_detail_count();
  j["chunks"] = index.chunk_count;
  j["levels"] = index.level_count;
  j["budgets"] = {{"splats", o.stream.budget.max_splats}, {"pixel_error", o.stream.budget.pixel_error},
                  {"memory_bytes", o.stream.memory_budget}, {"pool_bytes", streamer.pool_bytes()},
                  {"stream_bytes_per_frame", o.stream.stream_bytes_per_frame}, {"scratch_bytes", o.scratch_budget}};
  j["open_ms"] = open_ms;
  nlohmann::json views = nlohmann::json::array();
  for (const Frame& f : frames) {
    views.push_back(frame_json(f));
  }
  j["views"] = views;
  j["frame_ms"] = {{"median", percentile(ms, 50)}, {"p95", percentile(ms, 95)}, {"max", percentile(ms, 100)}};
  if (!psnr.empty()) {
    j["quality"] = {{"reference", "full detail at 2x width and height, area-downsampled 2x2"},
                    {"psnr_db", {{"mean", psnr_mean}, {"min", percentile(psnr, 0.0001)}}},
                    {"ssim", mean_of(ssim)},
                    {"floor_psnr_db", {{"mean", floor_mean}, {"min", percentile(floor_psnr, 0.0001)}}},
                    {"floor_ssim", mean_of(floor_ssim)},
                    {"popping_8bit", change_lod.empty() ? nlohmann::json() : nlohmann::json(popping)},
                    {"frame_change_8bit", json_or_null(mean_of(change_lod))},
                    {"full_frame_change_8bit", json_or_null(mean_of(change_full))}};
  }
  const std::string text = j.dump(2);
  return outputs.write(o.json_path, text.data(), text.size());
}

}  // namespace rgs::tools
