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
#include "rgs/lab/gpu_modes.h"
#include "rgs/lab/replicated_scene.h"
#include "rgs/api/camera.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/runtime/gpu_image_metrics.h"
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

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(std::ceil(p / 100.0 * double(v.size())) - 1));
  return v[i];
}

}  // namespace

Status bench_lod(const LodBenchOptions& o,
                 const std::function<Result<std::vector<runtime::Camera>>(const format::SceneBounds&)>& make_cameras,
                 OutputSet& outputs) {
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

  struct Frame {
    std::string name;
    double ms = 0, wait_ms = 0, psnr = std::numeric_limits<double>::quiet_NaN();
    runtime::LodFrameStats stats;
  };
  std::vector<Frame> frames;
  runtime::DeviceImage image;
  std::fprintf(stderr, "fly-through: %zu views, splat budget %s, memory budget %s bytes ...\n", cameras.size(),
               group_digits(o.stream.budget.max_splats).c_str(), group_digits(o.stream.memory_budget).c_str());
  for (const runtime::Camera& cam : cameras) {
    const auto t0 = Clock::now();
    RGS_ASSIGN_OR_RETURN(runtime::LodFrameStats stats, streamer.prepare(cam));
    auto rendered = renderer.render(streamer.scene(), cam, options, &image);
    if (!rendered.ok()) return Status(rendered.status()).prepend("view " + cam.name);
    RGS_RETURN_IF_CUDA_ERROR(cudaDeviceSynchronize(), "view " + cam.name);
    frames.push_back({cam.name, ms_since(t0), stats.wait_ms, std::numeric_limits<double>::quiet_NaN(), stats});
  }

  // Quality: the same views rendered from the full detail, where it fits the device with the streamer's pool.
  std::string quality_note;
  if (o.quality) {
    size_t free_bytes = 0, total_bytes = 0;
    RGS_RETURN_IF_CUDA_ERROR(cudaMemGetInfo(&free_bytes, &total_bytes), "device memory");
    // The full detail's runtime sections; the renderer's per-Gaussian buffers take a few times more.
    const uint64_t k3 = 3 * format::sh_coefficient_count(file.metadata().sh_degree);
    const bool residual = file.find(format::SectionId::kShDcResidual) != nullptr;
    const uint64_t full_bytes = index.full_detail_count() * (12 + 8 + 6 + 2 + k3 + (residual ? 3 : 0));
    if (full_bytes * 5 < free_bytes) {
      runtime::GpuSceneOptions compact_only;
      compact_only.fp32_attributes = false;
      RGS_ASSIGN_OR_RETURN(runtime::GpuScene full, runtime::GpuScene::from_rgs(file, compact_only));
      // A second streamer flies the same path from the same cold pool: streaming is deterministic, so its frames
      // are those of the timed fly-through, which the full renders would have slowed.
      RGS_ASSIGN_OR_RETURN(runtime::LodStreamer replay, runtime::LodStreamer::open(file, o.stream));
      runtime::GpuImageComparer comparer;
      runtime::DeviceImage expected;
      // The full detail is rendered without a scratch budget, by a renderer of its own: the budgeted renderer's
      // per-Gaussian buffers stay sized by the frames it draws.
      runtime::GpuRenderOptions full_options = options;
      full_options.scratch_budget = 0;
      RGS_ASSIGN_OR_RETURN(runtime::GpuRenderer full_renderer, runtime::GpuRenderer::create());
      for (size_t v = 0; v < cameras.size(); ++v) {
        const runtime::Camera& cam = cameras[v];
        RGS_RETURN_IF_ERROR(replay.prepare(cam).status());
        auto a = full_renderer.render(full, cam, full_options, &expected);
        if (!a.ok()) return Status(a.status()).prepend("full render, view " + cam.name);
        auto b = renderer.render(replay.scene(), cam, options, &image);
        if (!b.ok()) return Status(b.status()).prepend("view " + cam.name);
        RGS_ASSIGN_OR_RETURN(const runtime::ImageMetrics m,
                             comparer.compare(expected.rgba(), image.rgba(), cam.width, cam.height, 4));
        frames[v].psnr = m.psnr_db;
      }
    } else {
      quality_note = "full detail (" + group_digits(full_bytes) + " bytes) does not fit next to the pool: no PSNR";
    }
  }

  std::vector<double> ms, psnr;
  uint64_t streamed = 0, max_splats = 0, max_resident = 0;
  for (const Frame& f : frames) {
    ms.push_back(f.ms);
    if (!std::isnan(f.psnr)) psnr.push_back(f.psnr);
    streamed += f.stats.bytes_streamed;
    max_splats = std::max(max_splats, f.stats.splats);
    max_resident = std::max(max_resident, f.stats.bytes_resident);
  }
  double psnr_mean = 0;
  for (double p : psnr) psnr_mean += p / double(psnr.size());
  std::printf("rgs-bench %s (streamed, levels of detail)\n", source.description.c_str());
  std::printf("  device           %s, %s\n", device.name.c_str(), format_time("%Y-%m-%d", false).c_str());
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
  std::printf("  %-10s %9s %8s %8s %11s %6s %6s %6s %13s %13s %8s\n", "view", "frame ms", "wait ms", "read ms",
              "splats", "drawn", "coarse", "behind", "streamed B", "resident B", "PSNR dB");
  for (const Frame& f : frames) {
    std::printf("  %-10s %9s %8s %8s %11s %6u %6u %6u %13s %13s %8s\n", f.name.c_str(), fixed(f.ms, 3).c_str(),
                fixed(f.wait_ms, 3).c_str(), fixed(f.stats.read_ms, 3).c_str(), group_digits(f.stats.splats).c_str(),
                f.stats.chunks_drawn,
                f.stats.chunks_coarsened, f.stats.chunks_not_resident, group_digits(f.stats.bytes_streamed).c_str(),
                group_digits(f.stats.bytes_resident).c_str(), std::isnan(f.psnr) ? "-" : fixed(f.psnr, 2).c_str());
  }
  std::printf("  frame time       median %s ms, p95 %s ms, max %s ms over %zu views (host clock: select, stream, "
              "gather, render, synchronize)\n",
              fixed(percentile(ms, 50), 3).c_str(), fixed(percentile(ms, 95), 3).c_str(),
              fixed(percentile(ms, 100), 3).c_str(), ms.size());
  std::printf("  splats           at most %s; %s bytes streamed in all, at most %s resident\n",
              group_digits(max_splats).c_str(), group_digits(streamed).c_str(), group_digits(max_resident).c_str());
  if (!psnr.empty()) {
    std::printf("  quality          PSNR against the full detail: mean %s dB, min %s dB over %zu views\n",
                fixed(psnr_mean, 2).c_str(), fixed(percentile(psnr, 0.0001), 2).c_str(), psnr.size());
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
    views.push_back({{"view", f.name}, {"frame_ms", f.ms}, {"wait_ms", f.wait_ms}, {"read_ms", f.stats.read_ms},
                     {"splats", f.stats.splats},
                     {"chunks_drawn", f.stats.chunks_drawn}, {"chunks_coarsened", f.stats.chunks_coarsened},
                     {"chunks_not_resident", f.stats.chunks_not_resident},
                     {"bytes_streamed", f.stats.bytes_streamed}, {"bytes_resident", f.stats.bytes_resident},
                     {"psnr_db", std::isnan(f.psnr) ? nlohmann::json() : nlohmann::json(f.psnr)}});
  }
  j["views"] = views;
  j["frame_ms"] = {{"median", percentile(ms, 50)}, {"p95", percentile(ms, 95)}, {"max", percentile(ms, 100)}};
  if (!psnr.empty()) j["psnr_db"] = {{"mean", psnr_mean}, {"min", percentile(psnr, 0.0001)}};
  const std::string text = j.dump(2);
  return outputs.write(o.json_path, text.data(), text.size());
}

}  // namespace rgs::tools
