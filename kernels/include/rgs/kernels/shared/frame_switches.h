// What the RoofGS kernels are told about a frame: the technique switches, the 32-bit key's layout, where the
// fused kernel allocates pairs and which rasterizer variant blends. Plain data without CUDA types, so that the
// host-side frame plan (runtime/frame_plan.h) is built and tested without a CUDA toolchain.
#pragma once

#include <cstdint>

#include "rgs/kernels/shared/sort_key.h"

namespace rgs::kernels {

/// Technique switches and per-frame key layout of a RoofGS frame (passed by value).
struct RoofgsFrame {
  /// Read the compact .rgs sections (FP16 geometry, INT8 SH) and dequantize in registers; else FP32.
  bool compact = false;
  /// 32-bit keys: tile << b_d | depth bin; Gaussians with depth outside [cull_z_min, cull_z_max] culled.
  bool key32 = false;
  /// SnugBox + AccuTile tile culling (kernels/shared/tile_culling.h); cull o ≤ 1/255.
  bool snugbox_accutile = false;
  /// With snugbox_accutile: limit the tiles to the baseline rectangle (see runtime::RoofgsOptions).
  bool accutile_within_baseline_rect = true;
  /// Fast exp α = min(0.99, exp̂(P)) with this σ (kernels/shared/fast_exp.h).
  bool fast_exp = false;
  float fast_exp_sigma = 0.045677f;
  /// key32 layout: depth bits b_d (tile bits 32 − b_d) and the per-camera quantizer.
  int key_depth_bits = 0;
  DepthQuantizer quantizer{0, 0, 0, 0, 0};
  float cull_z_min = 0, cull_z_max = 0;
  bool empty_depth_range = false;
};

/// Where the fused kernel puts the pairs of each thread block.
enum class PairAllocation {
  /// After all pairs of the blocks before it (decoupled look-back): pairs come out in emission order, as with
  /// the separate stages, so equal keys leave the stable sort in the same order every run.
  kBlockOrder,
  /// Where the block arrives (one atomicAdd, as the public RoofGS code allocates): no block waits for its
  /// predecessors, but pairs with equal keys leave the sort in an order that varies between runs. Only for
  /// frames whose tied keys order_equal_keys_by_depth reorders afterwards: its (depth, id) order of each run
  /// does not depend on the order it receives, so the final pairs and image are the same as with kBlockOrder.
  kArrivalOrder,
};

/// With SnugBox + AccuTile, sub-tile culling pays only where a frame's pairs come from Gaussians small next to
/// a 4×4 block: a large Gaussian's tiles are those its ellipse reaches, their blocks nearly all covered,
/// so its pairs cost the mask and gain nothing (with 3σ rectangles its corner tiles are empty, and the culling
/// pays). The automatic choice (runtime::SubtileCulling::kAuto) turns it off when SnugBox + AccuTile is on and
/// more than kSubtileMaxLargePairFraction of the pairs belong to Gaussians with more than kSubtileLargeTiles
/// tiles.
/// Fractions measured with the CPU reference's preprocess (SnugBox + AccuTile, 3 views each): flowers
/// 0.66–0.71 at 1080p, 0.89–0.92 at 4K, 0.98 at 8K; flowers ×53 0.60 / 0.82; daffodils 0.01 / 0.05;
/// daffodils ×4 0.003 / 0.02 (1080p / 4K). What the culling gains and costs on those scenes:
/// docs/lab/TRIED.md#tried-and-not-kept.
constexpr uint32_t kSubtileLargeTiles = 32;
constexpr double kSubtileMaxLargePairFraction = 0.5;

/// The automatic choice above for a frame of `pairs` pairs, `large_pairs` of them from Gaussians with more
/// than kSubtileLargeTiles tiles: whether its rasterizer culls 4×4 blocks.
constexpr bool auto_block_culling(bool snugbox_accutile, uint64_t pairs, uint64_t large_pairs) {
  return !snugbox_accutile || double(large_pairs) <= kSubtileMaxLargePairFraction * double(pairs);
}

/// Rasterizer switches.
struct RasterOptions {
  /// Folded C1..C6 in tile-local coordinates, hoisted pixel terms, two vertically adjacent pixels per thread.
  bool folded = false;
  /// Fast exp (σ from RoofgsFrame) instead of expf.
  bool fast_exp = false;
  /// With `folded` (beyond the paper): each group of 8 lanes skips the pairs that cannot reach alpha 1/255
  /// on its 4×4 block (block_mask in shared/tile_culling.h), so that a Gaussian a few pixels wide costs the
  /// lanes of the blocks it reaches and not the whole warp. Fewer iterations, the same output bits (up to
  /// subtile_mask's caveat on pairs whose folded P is dominated by its own FP32 rounding); with half_blend the
  /// colour windows follow the lists, so the colour moves by their roundings (T and depth keep their bits).
  bool subtile_culling = false;
  /// With `folded` and `fast_exp` (beyond the paper): α, T and the colour window of a thread's two pixels in
  /// binary16, one half2 instruction for both, the closed windows' colour in FP32 (shared/half_blend.h);
  /// ignored otherwise.
  bool half_blend = false;
};

/// Whether `raster` renders with a lab variant of the kernel. The product (kernels::render_roofgs) compiles the
/// variants the presets reach: fastest (folded, fast exp, binary16 blending, sub-tile culling on or off) and
/// paper (folded, fast exp, FP32 blending, no culling), besides the baseline kernel of faithful. The lab (lab/,
/// RGS_BUILD_LAB) compiles the others: the RoofGS pixel kernel, the folded kernel without the fast exp, FP32
/// blending with culling (the one-technique ablations, comparison modes).
inline bool is_lab_variant(const RasterOptions& raster) {
  if (!raster.folded || !raster.fast_exp) return true;  // the RoofGS pixel kernel, folded without fast exp
  return !raster.half_blend && raster.subtile_culling;  // FP32 blending with culling
}

}  // namespace rgs::kernels
