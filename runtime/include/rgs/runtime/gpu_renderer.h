// The CUDA renderer: renders a GpuScene from a Camera into a float RGBA image in device memory.
// Available only with RGS_WITH_CUDA. docs/RENDERER.md describes the pipelines.
#pragma once

#include <cuda_runtime_api.h>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

#include "rgs/format/status.h"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/output_convert.h"
#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/device_buffer.h"
#include "rgs/runtime/frame_plan.h"
#include "rgs/runtime/gpu_scene.h"
#include "rgs/runtime/roofgs_options.h"

namespace rgs::runtime {

/// An image in device memory, row-major, top row first. Move-only.
class DeviceImage {
 public:
  /// Makes the image width × height (contents undefined), with a depth plane when `with_depth`.
  /// Errors: kInvalidArgument (a zero or > 32768 side), kOutOfMemory, kCudaError.
  Status resize(uint32_t width, uint32_t height, bool with_depth);

  uint32_t width() const { return width_; }
  uint32_t height() const { return height_; }
  bool has_depth() const { return has_depth_; }
  /// [H, W, 4] float32 RGBA: rgb = C + T·bg (linear, not clamped; SH colours can exceed 1), a = 1 − T.
  float* rgba() const { return rgba_.data(); }
  /// [H, W] float32 expected view-space depth Σ wᵢzᵢ / Σ wᵢ (0 where nothing blended), or nullptr.
  float* depth() const { return has_depth_ ? depth_.data() : nullptr; }
  kernels::ImageView view() const { return kernels::ImageView{rgba(), depth()}; }

