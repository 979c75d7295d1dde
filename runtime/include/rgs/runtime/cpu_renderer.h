// CPU reference renderer: the original 3DGS rasterizer's math written out in spec order, plus a RoofGS mode
// that mirrors the GPU pipeline's math with each technique switchable (docs/RENDERER.md).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <utility>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/sort_key.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/depth_key.h"
#include "rgs/runtime/roofgs_options.h"

namespace rgs::runtime {

/// Options of render_cpu().
struct RenderOptions {
  /// Background colour (linear RGB, as 3DGS: out = C + T·bg).
  std::array<float, 3> background = {0.f, 0.f, 0.f};
  /// Worker threads; 0 = std::thread::hardware_concurrency(). Results do not depend on it (bit for bit).
  unsigned num_threads = 0;
  /// RoofGS techniques; default all off = the 3DGS baseline.
  RoofgsOptions roofgs;
  /// Scene bounds (the .rgs metadata, or converter::compute_bounds of a PLY): every mean inside its sphere and
  /// its AABB; required by roofgs.key32, whose depth range they give (make_depth_key).
  std::optional<format::SceneBounds> scene_bounds;
};

/// Per-Gaussian result of the preprocess stage (3DGS preprocessCUDA), in pixel units.
struct ProjectedGaussian {
  /// Number of (tile, Gaussian) pairs this Gaussian emits; 0 when it is culled (then the rest is unspecified).
  uint32_t tiles_touched = 0;
  /// View-space depth z (world units).
  float depth = 0;
  /// Projected mean (px, py); pixel centres are at integers.
  float mean[2] = {0, 0};
  /// Dilated 2D covariance (pixels²) and its determinant.
  kernels::Cov2 cov{0, 0, 0};
  float det = 0;
  /// Conic (a, b, c) = inverse covariance.
  kernels::Conic conic{0, 0, 0};
  /// Activated opacity o and ln(o) (folded into C6 / the fast exp argument).
  float opacity = 0;
  float log_opacity = 0;
  /// RGB colour from SH, max(Σ sh·Y + 0.5, 0); not clamped above.
  float rgb[3] = {0, 0, 0};
  /// 3DGS radius ceil(3·sqrt(λmax)) and rectangle getRect(); with SnugBox + AccuTile, `rect` is the SnugBox
  /// tile rectangle that AccuTile walked.
  int radius = 0;
  kernels::TileRect rect{0, 0, 0, 0};
  /// SnugBox threshold 2·ln(255·o) (0 unless snugbox_accutile).
  float snug_t = 0;
  /// 32-bit key depth bin (0 unless key32).
  uint32_t depth_bin = 0;
};

/// Frame-wide parameters of one render.
struct FrameSetup {
  uint32_t width = 0, height = 0;
  /// Tile grid ceil(W/16) × ceil(H/16).
  int tiles_x = 0, tiles_y = 0;
  /// EWA clamp of the camera (camera.h).
  kernels::EwaClamp ewa_clamp{0, 0, 0, 0};
  /// 32-bit key layout (key32 only; make_depth_key).
  DepthKey key;
};

/// Sorted (tile, Gaussian) pairs.
struct TileBins {
  /// [P] sort keys after the stable sort: 64-bit baseline keys tile << 32 | float_bits(depth), or the 32-bit
  /// RoofGS keys (zero-extended).
  std::vector<uint64_t> keys;
  /// [P] Gaussian index of each pair.
  std::vector<uint32_t> values;
  /// [tiles_x·tiles_y + 1] offsets: the pairs of tile id (ty·tiles_x + tx) are [tile_begin[id], tile_begin[id+1]).
  std::vector<uint64_t> tile_begin;
};

/// Counts of one render.
struct RenderStats {
  uint64_t gaussians = 0;         ///< input Gaussians
  uint64_t visible = 0;           ///< Gaussians with at least one tile
  uint64_t pairs = 0;             ///< (tile, Gaussian) pairs sorted
  uint64_t culled_near = 0;       ///< z ≤ near plane
  uint64_t culled_depth_range = 0;///< outside [z_near, z_far] (key32)
  uint64_t culled_opacity = 0;    ///< o ≤ 1/255 (snugbox_accutile)
  int tiles_x = 0, tiles_y = 0;
  int key_tile_bits = 0, key_depth_bits = 0;  ///< key32 only
  float z_near = 0, z_far = 0;                ///< key32 only
};

/// Output of render_cpu(). Images are row-major, top row first.
struct RenderResult {
  uint32_t width = 0, height = 0;
  /// [H, W, 3] float32 linear RGB, C + T·bg (not clamped; SH colours can exceed 1).
  std::vector<float> rgb;
  /// [H, W] float32 accumulated opacity 1 − T (T = final transmittance).
  std::vector<float> alpha;
  /// [H, W] float32 expected view-space depth Σ wᵢ·zᵢ / Σ wᵢ over the blended Gaussians, wᵢ = αᵢ·Tᵢ (the
  /// same weights as the colour; Σ wᵢ = 1 − T). 0 where nothing was blended. z is the Gaussian mean's
  /// view-space depth (world units), not the per-pixel ray depth.
  std::vector<float> depth;
  RenderStats stats;
};

namespace detail {

/// What blending reads per Gaussian of a tile, gathered once per tile into a contiguous array (the CPU
/// counterpart of 3DGS's shared-memory batch: collected_xy, collected_conic_opacity, features, depth; with
/// folded coefficients the C1..C6 are folded at this load, as RoofGS does).
struct TileGaussian {
  float mean[2];
  kernels::Conic conic;
  float opacity, log_opacity;
  float rgb[3];
  float depth;
  kernels::FoldedCoefficients folded;
  float skip_power;  // unfolded path: powers below this give α < 1/255 for sure (visible_power_floor)
};

/// One blending worker's lists of the tile it blends.
struct TileScratch {
  std::vector<TileGaussian> list;
  std::vector<kernels::FoldedCoefficients> exp2;  // half blend: the coefficients in base 2
  std::vector<uint32_t> masks;                    // half blend: walk_masks
};

}  // namespace detail

/// Working memory of a CPU render: the projected Gaussians, the (tile, Gaussian) pairs and per-tile lists, and the
/// frame's images. A caller rendering many frames (api::Renderer) keeps one and passes it to each frame, which
/// clears and refills its vectors (never shrinks them), so frames of a steady size reuse the same memory instead of
/// allocating it afresh. Not thread-safe: one per thread. Fields are internal to render_cpu() except `result`.
struct CpuScratch {
  std::vector<ProjectedGaussian> gaussians;
  TileBins bins;
  std::vector<uint32_t> order;                        // emission order of the Gaussians
  std::vector<uint64_t> offsets;                      // [N + 1] first pair of each emitted Gaussian
  std::vector<std::pair<uint64_t, uint32_t>> pairs;   // (key, emission rank) before the sort
  std::vector<detail::TileScratch> workers;           // blending's, one per worker thread
  /// The frame render_cpu(…, scratch) rendered last; valid until the next call.
  RenderResult result;
};

/// Renders `cloud` from `camera` on the CPU. Stages, in the order of docs/DESIGN.md#conventions:
/// preprocess (cull z ≤ near, project, EWA clamp, cov2D + 0.3, cull det == 0, conic, radius, tile rect, SH
/// colour) → pairs per touched tile with keys → stable sort → per-tile ranges → per-pixel front-to-back
/// blending in 16×16 tiles (skip power > 0, α = min(0.99, o·exp(power)), skip α < 1/255, stop before the
/// Gaussian that would make T < 1e-4, out = C + T·bg).
/// @param cloud   activated float Gaussians (GaussianCloud), e.g. a PLY or a dequantized .rgs; SH degree 0..3.
/// @param camera  any size up to 32768² (validate_camera); not only multiples of 16.
/// Deterministic: the same inputs give the same bits for any num_threads.
/// @return kInvalidArgument (inconsistent cloud, invalid camera, key32 without scene_bounds, fast exp σ not in
/// [0, 1)), kLimitExceeded (more than 2^32 − 1 Gaussians, or a tile grid too large for a 32-bit key with at least
/// 8 depth bits), kOutOfMemory (any allocation failed, on any worker thread).
Result<RenderResult> render_cpu(const format::GaussianCloud& cloud, const Camera& camera,
                                const RenderOptions& options = {});

/// render_cpu() with the caller's working memory: the frame is `scratch->result`. Errors as render_cpu(); after
/// an error `scratch->result` is unspecified.
Status render_cpu(const format::GaussianCloud& cloud, const Camera& camera, const RenderOptions& options,
                  CpuScratch* scratch);

/// Stage 0: checks the inputs and derives the frame parameters (tile grid, EWA clamp, key layout and depth
/// range for key32). Errors as render_cpu().
Result<FrameSetup> setup_frame(const format::GaussianCloud& cloud, const Camera& camera,
                               const RenderOptions& options);


/// Stage 1 (3DGS preprocessCUDA): one ProjectedGaussian per input Gaussian, in input order, into `*out`
/// (resized to the cloud's size). Multithreaded over Gaussians; deterministic. `frame` comes from
/// setup_frame() for the same inputs.
/// @return kInvalidArgument (null `out`), kOutOfMemory (on any thread; `*out` is then empty).
Status preprocess_cpu(const format::GaussianCloud& cloud, const Camera& camera, const FrameSetup& frame,
                      const RenderOptions& options, RenderStats* stats, std::vector<ProjectedGaussian>* out);

/// preprocess_cpu() returning the vector, for tests and callers that treat memory exhaustion as fatal:
/// it throws std::bad_alloc when memory runs out, as a standard container would. render_cpu() and
/// library code use the Status form.
std::vector<ProjectedGaussian> preprocess_cpu(const format::GaussianCloud& cloud, const Camera& camera,
                                              const FrameSetup& frame, const RenderOptions& options,
                                              RenderStats* stats);

/// Stages 2–4 (3DGS duplicateWithKeys, radix sort, identifyTileRanges): emits the pairs of every Gaussian in
/// index order, or (depth, index) order with RoofgsOptions::depth_order (its tiles row-major, or in
/// AccuTile's walk order), sorts them stably by key (equal keys keep
/// Gaussian index order), and computes per-tile ranges.
/// @return kOutOfMemory if the pair buffers (or the per-thread work) cannot be allocated.
Result<TileBins> bin_and_sort_cpu(const std::vector<ProjectedGaussian>& gaussians, const FrameSetup& frame,
                                  const RenderOptions& options);

/// Stage 5 (3DGS renderCUDA): blends every pixel front to back from its tile's sorted list. Multithreaded over
/// tile rows; deterministic. Writes result->rgb/alpha/depth (resized to the frame).
/// @return kOutOfMemory when the images or a thread's tile list cannot be allocated.
Status blend_cpu(const std::vector<ProjectedGaussian>& gaussians, const TileBins& bins, const FrameSetup& frame,
                 const RenderOptions& options, RenderResult* result);

}  // namespace rgs::runtime
