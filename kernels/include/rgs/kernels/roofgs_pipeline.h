// The RoofGS pipeline's stages as host-callable CUDA launches (paper §§ "Compact attributes",
// "Resolution-Adaptive Sorting-Key Encoding", "Fused preprocessing", "Rasterization Reorganization for
// Dual-Pixel ILP", "Range-aware fast exponential"; docs/DESIGN.md#render-pipeline), each technique switchable
// at run time through RoofgsFrame so that every ablation runs the same code. With every switch off the stages
// compute exactly what the baseline's do. The CPU reference's RoofGS mode (runtime/cpu_renderer.h) does the
// same math on the host; kernels are compiled with --fmad=false to match it term by term.
//
//   fused_preprocess_roofgs  one kernel: preprocess + tile count + order-preserving allocation + pairs, or
//                            (RoofgsStages, the lab's) preprocess per Gaussian + inclusive_scan + duplication
//   emit_large_gaussians     pairs of the Gaussians with many tiles, a warp per chunk (after either)
//   sort_pairs (32 or 64-bit keys), tile_ranges (baseline_pipeline.h)
//   [order_equal_keys_by_depth]  optional with the 32-bit key: tied keys in exact depth order, and the
//                            ranges (RoofGS+; replaces tile_ranges)
//   [list_tile_chunks]       optional with half-precision blending: the long tiles' chunks
//   render_roofgs            folded coefficients with two pixels per thread and the fast exp (the presets'
//                            variants; a RenderRoofgsStage of the lab's adds the baseline loop and expf)
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <cstdint>

#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/device_scene.h"
#include "rgs/kernels/shared/frame_switches.h"
#include "rgs/kernels/shared/sort_key.h"