 private:
  uint32_t width_ = 0, height_ = 0;
  bool has_depth_ = false;
  DeviceBuffer<float> rgba_, depth_;
};

/// A DeviceImage copied to host memory.
struct HostImage {
  uint32_t width = 0, height = 0;
  std::vector<float> rgba;   ///< [H, W, 4] as DeviceImage::rgba()
  std::vector<float> depth;  ///< [H, W], empty when the image had no depth plane
};

/// Copies `image` to the host on `stream` and waits. Errors: kCudaError.
Result<HostImage> download(const DeviceImage& image, cudaStream_t stream = nullptr);

/// Pixel format of a caller's colour image (OutputImage): RGBA32F, RGBA16F or RGBA8, channels R, G, B, A.
using PixelFormat = kernels::OutputPixelFormat;

/// Bytes per pixel of `format` (16, 8 or 4).
inline size_t bytes_per_pixel(PixelFormat format) {
  return format == PixelFormat::kRgba32f ? 16 : format == PixelFormat::kRgba16f ? 8 : 4;
}

/// A caller-owned image in device memory that GpuRenderer::render() writes one frame into. The renderer
/// never allocates, frees or keeps it; it must stay valid until the frame's work on the stream is done.
///
/// - Colour: row y (top row first) starts at `color` + y·`color_pitch` bytes, `width` pixels of `format`
///   (kernels/output_convert.h gives each format's rounding). RGB = C + T·bg as rendered (the values the
///   3DGS rasterizer outputs, no sRGB transfer applied); A = 1 − T, or 1 when `write_alpha` is false.
///   `color_pitch` ≥ width·bytes_per_pixel(format) and a multiple of the channel size; `color` aligned to the
///   channel size (cudaMalloc and cudaMallocPitch give both).
/// - Depth (optional): float32 expected view-space depth Σ wᵢzᵢ / Σ wᵢ (world units, 0 where nothing
///   blended), row y at `depth` + y·`depth_pitch` bytes; `depth_pitch` ≥ 4·width, multiple of 4.
///
/// A tightly packed RGBA32F image with alpha (pitch = 16·width; depth, if any, pitch = 4·width) is written
/// by the render kernel directly; any other target costs one conversion pass over the frame (one read of
/// 16 B and one write of bytes_per_pixel per pixel) from the renderer's own scratch frame.
struct OutputImage {
  uint32_t width = 0, height = 0;  ///< must equal the camera's width and height
  void* color = nullptr;
  size_t color_pitch = 0;
  PixelFormat format = PixelFormat::kRgba32f;
  bool write_alpha = true;
  float* depth = nullptr;
  size_t depth_pitch = 0;
};

/// Checks an OutputImage against a width × height frame: non-null colour, pitches and alignments as
/// documented there. @return kInvalidArgument naming the first problem.
Status validate_output_image(const OutputImage& target, uint32_t width, uint32_t height);

/// Options of GpuRenderer::render().
struct GpuRenderOptions {
  /// What the frame is rendered with (plan_frame(Preset, ...)); by default the 3DGS rasterizer, the reference
  /// every other frame is measured against (the front door's default is api::RenderSettings').
  Preset preset = Preset::kFaithful;
  /// The lab's plan factory (lab/technique_options.h): when set, the frame is planned from these techniques
  /// instead of the preset's, any combination of them (ablations). A combination no preset uses may need
  /// `stages` to have its launches.
  std::optional<GpuTechniques> lab_techniques;
  /// The RoofGS launches that exist in variants no preset reaches (used by a RoofGS frame); the default, the
  /// product's, renders every configuration of the presets. Separate stages (roofgs.fused_preprocess off)
  /// need stages.preprocess and stages.duplicate, and a render-kernel variant render_roofgs lacks
  /// (kernels::raster_variant_compiled) needs another stages.render: the lab's (lab/) have them.
  kernels::RoofgsStages stages;
  /// Background colour (linear RGB, out = C + T·bg).
  std::array<float, 3> background = {0.f, 0.f, 0.f};
  /// Record CUDA events around each stage and fill GpuRenderStats::times (waits for the frame to finish).
  bool time_stages = false;
  /// Bound on the renderer's scratch memory (GpuRenderer::scratch_bytes()), bytes; 0: none, the pair buffers
  /// grow to what each frame needs. A frame whose pairs do not fit in what is left once the per-Gaussian and
  /// per-tile buffers are held, or that has more than kMaxPassPairs pairs, is rendered in groups of tile rows,
  /// each emitted, sorted and blended on its own, into the same image bits as one pass
  /// (docs/RENDERER.md#bounded-pair-memory).
  uint64_t scratch_budget = 0;
};

/// Stage times of one frame from CUDA events, milliseconds. preprocess covers preprocess, the offset scan,
/// the pair-count read-back and duplication (3DGS's geometry + binning steps before the sort). A frame
/// rendered in groups of tile rows sums each stage over its groups (preprocess includes the pass that counted
/// the whole frame's pairs).
struct StageTimes {
  float preprocess_ms = 0, sort_ms = 0, ranges_ms = 0, render_ms = 0, total_ms = 0;
};

/// Counts of one frame.
struct GpuRenderStats {
  uint64_t gaussians = 0;      ///< input Gaussians
  uint64_t pairs = 0;          ///< (tile, Gaussian) pairs sorted, over all tile groups
  /// Passes the frame was rendered in: 1, or its groups of tile rows (GpuRenderOptions::scratch_budget).
  uint32_t tile_groups = 1;
  /// Most pairs a pass could hold: kMaxPassPairs, or fewer under a scratch budget.
  uint64_t pass_pair_limit = 0;
  uint32_t tiles_x = 0, tiles_y = 0;
  /// Key bits the pair sort covered: 32 + ceil(log2(tiles)) for 64-bit keys, 32 for 32-bit keys (with or
  /// without depth order).
  int sort_bits = 0;
  int key_tile_bits = 0, key_depth_bits = 0;  ///< 32-bit key layout (0 without it)
  float z_near = 0, z_far = 0; ///< 32-bit key depth range (0 without it)
  uint32_t fused_relaunches = 0;  ///< fused kernel runs repeated because the pair buffer had to grow
  /// RoofGS with balanced emission: work items of emit_large_gaussians, one per chunk of up to
  /// kernels::kLargeChunkSlices slices of a Gaussian with more than kernels::kSerialTileLimit tiles. Read
  /// back only for timed frames (time_stages); 0 otherwise.
  uint64_t large_chunks = 0;
  /// RoofGS: pairs of the Gaussians with more than kernels::kSubtileLargeTiles tiles (SubtileCulling::kAuto's
  /// measure), and whether the rasterizer culled sub-tiles.
  uint64_t large_pairs = 0;
  bool subtile_culling = false;
  /// RoofGS: the frame listed the chunks of its long tiles (chunking on for the frame: kernels::frame_chunk_pairs
  /// nonzero and below the pair count), and how many chunk blocks it listed (read back only for timed frames;
  /// 0 otherwise).
  bool tile_chunks_listed = false;
  uint32_t tile_chunks = 0;
  bool timed = false;          ///< times is valid (GpuRenderOptions::time_stages)
  StageTimes times;
};

/// Renders scenes with the 3DGS baseline pipeline or the RoofGS pipeline (the plan's GpuTechniques::pipeline). Both
/// follow render_cpu() (runtime/cpu_renderer.h) with the same RoofgsOptions: the same conventions and
/// per-Gaussian bits; pixels differ from it only through the device's expf and logf. Keeps its scratch buffers between
/// frames and grows them as needed (by a quarter more than asked), so a steady sequence of frames allocates nothing.
/// Not thread-safe; one renderer per stream. Move-only.
///
/// Each frame brings the pair count to the host once, like 3DGS: the fused RoofGS pipeline's host polls pinned
/// memory that a kernel on `stream` writes the count to (kernels::HostTotals); the baseline and the separate
/// RoofGS stages copy it and wait on `stream`.
class GpuRenderer {
 public:
  /// Creates a renderer on the current device. Errors: kCudaError (no device, driver problem).
  static Result<GpuRenderer> create();

  GpuRenderer(GpuRenderer&&) noexcept;
  GpuRenderer& operator=(GpuRenderer&&) noexcept;
  ~GpuRenderer();

