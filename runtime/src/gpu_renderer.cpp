// GpuRenderer: a frame of either pipeline, composed of the stages of internal_gpu_stages.h (projection and
// pair counts, sort, tile ranges, chunk list) and the blend, every CUDA call checked.
#include "rgs/runtime/gpu_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <string>
#include <utility>

#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/tile_chunks.h"

#include "internal_gpu_stages.h"

namespace rgs::runtime {
namespace {

/// Largest image side the renderer accepts (validate_camera's bound as well).
constexpr uint32_t kMaxImageSide = 32768;

kernels::FrameParams make_frame_params(const Camera& camera, const GpuRenderOptions& options, bool antialiased) {
  kernels::FrameParams f{};
  for (int i = 0; i < 9; ++i) f.view_rotation[i] = camera.rotation[i];
  for (int i = 0; i < 3; ++i) f.view_translation[i] = camera.translation[i];
  const std::array<float, 3> centre = camera_centre(camera);
  for (int i = 0; i < 3; ++i) f.camera_centre[i] = centre[i];
  f.fx = camera.fx;
  f.fy = camera.fy;
  f.cx = camera.cx;
  f.cy = camera.cy;
  f.near_plane = camera.near_plane;
  f.ewa_clamp = kernels::ewa_clamp_for(camera.fx, camera.fy, camera.cx, camera.cy, static_cast<float>(camera.width),
                                       static_cast<float>(camera.height));
  for (int i = 0; i < 3; ++i) f.background[i] = options.background[i];
  f.width = camera.width;
  f.height = camera.height;
  f.tiles_x = uint32_t(kernels::tile_count_for(int(camera.width)));
  f.tiles_y = uint32_t(kernels::tile_count_for(int(camera.height)));
  f.tile_row_begin = 0;
  f.tile_row_end = f.tiles_y;
  f.antialiased = antialiased ? 1u : 0u;
  return f;
}

/// Adds the stage times between events[0..4] to *times, waiting for events[4].
Status add_stage_times(cudaEvent_t const events[5], StageTimes* times) {
  RGS_RETURN_IF_CUDA_ERROR(cudaEventSynchronize(events[4]), "GpuRenderer: frame");
  float* fields[4] = {&times->preprocess_ms, &times->sort_ms, &times->ranges_ms, &times->render_ms};
  for (int s = 0; s < 4; ++s) {
    float ms = 0.f;
    RGS_RETURN_IF_CUDA_ERROR(cudaEventElapsedTime(&ms, events[s], events[s + 1]), "GpuRenderer: cudaEventElapsedTime");
    *fields[s] += ms;
    times->total_ms += ms;
  }
  return Status();
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// DeviceImage

Status DeviceImage::resize(uint32_t width, uint32_t height, bool with_depth) {
  RGS_RETURN_ERROR_IF(width == 0 || height == 0 || width > kMaxImageSide || height > kMaxImageSide,
                      StatusCode::kInvalidArgument,
                      "DeviceImage: size " + std::to_string(width) + "x" + std::to_string(height) +
                          " outside [1, " + std::to_string(kMaxImageSide) + "]");
  const size_t pixels = size_t(width) * height;
  RGS_RETURN_IF_ERROR(rgba_.reserve(pixels * 4, "DeviceImage: RGBA plane"));
  if (with_depth) RGS_RETURN_IF_ERROR(depth_.reserve(pixels, "DeviceImage: depth plane"));
  width_ = width;
  height_ = height;
  has_depth_ = with_depth;
  return Status();
}

Result<HostImage> download(const DeviceImage& image, cudaStream_t stream) {
  HostImage host;
  host.width = image.width();
  host.height = image.height();
  const size_t pixels = size_t(host.width) * host.height;
  host.rgba.resize(pixels * 4);
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host.rgba.data(), image.rgba(), pixels * 4 * sizeof(float),
                                           cudaMemcpyDeviceToHost, stream),
                           "download: RGBA plane");
  if (image.has_depth()) {
    host.depth.resize(pixels);
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host.depth.data(), image.depth(), pixels * sizeof(float),
                                             cudaMemcpyDeviceToHost, stream),
                             "download: depth plane");
  }
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "download");
  return host;
}

// ---------------------------------------------------------------------------------------------------------
// GpuRenderer