namespace rgs::kernels {

/// Per-Gaussian outputs of the RoofGS preprocess, device arrays indexed by Gaussian id (N entries each).
struct RoofgsProjected {
  float* depths = nullptr;          ///< [N] view-space z
  float* means2d = nullptr;         ///< [N, 2] pixel mean
  float* conic_opacity = nullptr;   ///< [N, 4] conic (a, b, c) and opacity o
  /// [N, 4] colour (r, g, b) and ln o (folded into C6 / the fast exp's argument): one 16-byte store in the
  /// preprocess and one 16-byte gather a pair in the render (three 4-byte colour stores at a 12-byte stride
  /// wrote 36 partial sectors a warp where this writes 16 whole ones).
  float* colour_log_opacity = nullptr;
  // The tile walk's inputs: written for every visible Gaussian by preprocess_roofgs, and by the fused kernel
  // only for Gaussians it lists as large (emit_large_gaussians reads them).
  float* cov2d = nullptr;           ///< [N, 3] dilated 2D covariance (xx, xy, yy) for SnugBox
  float* snug_t = nullptr;          ///< [N] SnugBox threshold 2·ln(255·o)
  int32_t* radii = nullptr;         ///< [N] 3DGS radius; 0 = culled
  uint32_t* depth_bins = nullptr;   ///< [N] key32 depth bin (0 without key32)
  uint64_t* tiles_touched = nullptr;///< [N] tile count (separate stages); 0 = culled
};

/// Source attributes of a frame: `compact` when RoofgsFrame::compact, else `fp32`.
struct GaussianSource {
  Fp32GaussiansView fp32;
  CompactGaussiansView compact;
  uint32_t count = 0;
};

/// Pair emission (duplicate_roofgs and the fused kernel): a Gaussian with at most this many tiles is written
/// by its own thread; a larger one is listed and written by emit_large_gaussians, a warp per chunk of its
/// walk, in the same positions and order. 16 rather than 8: a warp rebuilds a listed Gaussian's walk, which
/// costs more than a lane writing up to 16 pairs (8, 24 and 32 measured: docs/lab/TRIED.md#tried-and-not-kept).
constexpr uint32_t kSerialTileLimit = 16;

/// A large Gaussian's tile walk is listed in chunks of consecutive slices, a work item each: at most
/// kLargeChunkSlices slices (a warp measures one per lane) and about kLargeChunkPairs pairs, so that the
/// longest item — the critical path of emit_large_gaussians — stays short where slices are long (the
/// Gaussian covering flowers at 4K: 135 slices of 240 tiles, 135 items of one slice instead of 9 of 16).
constexpr uint32_t kLargeChunkSlices = 16;
constexpr uint32_t kLargeChunkPairs = 256;

/// Slices per chunk of a walk of `slices` slices and `tiles` tiles (both ≥ 1):
/// clamp(floor(kLargeChunkPairs · slices / tiles), 1, kLargeChunkSlices). A chunk then holds
/// kLargeChunkPairs / 2 to kLargeChunkPairs pairs on average, or kLargeChunkSlices slices, or one slice.
RGS_HOST_DEVICE uint32_t large_chunk_slices(uint32_t slices, uint32_t tiles) {
  const uint64_t by_pairs = uint64_t(kLargeChunkPairs) * slices / tiles;
  return by_pairs < 1 ? 1u : by_pairs > kLargeChunkSlices ? kLargeChunkSlices : uint32_t(by_pairs);
}

/// One work item of emit_large_gaussians: slices [walk's first + first_slice, + slices) of a Gaussian with
/// more than kSerialTileLimit tiles (slices ≤ kLargeChunkSlices; a walk has at most 2,048 slices).
struct LargeGaussian {
  uint64_t offset;  ///< position of the Gaussian's first pair
  uint32_t g;       ///< Gaussian id, or kNoLargeGaussian for an unused item
  uint16_t first_slice;
  uint16_t slices;
};
constexpr uint32_t kNoLargeGaussian = 0xffffffffu;

/// Work items of a frame, in any order (each carries its pairs' positions, so the order does not reach the
/// output). A Gaussian that finds no room for its items (the list holds `capacity`) writes its pairs from its
/// own thread, as does every Gaussian when capacity is 0 (the ablation of the load balancing).
struct LargeGaussianList {
  LargeGaussian* items = nullptr;  ///< [capacity]
  unsigned long long* count = nullptr;  ///< [1] items taken (may exceed capacity); zeroed by the launchers
  uint64_t capacity = 0;
};

/// List capacity for a frame of `gaussians` Gaussians and at most `pairs` pairs: one item per Gaussian plus
/// one per kLargeChunkSlices pairs covers every walk whose slices all hold a tile (a chunk of fewer than
/// kLargeChunkSlices slices holds at least kLargeChunkPairs / 2 pairs on average; an AccuTile slice clipped
/// by the grid can be empty, hence the serial fallback).
inline uint64_t large_list_capacity(uint32_t gaussians, uint64_t pairs) {
  return uint64_t(gaussians) + pairs / kLargeChunkSlices + 1;
}

/// The fused kernel's pair totals, copied by the kernel that follows it into host memory that the device can
/// write, so that the host learns the pair count by polling that memory while the stream runs on, instead of
/// a copy and a stream synchronization after the kernel.
struct HostTotals {
  const unsigned long long* totals = nullptr;   ///< [2] device: FusedScratch::totals[0..1], final
  /// [3] pinned host memory mapped for the device (cudaHostAllocMapped): [0], [1] ← totals, then [2] ←
  /// sequence. Null: nothing is published.
  volatile unsigned long long* host = nullptr;
  unsigned long long sequence = 0;  ///< ≠ 0; a new value for every launch
};

/// Writes the pairs of every listed large Gaussian, one warp per work item (a chunk of consecutive slices of
/// its tile walk; a persistent grid takes them in turn), so that a Gaussian covering the frame is written by
/// many warps at once: a warp adds up the lengths of the slices before its chunk, a warp scan places the
/// chunk's slices, and the warp writes the chunk's pairs, one per lane.
/// Positions and keys are those the serial walk gives; positions ≥ capacity are skipped. Its first thread
/// publishes `totals` (unless totals.host is null) before any pair is written; without a list (capacity 0)
/// a one-thread kernel publishes them.
cudaError_t emit_large_gaussians(const RoofgsProjected& projected, const LargeGaussianList& large,
                                 const FrameParams& frame, const RoofgsFrame& roofgs, uint64_t capacity,
                                 uint64_t* keys64, uint32_t* keys32, uint32_t* values, const HostTotals& totals,
                                 cudaStream_t stream);

/// Preprocess of the separate stages (the fused kernel's twin, which no preset uses: a launch of the lab's,
/// RoofgsStages). Thread g writes Gaussian g's per-Gaussian outputs and its tile count tiles_touched[g] (0 when
/// culled); *large_pairs ([1], zeroed here) receives the pairs of the Gaussians with more than
/// kSubtileLargeTiles tiles, as FusedScratch::totals[1].
using PreprocessRoofgsStage = cudaError_t (*)(const GaussianSource& source, const FrameParams& frame,
                                              const RoofgsFrame& roofgs, const RoofgsProjected& out,
                                              unsigned long long* large_pairs, cudaStream_t stream);

/// Duplication of the separate stages (after PreprocessRoofgsStage and an inclusive scan of tiles_touched).
/// Thread g writes Gaussian g's pairs at [offsets[g−1], offsets[g]): its tiles in row-major order, or in
/// AccuTile's walk order; key = key32 ? tile << b_d | bin : tile << 32 | float_bits(depth); value = g.
/// Gaussians with more than kSerialTileLimit tiles go to `large` instead (emit_large_gaussians writes them).
using DuplicateRoofgsStage = cudaError_t (*)(const RoofgsProjected& projected, const uint64_t* offsets,
                                             uint32_t count, const FrameParams& frame, const RoofgsFrame& roofgs,
                                             const LargeGaussianList& large, uint64_t* keys64, uint32_t* keys32,
                                             uint32_t* values, cudaStream_t stream);

/// Scratch of the fused kernel's order-preserving allocation (decoupled look-back over thread blocks).
struct FusedScratch {
  uint32_t* block_ticket = nullptr;        ///< [1], zeroed by the launcher (block order only)
  unsigned long long* block_status = nullptr;  ///< [blocks], zeroed by the launcher (block order only)
  /// [kFusedTotals], zeroed by the launcher: [0] out: pairs of the frame (even beyond capacity); [1] out: of
  /// them, the pairs of Gaussians with more than kSubtileLargeTiles tiles (the automatic sub-tile culling's
  /// measure); [2] free for the launch's LargeGaussianList::count, which is then zeroed with the rest.
  unsigned long long* totals = nullptr;
};

/// Words of FusedScratch::totals, and the one a launch's LargeGaussianList::count may take.
inline constexpr int kFusedTotals = 3;
inline constexpr int kFusedLargeCount = 2;

/// Number of FusedScratch::block_status entries for `count` Gaussians.
uint32_t fused_blocks(uint32_t count);

/// One kernel for preprocess + tile count + allocation + key/value generation (paper's fused kernel). Each
/// block's pairs are allocated as `allocation` says. Pairs at positions ≥ capacity are not written;
/// totals[0] always receives the full count, and the caller runs the kernel again with enough capacity when
/// it exceeds `capacity`. Gaussians with more than kSerialTileLimit tiles are listed in `large` (with their
/// cov2d, snug_t and depth bin stored), and emit_large_gaussians must follow to write their pairs.
cudaError_t fused_preprocess_roofgs(const GaussianSource& source, const FrameParams& frame,
                                    const RoofgsFrame& roofgs, const RoofgsProjected& out,
                                    const FusedScratch& scratch, const LargeGaussianList& large, uint64_t capacity,
                                    PairAllocation allocation, uint64_t* keys64, uint32_t* keys32, uint32_t* values,
                                    cudaStream_t stream);

/// Depth order (RoofGS+, beyond the paper) after the stable sort of 32-bit keys, with the tile ranges. Pairs
/// whose keys tie (same tile and depth bin) leave the sort in emission order, i.e. by Gaussian id, which is
/// the 32-bit key's ordering loss (docs/DESIGN.md#32-bit-sort-key); this writes the sorted values with each run of tied
/// keys put in (view depth, id) order, so that every tile is in the order of the baseline's 64-bit key (tile, float
/// depth) — depth bins are non-decreasing in depth, so ordering within the runs orders the tile. Keys are unchanged. It
/// reads every key and its neighbours, so it also writes what tile_ranges would (same arguments), and a RoofGS+ frame
/// runs no separate ranges kernel.
/// @param sorted_keys    [count] 32-bit keys, sorted
/// @param sorted_values  [count] Gaussian ids, stably sorted with them
/// @param depths         [N] view-space z per Gaussian (RoofgsProjected::depths)
/// @param tile_shift     the key's depth bits (tile = key >> tile_shift)
/// @param values_out     [count] the reordered ids (not aliasing sorted_values)
/// @param ranges         [num_tiles, 2] out: per tile [begin, end) of its pairs, (0, 0) when it has none
/// A run inside a warp's 32 pairs is ranked with shuffles (one depth gather a pair, as many steps as the warp's
/// longest run); a run across a warp's ends costs O(L) reads a pair (the render's loop over the tile costs as
/// much).
cudaError_t order_equal_keys_by_depth(const uint32_t* sorted_keys, const uint32_t* sorted_values,
                                      const float* depths, uint64_t count, int tile_shift, uint32_t num_tiles,
                                      uint32_t* values_out, uint64_t* ranges, cudaStream_t stream);

/// Long tiles blended in chunks (beyond the paper; runtime::RoofgsOptions::tile_chunk_pairs, the rule in
/// kernels/shared/tile_chunks.h): a tile of more than chunk_pairs pairs is rendered by one block per chunk,
/// listed by list_tile_chunks; each chunk block leaves its pixels' T, C (and depth sums) in a record slot, and
/// the tile's last chunk block to finish merges the slots in chunk order and writes the pixels. Device arrays,
/// sized by the caller; with chunk_pairs == 0 the others are unused.
struct TileChunks {
  uint32_t chunk_pairs = 0;        ///< pairs per chunk (K); 0: off, one block per tile
  uint32_t capacity = 0;           ///< items and record slots: tile_chunk_capacity(pairs, K)
  /// Rows of tiles_x blocks that render_roofgs launches for the items before the tiles: ⌈capacity / tiles_x⌉.
  uint32_t item_rows = 0;
  uint2* items = nullptr;          ///< [capacity] (tile, chunk) of every chunk of every chunked tile
  uint32_t* item_count = nullptr;  ///< [1] items listed; 0 before list_tile_chunks
  /// [1] the next frame's item_count, zeroed by list_tile_chunks (so no frame needs a memset of its own).
  uint32_t* next_item_count = nullptr;
  uint32_t* first_item = nullptr;  ///< [tiles] a chunked tile's first item; its chunks follow in order
  uint32_t* arrivals = nullptr;    ///< [tiles] chunk blocks of the tile that have finished
  uint32_t* records = nullptr;     ///< [capacity, tile_chunk_record_words(depth), 128] the chunks' pixels
};

/// Items (chunk blocks and record slots) a frame of `pairs` pairs can need: Σ ⌈n/K⌉ over the tiles with
/// n > K pairs, at most 2·⌊pairs/K⌋ since each such tile has ⌊n/K⌋ ≥ 1.
inline uint64_t tile_chunk_capacity(uint64_t pairs, uint32_t chunk_pairs) {
  return chunk_pairs == 0 ? 0 : 2 * (pairs / chunk_pairs);
}

/// 32-bit words per thread of a chunk record: T as a binary16 pair, the two pixels' colours in FP32, and their
/// depth sums (Σ w·z, Σ w) with depth.
inline uint32_t tile_chunk_record_words(bool depth) { return depth ? 11 : 7; }

/// Lists the chunks of the tiles of more than chunks.chunk_pairs pairs into chunks.items (a tile's chunks
/// consecutive, tiles in any order: the pixels do not depend on it), counting them in *chunks.item_count
/// (which must be 0), and zeroes chunks.arrivals and *chunks.next_item_count. Needs chunks.chunk_pairs > 0 and
/// the ranges of a frame of at most the pairs chunks.capacity was sized for.
cudaError_t list_tile_chunks(const uint64_t* ranges, uint32_t tiles, const TileChunks& chunks, cudaStream_t stream);

/// Whether render_roofgs (the product's render stage) holds the render kernel `raster` needs: every variant but
/// the lab ones (is_lab_variant), which the lab's RoofgsStages render.
bool raster_variant_compiled(const RasterOptions& raster);

/// Render stage of the RoofGS pipeline. Same outputs and per-pixel rules as render_baseline; with `folded`,
/// α = min(0.99, exp(P)), P = C1·x² + C2·xy + C3·y² + C4·x + C5·y + C6 (skip P > 0), 128 threads per tile
/// (a warp per 8×8 quadrant, two vertically adjacent pixels per thread). `chunks` (with `folded` and
/// `half_blend`; listed by list_tile_chunks) renders the long tiles in chunks, before the other tiles.
/// cudaErrorNotSupported for a variant it lacks (raster_variant_compiled).
cudaError_t render_roofgs(const uint64_t* ranges, const TileChunks& chunks, const uint32_t* sorted_values,
                          const RoofgsProjected& projected, const FrameParams& frame, const RoofgsFrame& roofgs,
                          const RasterOptions& raster, const ImageView& image, cudaStream_t stream);

/// A render stage with render_roofgs's contract: render_roofgs itself, or one that also holds the variants the
/// presets do not reach (the lab's).
using RenderRoofgsStage = cudaError_t (*)(const uint64_t* ranges, const TileChunks& chunks,
                                          const uint32_t* sorted_values, const RoofgsProjected& projected,
                                          const FrameParams& frame, const RoofgsFrame& roofgs,
                                          const RasterOptions& raster, const ImageView& image, cudaStream_t stream);

/// The launches of the RoofGS pipeline that exist in variants no preset reaches, as the GPU renderer calls
/// them (runtime::GpuRenderOptions::stages), each once per pass. The default is the product's: no separate
/// stages (a frame needs the fused kernel) and render_roofgs; the lab's (lab/) give all of them.
struct RoofgsStages {
  PreprocessRoofgsStage preprocess = nullptr;  ///< null: the separate stages are not available
  DuplicateRoofgsStage duplicate = nullptr;    ///< with `preprocess`
  RenderRoofgsStage render = render_roofgs;
};

}  // namespace rgs::kernels