  /// Renders `scene` from `camera` into `image`, resized to the camera's size (with a depth plane if it
  /// already had one), all work on `stream`. When it returns ok the frame is enqueued (and finished if
  /// options.time_stages). Errors: kInvalidArgument (validate_camera(), background not finite, fast exp σ
  /// outside [0, 1), compact attributes of a scene without them, the 32-bit key without scene bounds),
  /// kLimitExceeded (an image too large for the 32-bit key), kUnsupportedFeature (a RoofGS configuration no
  /// preset uses, without the stages it needs in options.stages),
  /// kOutOfMemory (pair buffers too large for the device: the message gives the pair count; the renderer
  /// frees what it held and stays usable), kCudaError (a failed launch or copy, naming the stage).
  Result<GpuRenderStats> render(const GpuScene& scene, const Camera& camera, const GpuRenderOptions& options,
                                DeviceImage* image, cudaStream_t stream = nullptr);

  /// Renders `scene` from `camera` into the caller's device image `target` (OutputImage: format, pitch,
  /// optional alpha and depth), all work enqueued on `stream`; nothing synchronizes the device. The only
  /// waits are those of render(): the per-frame pair count (polled in pinned memory that a kernel on
  /// `stream` writes, or a copy and a wait on `stream`), and time_stages. Scratch buffers that must grow
  /// are allocated with cudaMalloc (which may synchronize the device), so only the first frames of a
  /// sequence, or a larger frame, allocate. Errors: those of render(), and kInvalidArgument from
  /// validate_output_image() or a target size other than the camera's.
  Result<GpuRenderStats> render(const GpuScene& scene, const Camera& camera, const GpuRenderOptions& options,
                                const OutputImage& target, cudaStream_t stream = nullptr);

  /// Device bytes held by the scratch buffers now.
  uint64_t scratch_bytes() const;

  /// The last frame's (tile, Gaussian) pairs after the sort, copied to the host for tests and debugging (the
  /// CPU reference's TileBins::keys/values, term by term). Waits for `stream`.
  /// @return keys [P] widened to 64 bits (the baseline's tile << 32 | depth bits, or the 32-bit RoofGS key),
  /// values [P] Gaussian ids; P = GpuRenderStats::pairs of the last render (0 before the first one), or of its
  /// last group of tile rows when it was rendered in groups.
  /// Errors: kCudaError (a failed copy).
  Status download_sorted_pairs(std::vector<uint64_t>* keys, std::vector<uint32_t>* values,
                               cudaStream_t stream = nullptr) const;

 private:
  GpuRenderer() = default;
  struct Buffers;
  Result<GpuRenderStats> render_frame(const GpuScene& scene, const Camera& camera, const GpuRenderOptions& options,
                                      const kernels::ImageView& view, const kernels::OutputConvertParams* convert,
                                      cudaStream_t stream);
  Status render_baseline(const GpuScene& scene, const kernels::FrameParams& frame, const FramePlan& plan,
                         const GpuRenderOptions& options, const kernels::ImageView& view, GpuRenderStats* stats,
                         cudaStream_t stream);
  Status render_roofgs(const GpuScene& scene, const kernels::FrameParams& frame, const FramePlan& plan,
                       const GpuRenderOptions& options, const kernels::ImageView& view, GpuRenderStats* stats,
                       cudaStream_t stream);
  /// Pairs of a pass, and the sort counters zeroed ahead of the count (0: none).
  struct PairCounts {
    uint64_t pairs = 0, large_pairs = 0, sort_counters = 0;
  };
  /// A pipeline's pass over the tile rows of `frame`: its emission, which leaves the pairs unwritten when they
  /// are more than `limit` (`counts` still gives them), and the rest of the pass, which sorts, ranges and
  /// blends those pairs, planned with the whole frame's counts `whole`.
  using EmitPass = std::function<Status(const kernels::FrameParams& frame, uint64_t limit, PairCounts* counts)>;
  using FinishPass = std::function<Status(const kernels::FrameParams& frame, const PairCounts& pass,
                                          const PairCounts& whole)>;
  /// Renders `frame` in one pass, or in groups of tile rows when its pairs are more than `limit`
  /// (docs/RENDERER.md#bounded-pair-memory).
  Status render_passes(const kernels::FrameParams& frame, uint64_t limit, bool timed, const EmitPass& emit,
                       const FinishPass& finish, GpuRenderStats* stats, cudaStream_t stream);
  /// The pairs a pass may hold under options.scratch_budget once the buffers that do not grow with the pairs
  /// are held (the caller reserves those first): pass_pair_limit() of what they take. `min_chunk`: the smallest
  /// chunk of a long tile the frame may list (RoofgsOptions::tile_chunk_pairs), 0 without chunks.
  Result<uint64_t> pass_limit(const GpuRenderOptions& options, uint32_t gaussians, uint32_t num_tiles, bool key32,
                              int key_bits, bool large_list, uint32_t min_chunk);
  /// The RoofGS preprocess and pair emission stage (fused or separate, as `plan` says) of a non-empty scene.
  Status emit_roofgs_pairs(const GpuScene& scene, const kernels::FrameParams& frame, const FramePlan& plan,
                           const kernels::RoofgsStages& stages, uint64_t limit, GpuRenderStats* stats,
                           PairCounts* counts, cudaStream_t stream);
  std::unique_ptr<Buffers> buffers_;  // scratch buffers and events (gpu_renderer.cpp)
};

}  // namespace rgs::runtime