struct GpuRenderer::Buffers {
  // The stages: projection and pair counts (emission), the pairs and their sort, the tile ranges, the long
  // tiles' chunks; each owns its buffers.
  GaussianProjection projection;
  PairSort sort;
  TileRanges tiles;
  TileChunkList chunks;
  // The frame rendered for an OutputImage that the render kernel cannot write directly (converted after).
  DeviceImage staging;
  // The last frame's pairs, key width and where its final values are (download_sorted_pairs).
  uint64_t last_pairs = 0;
  bool last_key32 = false;
  bool last_values_reordered = false;
  // Stage boundaries: start, after duplicate, after sort, after ranges, after render.
  cudaEvent_t events[5] = {nullptr, nullptr, nullptr, nullptr, nullptr};

  ~Buffers() {
    for (cudaEvent_t& e : events) {
      if (e != nullptr) cudaEventDestroy(e);
    }
  }

  uint64_t bytes() const {
    return projection.bytes() + sort.bytes() + tiles.bytes() + chunks.bytes() +
           uint64_t(staging.width()) * staging.height() * (staging.has_depth() ? 20 : 16);
  }
};

Result<GpuRenderer> GpuRenderer::create() {
  GpuRenderer renderer;
  renderer.buffers_ = std::make_unique<Buffers>();
  Buffers& b = *renderer.buffers_;
  RGS_RETURN_IF_ERROR(b.projection.create());
  for (cudaEvent_t& e : b.events) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventCreate(&e), "GpuRenderer: cudaEventCreate");
  }
  return renderer;
}

GpuRenderer::GpuRenderer(GpuRenderer&&) noexcept = default;
GpuRenderer& GpuRenderer::operator=(GpuRenderer&&) noexcept = default;
GpuRenderer::~GpuRenderer() = default;

uint64_t GpuRenderer::scratch_bytes() const { return buffers_ ? buffers_->bytes() : 0; }

Status GpuRenderer::download_sorted_pairs(std::vector<uint64_t>* keys, std::vector<uint32_t>* values,
                                          cudaStream_t stream) const {
  RGS_RETURN_ERROR_IF(buffers_ == nullptr, StatusCode::kInvalidArgument, "GpuRenderer: used after move");
  const Buffers& b = *buffers_;
  const uint64_t pairs = b.last_pairs;
  keys->assign(pairs, 0);
  values->assign(pairs, 0);
  if (pairs == 0) return Status();
  std::vector<uint32_t> keys32(b.last_key32 ? pairs : 0);
  if (b.last_key32) {
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(keys32.data(), b.sort.sorted_keys32(), pairs * sizeof(uint32_t),
                                             cudaMemcpyDeviceToHost, stream),
                             "GpuRenderer: sorted keys read-back");
  } else {
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(keys->data(), b.sort.sorted_keys64(), pairs * sizeof(uint64_t),
                                             cudaMemcpyDeviceToHost, stream),
                             "GpuRenderer: sorted keys read-back");
  }
  const uint32_t* final_values = b.last_values_reordered ? b.sort.values() : b.sort.sorted_values();
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(values->data(), final_values, pairs * sizeof(uint32_t),
                                           cudaMemcpyDeviceToHost, stream),
                           "GpuRenderer: sorted values read-back");
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "GpuRenderer: sorted pairs read-back");
  std::copy(keys32.begin(), keys32.end(), keys->begin());  // widened; nothing with 64-bit keys
  return Status();
}

Status validate_output_image(const OutputImage& target, uint32_t width, uint32_t height) {
  const std::string size = std::to_string(target.width) + "x" + std::to_string(target.height);
  RGS_RETURN_ERROR_IF(target.width != width || target.height != height, StatusCode::kInvalidArgument,
                      "output image: size " + size + " differs from the camera's " + std::to_string(width) + "x" +
                          std::to_string(height));
  RGS_RETURN_ERROR_IF(target.color == nullptr, StatusCode::kInvalidArgument, "output image: colour pointer is null");
  const int format = int(target.format);
  RGS_RETURN_ERROR_IF(format < 0 || format > 2, StatusCode::kInvalidArgument,
                      "output image: unknown pixel format " + std::to_string(format));
  const size_t row = size_t(target.width) * bytes_per_pixel(target.format);
  const size_t channel = bytes_per_pixel(target.format) / 4;
  RGS_RETURN_ERROR_IF(target.color_pitch < row, StatusCode::kInvalidArgument,
                      "output image: colour pitch " + std::to_string(target.color_pitch) + " < " +
                          std::to_string(row) + " bytes of a row");
  RGS_RETURN_ERROR_IF(target.color_pitch % channel != 0 || reinterpret_cast<uintptr_t>(target.color) % channel != 0,
                      StatusCode::kInvalidArgument,
                      "output image: colour pointer or pitch " + std::to_string(target.color_pitch) +
                          " not a multiple of the channel size " + std::to_string(channel));
  if (target.depth != nullptr) {
    RGS_RETURN_ERROR_IF(target.depth_pitch < size_t(target.width) * 4 || target.depth_pitch % 4 != 0 ||
                            reinterpret_cast<uintptr_t>(target.depth) % 4 != 0,
                        StatusCode::kInvalidArgument,
                        "output image: depth pitch " + std::to_string(target.depth_pitch) +
                            " is not a multiple of 4 of at least " + std::to_string(size_t(target.width) * 4) +
                            " bytes, or the depth pointer is misaligned");
  }
  return Status();
}

Result<GpuRenderStats> GpuRenderer::render(const GpuScene& scene, const Camera& camera,
                                           const GpuRenderOptions& options, DeviceImage* image,
                                           cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(buffers_ == nullptr, StatusCode::kInvalidArgument, "GpuRenderer: used after move");
  RGS_RETURN_ERROR_IF(image == nullptr, StatusCode::kInvalidArgument, "GpuRenderer: no output image");
  RGS_RETURN_IF_ERROR(validate_camera(camera));
  RGS_RETURN_IF_ERROR(image->resize(camera.width, camera.height, image->has_depth()));
  return render_frame(scene, camera, options, image->view(), nullptr, stream);
}

Result<GpuRenderStats> GpuRenderer::render(const GpuScene& scene, const Camera& camera,
                                           const GpuRenderOptions& options, const OutputImage& target,
                                           cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(buffers_ == nullptr, StatusCode::kInvalidArgument, "GpuRenderer: used after move");
  RGS_RETURN_IF_ERROR(validate_camera(camera));
  RGS_RETURN_IF_ERROR(validate_output_image(target, camera.width, camera.height));
  const bool packed_depth = target.depth == nullptr || target.depth_pitch == size_t(target.width) * 4;
  const bool direct = target.format == PixelFormat::kRgba32f && target.write_alpha &&
                      target.color_pitch == size_t(target.width) * 16 && packed_depth;
  if (direct) {
    return render_frame(scene, camera, options, kernels::ImageView{static_cast<float*>(target.color), target.depth},
                        nullptr, stream);
  }
  DeviceImage& staging = buffers_->staging;
  RGS_RETURN_IF_ERROR(staging.resize(camera.width, camera.height, target.depth != nullptr));
  kernels::OutputConvertParams convert;
  convert.rgba = staging.rgba();
  convert.depth = staging.depth();
  convert.width = target.width;
  convert.height = target.height;
  convert.color = target.color;
  convert.color_pitch = target.color_pitch;
  convert.format = target.format;
  convert.write_alpha = target.write_alpha;
  convert.depth_out = target.depth;
  convert.depth_pitch = target.depth_pitch;
  return render_frame(scene, camera, options, staging.view(), &convert, stream);
}

Result<GpuRenderStats> GpuRenderer::render_frame(const GpuScene& scene, const Camera& camera,
                                                 const GpuRenderOptions& options, const kernels::ImageView& view,
                                                 const kernels::OutputConvertParams* convert, cudaStream_t stream) {
  for (float c : options.background) {
    RGS_RETURN_ERROR_IF(!std::isfinite(c), StatusCode::kInvalidArgument, "GpuRenderer: background is not finite");
  }
  RGS_ASSIGN_OR_RETURN(const FramePlan plan,
                       options.lab_techniques
                           ? plan_frame(*options.lab_techniques, camera, scene.bounds(), scene.has_compact())
                           : plan_frame(options.preset, camera, scene.bounds(), scene.has_compact()));
  const GpuTechniques& techniques = plan.techniques;
  const bool roofgs = techniques.pipeline == GpuPipeline::kRoofgs;
  RGS_RETURN_ERROR_IF(techniques.reads_fp32() && !scene.has_fp32(), StatusCode::kInvalidArgument,
                      std::string("GpuRenderer: the ") +
                          (roofgs ? "RoofGS pipeline without compact attributes" : "baseline pipeline") +
                          " reads FP32 attributes, and this scene was uploaded without them "
                          "(GpuSceneOptions::fp32_attributes)");

  const kernels::FrameParams frame = make_frame_params(camera, options, scene.antialiased());
  const bool timed = options.time_stages;
  GpuRenderStats stats;
  stats.gaussians = scene.size();
  stats.tiles_x = frame.tiles_x;
  stats.tiles_y = frame.tiles_y;
  cudaEvent_t* ev = buffers_->events;
  buffers_->last_pairs = 0;  // until this frame's pairs are sorted (render_passes)
  buffers_->last_values_reordered = false;
  if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[0], stream), "GpuRenderer: cudaEventRecord");
  if (roofgs) {
    RGS_RETURN_IF_ERROR(render_roofgs(scene, frame, plan, options, view, &stats, stream));
  } else {
    RGS_RETURN_IF_ERROR(render_baseline(scene, frame, plan, options, view, &stats, stream));
  }
  if (convert != nullptr) {
    RGS_RETURN_IF_CUDA_ERROR(kernels::launch_convert_output(*convert, stream), "GpuRenderer: output conversion kernel");
  }
  buffers_->last_key32 = plan.switches.key32;
  if (timed) {
    RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[4], stream), "GpuRenderer: cudaEventRecord");
    RGS_RETURN_IF_ERROR(add_stage_times(ev, &stats.times));
    stats.timed = true;
    if (roofgs && plan.balanced_emission && scene.size() > 0) {
      unsigned long long large = 0;
      const unsigned long long* count = buffers_->projection.large_list_count(plan.fused);
      RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(&large, count, sizeof(large), cudaMemcpyDeviceToHost, stream),
                               "GpuRenderer: large Gaussian count read-back");
      RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "GpuRenderer: large Gaussian count read-back");
      stats.large_chunks = large;
    }
    if (stats.tile_chunks_listed) {
      const uint32_t* count = buffers_->chunks.last_count();
      RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(&stats.tile_chunks, count, sizeof(uint32_t), cudaMemcpyDeviceToHost,
                                               stream),
                               "GpuRenderer: tile chunk count read-back");
      RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "GpuRenderer: tile chunk count read-back");
    }
  }
  return stats;
}

Status GpuRenderer::render_passes(const kernels::FrameParams& frame, uint64_t limit, bool timed, const EmitPass& emit,
                                  const FinishPass& finish, GpuRenderStats* stats, cudaStream_t stream) {
  Buffers& b = *buffers_;
  cudaEvent_t* ev = b.events;
  stats->pass_pair_limit = limit;
  PairCounts whole;
  RGS_RETURN_IF_ERROR(emit(frame, limit, &whole));
  stats->large_pairs = whole.large_pairs;
  if (whole.pairs <= limit) {
    stats->pairs = whole.pairs;
    if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[1], stream), "GpuRenderer: cudaEventRecord");
    RGS_RETURN_IF_ERROR(finish(frame, whole, whole));
    b.last_pairs = whole.pairs;
    return Status();
  }
  // More pairs than a pass holds: groups of tile rows, top to bottom, each with the whole frame's pairs of its
  // tiles; a group that still holds too many is halved. Per-frame choices (blend variant, chunk size) follow the
  // whole frame's counts, so the image is the one pass's.
  std::vector<TileRows> pending = plan_tile_groups({frame.tile_row_begin, frame.tile_row_end}, whole.pairs, limit);
  std::reverse(pending.begin(), pending.end());  // the next group at the back
  stats->pairs = 0;
  stats->tile_groups = 0;
  while (!pending.empty()) {
    const TileRows rows = pending.back();
    pending.pop_back();
    kernels::FrameParams pass = frame;
    pass.tile_row_begin = rows.begin;
    pass.tile_row_end = rows.end;
    PairCounts counts;
    RGS_RETURN_IF_ERROR(emit(pass, limit, &counts));
    if (counts.pairs > limit) {
      RGS_RETURN_ERROR_IF(rows.size() == 1, StatusCode::kLimitExceeded,
                          "GpuRenderer: tile row " + std::to_string(rows.begin) + " alone holds " +
                              std::to_string(counts.pairs) + " pairs, more than the " + std::to_string(limit) +
                              " a pass can hold; raise GpuRenderOptions::scratch_budget");
      const uint32_t middle = rows.begin + rows.size() / 2;
      pending.push_back({middle, rows.end});
      pending.push_back({rows.begin, middle});
      continue;
    }
    if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[1], stream), "GpuRenderer: cudaEventRecord");
    RGS_RETURN_IF_ERROR(finish(pass, counts, whole));
    stats->pairs += counts.pairs;
    ++stats->tile_groups;
    b.last_pairs = counts.pairs;
    if (timed && !pending.empty()) {  // this group's stage times; the next group's start
      RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[4], stream), "GpuRenderer: cudaEventRecord");
      RGS_RETURN_IF_ERROR(add_stage_times(ev, &stats->times));
      RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[0], stream), "GpuRenderer: cudaEventRecord");
    }
  }
  return Status();
}

Result<uint64_t> GpuRenderer::pass_limit(const GpuRenderOptions& options, uint32_t gaussians, uint32_t num_tiles,
                                         bool key32, int key_bits, bool large_list, uint32_t min_chunk) {
  const bool chunks = min_chunk > 0;
  if (options.scratch_budget == 0) return kMaxPassPairs;
  Buffers& b = *buffers_;
  RGS_ASSIGN_OR_RETURN(uint64_t per_pair, PairSort::bytes_per_pair(key32, key_bits));
  // What is held now but the buffers sized by the pairs, and those buffers' parts that the pairs do not size:
  // CUB's fixed scratch (1 MiB), the large-Gaussian list's item per Gaussian.
  uint64_t fixed = b.bytes() - b.sort.bytes() - b.projection.large_list_bytes() - b.chunks.bytes() + (uint64_t{1} << 20);
  if (large_list) {
    per_pair += 2;  // one 16-byte item per kLargeChunkSlices pairs, with the buffer's headroom
    fixed += (uint64_t(gaussians) + 1) * sizeof(kernels::LargeGaussian) * 5 / 4;
  }
  if (!chunks) return pass_pair_limit(options.scratch_budget, fixed, per_pair, 1024);
  // The chunk list: two words per tile, and an item and a record slot per chunk, at most 2 per `min_chunk` pairs
  // (chunks hold at least that many) and at most TileChunkList::max_bytes in all, whichever is less. A list grown
  // by earlier frames beyond that is given back.
  const uint64_t per_chunk = sizeof(uint2) + uint64_t(kernels::tile_chunk_record_words(true)) * 128 * 4;
  const uint64_t chunk_per_pair = (2 * per_chunk * 5 / 4 + min_chunk - 1) / min_chunk;
  const uint64_t chunk_most = TileChunkList::max_bytes(num_tiles, true);
  fixed += uint64_t(num_tiles) * 2 * sizeof(uint32_t) * 5 / 4 + 2 * sizeof(uint32_t);
  Result<uint64_t> limit = pass_pair_limit(options.scratch_budget, fixed, per_pair + chunk_per_pair, 1024);
  if (!limit.ok() || *limit * chunk_per_pair > chunk_most) {
    limit = pass_pair_limit(options.scratch_budget, fixed + chunk_most, per_pair, 1024);
  }
  if (limit.ok() && b.chunks.bytes() > std::min(chunk_most, *limit * chunk_per_pair)) b.chunks.release();
  return limit;
}

Status GpuRenderer::render_baseline(const GpuScene& scene, const kernels::FrameParams& frame, const FramePlan& plan,
                                    const GpuRenderOptions& options, const kernels::ImageView& view,
                                    GpuRenderStats* stats, cudaStream_t stream) {
  Buffers& b = *buffers_;
  cudaEvent_t* ev = b.events;
  const bool timed = options.time_stages;
  const uint32_t n = scene.size();
  const uint32_t num_tiles = frame.tiles_x * frame.tiles_y;
  const int key_bits = plan.sort_bits;
  stats->sort_bits = key_bits;
  if (n > 0) {
    RGS_RETURN_IF_ERROR(b.projection.reserve_baseline(scene.capacity()));
  }
  RGS_RETURN_IF_ERROR(b.tiles.reserve(num_tiles));
  RGS_ASSIGN_OR_RETURN(const uint64_t limit, pass_limit(options, n, num_tiles, false, key_bits, false, 0));

  // 1. Preprocess, 2. offsets, pair count, duplication.
  const EmitPass emit = [&](const kernels::FrameParams& pass, uint64_t max_pairs, PairCounts* counts) -> Status {
    if (n == 0) return Status();
    RGS_RETURN_IF_CUDA_ERROR(kernels::preprocess_baseline(scene.fp32(), pass, b.projection.projected(), stream),
                             "GpuRenderer: preprocess kernel");
    RGS_ASSIGN_OR_RETURN(const FrameCounts totals, b.projection.scan_and_count(n, nullptr, stream));
    counts->pairs = totals.pairs;
    if (counts->pairs == 0 || counts->pairs > max_pairs) return Status();
    RGS_RETURN_IF_ERROR(b.sort.reserve(counts->pairs, false, key_bits, max_pairs, stream));
    RGS_RETURN_IF_CUDA_ERROR(kernels::duplicate_baseline(b.projection.projected(), b.projection.offsets(), n, pass,
                                                         b.sort.keys64(), b.sort.values(), stream),
                             "GpuRenderer: duplicate kernel");
    return Status();
  };
  const FinishPass finish = [&](const kernels::FrameParams& pass, const PairCounts& counts, const PairCounts&) {
    // 3. Stable radix sort over 32 + ceil(log2(tiles)) bits.
    RGS_RETURN_IF_ERROR(b.sort.sort(counts.pairs, false, key_bits, 0, stream));
    if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[2], stream), "GpuRenderer: cudaEventRecord");
    // 4. Per-tile ranges.
    RGS_ASSIGN_OR_RETURN(const uint32_t* sorted_values,
                         b.tiles.build(b.sort, counts.pairs, false, 0, num_tiles, nullptr, stream));
    if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[3], stream), "GpuRenderer: cudaEventRecord");
    // 5. Blend.
    RGS_RETURN_IF_CUDA_ERROR(kernels::render_baseline(b.tiles.ranges(), sorted_values, b.projection.projected(),
                                                      pass, view, stream),
                             "GpuRenderer: render kernel");
    return Status();
  };
  return render_passes(frame, limit, timed, emit, finish, stats, stream);
}

Status GpuRenderer::emit_roofgs_pairs(const GpuScene& scene, const kernels::FrameParams& frame, const FramePlan& plan,
                                      const kernels::RoofgsStages& stages, uint64_t limit, GpuRenderStats* stats,
                                      PairCounts* counts, cudaStream_t stream) {
  Buffers& b = *buffers_;
  const uint32_t n = scene.size();
  const kernels::RoofgsFrame& rf = plan.switches;
  const bool key32 = rf.key32;
  const int key_bits = plan.sort_bits;
  uint64_t& pairs = counts->pairs;
  uint64_t& large_pairs = counts->large_pairs;
  uint64_t& sort_counters = counts->sort_counters;
  kernels::GaussianSource source;
  source.fp32 = scene.fp32();
  if (scene.has_compact()) source.compact = scene.compact();
  source.count = n;

  // The per-Gaussian arrays are reserved by render_roofgs, before the pass limit is set.
  // The large Gaussians' work list for a frame of at most `max_pairs` pairs (capacity 0: listing off), never
  // longer than a pass of `limit` pairs needs (a list grown by earlier frames is given back first).
  const auto large_list = [&](uint64_t max_pairs) {
    return b.projection.large_list(n, max_pairs, limit, plan.balanced_emission, plan.fused);
  };
  const kernels::RoofgsProjected projected = b.projection.roofgs_projected();  // after every reserve above
  if (plan.fused) {
    const kernels::FusedScratch scratch = b.projection.fused_scratch();
    // Capacity: what the pair buffers hold now (sized by earlier frames), at least 2 pairs per Gaussian, at most
    // `limit`. A frame with more pairs runs the fused kernel again with enough (fused_relaunches), or, beyond
    // `limit`, leaves them to groups of tile rows; frames of dense scenes hold 1.5-3 pairs a Gaussian (taebak:
    // 1.5 at 1080p, 1.9 at 4K, 2.9 at 8K), large Gaussians many more (flowers: 35 at 4K).
    uint64_t capacity = std::min(std::max<uint64_t>(b.sort.capacity(), uint64_t(n) * 2), limit);
    for (int attempt = 0;; ++attempt) {
      RGS_RETURN_IF_ERROR(b.sort.reserve(capacity, key32, key_bits, limit, stream));
      capacity = b.sort.capacity();
      RGS_ASSIGN_OR_RETURN(const kernels::LargeGaussianList large, large_list(capacity));
      RGS_ASSIGN_OR_RETURN(const kernels::HostTotals published, b.projection.next_published_totals());
      RGS_RETURN_IF_CUDA_ERROR(kernels::fused_preprocess_roofgs(source, frame, rf, projected, scratch, large,
                                                                capacity, plan.allocation, b.sort.keys64(),
                                                                b.sort.keys32(), b.sort.values(), stream),
                               "GpuRenderer: fused preprocess kernel");
      // The large-Gaussian kernel publishes the totals as it starts.
      RGS_RETURN_IF_CUDA_ERROR(kernels::emit_large_gaussians(projected, large, frame, rf, capacity, b.sort.keys64(),
                                                             b.sort.keys32(), b.sort.values(), published, stream),
                               "GpuRenderer: large Gaussian kernel");
      RGS_RETURN_IF_ERROR(b.projection.record_publisher_done(stream));
      // The sort's counters need no pair count: zeroed now, while the host waits for it, not after.
      if (key32) {
        RGS_RETURN_IF_ERROR(b.sort.clear_counters(capacity, key_bits, stream));
        sort_counters = capacity;
      }
      // The host enqueues the sort as soon as it has the count, while the large Gaussians' pairs are written.
      RGS_ASSIGN_OR_RETURN(const FrameCounts totals, b.projection.wait_for_totals());
      pairs = totals.pairs;
      large_pairs = totals.large_pairs;
      if (pairs <= capacity || pairs > limit) break;
      RGS_RETURN_ERROR_IF(attempt > 0, StatusCode::kCudaError,
                          "GpuRenderer: fused kernel pair count changed between identical runs");
      capacity = pairs;
      ++stats->fused_relaunches;
    }
  } else {
    RGS_RETURN_IF_CUDA_ERROR(stages.preprocess(source, frame, rf, projected, b.projection.large_pairs(), stream),
                             "GpuRenderer: preprocess kernel");
    RGS_ASSIGN_OR_RETURN(const FrameCounts totals, b.projection.scan_and_count(n, b.projection.large_pairs(), stream));
    pairs = totals.pairs;
    large_pairs = totals.large_pairs;
    if (pairs > 0 && pairs <= limit) {
      RGS_RETURN_IF_ERROR(b.sort.reserve(pairs, key32, key_bits, limit, stream));
      RGS_ASSIGN_OR_RETURN(const kernels::LargeGaussianList large, large_list(pairs));
      RGS_RETURN_IF_CUDA_ERROR(stages.duplicate(projected, b.projection.offsets(), n, frame, rf, large, b.sort.keys64(),
                                                b.sort.keys32(), b.sort.values(), stream),
                               "GpuRenderer: duplicate kernel");
      RGS_RETURN_IF_CUDA_ERROR(kernels::emit_large_gaussians(projected, large, frame, rf, pairs, b.sort.keys64(),
                                                             b.sort.keys32(), b.sort.values(), {}, stream),
                               "GpuRenderer: large Gaussian kernel");
    }
  }
  return Status();
}

Status GpuRenderer::render_roofgs(const GpuScene& scene, const kernels::FrameParams& frame, const FramePlan& plan,
                                  const GpuRenderOptions& options, const kernels::ImageView& view,
                                  GpuRenderStats* stats, cudaStream_t stream) {
  Buffers& b = *buffers_;
  cudaEvent_t* ev = b.events;
  const bool timed = options.time_stages;
  const uint32_t n = scene.size();
  const uint32_t num_tiles = frame.tiles_x * frame.tiles_y;
  const kernels::RoofgsFrame& rf = plan.switches;
  const kernels::RoofgsStages& stages = options.stages;
  RGS_RETURN_ERROR_IF(!plan.fused && (stages.preprocess == nullptr || stages.duplicate == nullptr),
                      StatusCode::kUnsupportedFeature,
                      "GpuRenderer: separate preprocess and duplicate stages (fused_preprocess off) are not among "
                      "the product's launches; GpuRenderOptions::stages must give them "
                      "(docs/RENDERER.md#product-and-lab-kernels)");
  RGS_RETURN_ERROR_IF(stages.render == nullptr, StatusCode::kInvalidArgument,
                      "GpuRenderer: GpuRenderOptions::stages.render is null");
  const bool key32 = rf.key32;
  const int key_bits = plan.sort_bits;
  if (key32) {
    stats->key_tile_bits = plan.key.tile_bits;
    stats->key_depth_bits = plan.key.depth_bits;
    stats->z_near = plan.key.quantizer.z_near;
    stats->z_far = plan.key.empty_depth_range ? plan.key.quantizer.z_near : plan.key.quantizer.z_far;
  }
  stats->sort_bits = key_bits;
  if (n > 0) RGS_RETURN_IF_ERROR(b.projection.reserve_roofgs(scene.capacity(), plan.fused));
  RGS_RETURN_IF_ERROR(b.tiles.reserve(num_tiles));
  const RoofgsOptions& t = plan.techniques.roofgs.techniques;
  const bool may_chunk = t.folded_coefficients && t.fast_exp && t.half_blend;
  RGS_ASSIGN_OR_RETURN(const uint64_t limit, pass_limit(options, n, num_tiles, key32, key_bits,
                                                        plan.balanced_emission, may_chunk ? t.tile_chunk_pairs : 0));

  const EmitPass emit = [&](const kernels::FrameParams& pass, uint64_t max_pairs, PairCounts* counts) {
    return n > 0 ? emit_roofgs_pairs(scene, pass, plan, stages, max_pairs, stats, counts, stream) : Status();
  };
  const FinishPass finish = [&](const kernels::FrameParams& pass, const PairCounts& counts,
                                const PairCounts& whole) -> Status {
    // Stable radix sort over the key: 32 bits (4 passes) with key32, else 32 + ceil(log2(tiles)).
    RGS_RETURN_IF_ERROR(b.sort.sort(counts.pairs, key32, key_bits, counts.sort_counters, stream));
    if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[2], stream), "GpuRenderer: cudaEventRecord");
    // Tile ranges; with depth order and key32, the same pass puts the runs of tied keys in exact depth order.
    RGS_ASSIGN_OR_RETURN(const uint32_t* sorted_values,
                         b.tiles.build(b.sort, counts.pairs, key32, rf.key_depth_bits, num_tiles,
                                       plan.reorder_ties ? b.projection.depths() : nullptr, stream));
    b.last_values_reordered = plan.reorder_ties;
    // The blend is planned with the whole frame's counts, whatever rows this pass renders.
    const BlendPlan blend = plan_blend(plan.techniques.roofgs, whole.pairs, whole.large_pairs);
    stats->subtile_culling = blend.raster.subtile_culling;
    RGS_RETURN_ERROR_IF(stages.render == kernels::render_roofgs && !kernels::raster_variant_compiled(blend.raster),
                        StatusCode::kUnsupportedFeature,
                        "GpuRenderer: this combination of RoofGS techniques renders with a kernel variant no preset "
                        "uses, which the product's render stage lacks; GpuRenderOptions::stages must give one that "
                        "has it (docs/RENDERER.md#product-and-lab-kernels)");
    kernels::TileChunks chunks;
    if (blend.chunk_pairs > 0) {
      RGS_ASSIGN_OR_RETURN(chunks, b.chunks.list(blend.chunk_pairs, counts.pairs, pass, b.tiles.ranges(),
                                                 view.depth != nullptr, stream));
      stats->tile_chunks_listed = true;
    }
    if (timed) RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(ev[3], stream), "GpuRenderer: cudaEventRecord");
    RGS_RETURN_IF_CUDA_ERROR(stages.render(b.tiles.ranges(), chunks, sorted_values, b.projection.roofgs_projected(),
                                           pass, rf, blend.raster, view, stream),
                             "GpuRenderer: render kernel");
    return Status();
  };
  return render_passes(frame, limit, timed, emit, finish, stats, stream);
}

}  // namespace rgs::runtime
