// Switches of the RoofGS techniques, shared by the CPU reference renderer and the GPU renderer.
#pragma once

#include <cstdint>

#include "rgs/kernels/shared/fast_exp.h"

namespace rgs::runtime {

/// RoofGS techniques of the renderer (docs/DESIGN.md#render-pipeline, items 1-6); each switch is independent, and with
/// all of them off the renderer is the 3DGS baseline, bit for bit. On the CPU, compact attributes (item 1) need no
/// switch: render the dequantized cloud of a .rgs file. The GPU renderer adds the switches that only exist there
/// (compact attributes read in registers, the fused kernel: gpu_renderer.h).
struct RoofgsOptions {
  /// 32-bit keys (item 2): tile id in the high b_t = ceil(log2(num_tiles)) bits, depth quantized to
  /// b_d = 32 − b_t bits over [z_near, z_far] = [max(near, d_c − r), d_c + r] from the scene's bounding sphere
  /// (centre at view depth d_c, radius r); Gaussians outside that range (up to a rounding margin,
  /// DepthKey::cull_z_min/max) are culled. Stable sort (ties keep Gaussian index order). Needs
  /// RenderOptions::scene_bounds.
  bool key32 = false;
  /// SnugBox + AccuTile (item 4): cull o ≤ 1/255, and give each Gaussian exactly the tiles whose pixel
  /// centres its alpha ≥ 1/255 ellipse reaches (kernels/shared/tile_culling.h) instead of the 3DGS rectangle.
  bool snugbox_accutile = false;
  /// With snugbox_accutile: also limit the tiles to the baseline 3DGS rectangle, so culling only removes
  /// tiles (at o close to 1 the 1/255 ellipse reaches 3.33σ, past the baseline's 3σ radius). Off reproduces
  /// Speedy-Splat, which then adds contributions the baseline does not have.
  bool accutile_within_baseline_rect = true;
  /// Folded coefficients C1..C6 in tile-local coordinates with the dual-pixel update (item 5): each
  /// "thread" shades (x, y) and (x, y+1), the second through P(x, y+1) = P(x, y) + C2·x + C3·(2y+1) + C5.
  /// α = min(0.99, exp(P)) with P = power + ln(o); a pair is skipped when P > 0 (the folded form of the
  /// baseline's power > 0 guard).
  bool folded_coefficients = false;
  /// Schraudolph fast exp (item 6): α = min(0.99, exp̂(P)), P = power + ln(o) (folded or not).
  bool fast_exp = false;
  /// σ of the FP32 fast exp: kFastExpSigmaMinMax (0.045677, the paper's) or e.g. kFastExpSigmaZeroMean.
  float fast_exp_sigma = kernels::kFastExpSigmaMinMax;
  /// With folded_coefficients and fast_exp (beyond the paper): blend in binary16 (kernels/shared/half_blend.h).
  /// The power P stays FP32; α = min(0.990234, exp̂16), the fast exp with a binary16 result and a quadratic
  /// mantissa correction (relative error ≤ 0.41 %; fast_exp_sigma does not apply), skipped below 1/255 (the
  /// clamp takes the place of the 0.99 clamp and the P > 0 skip); T and C are binary16, two pixels per half2
  /// instruction on the GPU, emulated bit for bit on the CPU. Ignored without folded_coefficients and fast_exp.
  bool half_blend = false;
  /// With half_blend (beyond the paper): a tile with more than K = max(this, ⌈pairs / 2048⌉) pairs (pairs: the
  /// frame's) is blended in chunks of K consecutive pairs, each from T = 1, merged front to back; no chunks in
  /// a frame where Gaussians of more than 32 tiles hold more than half the pairs (kernels/shared/tile_chunks.h
  /// frame_chunk_pairs: the rule, and what it changes against the unchunked blend: at most one pair's weight
  /// of α·1e−4/(1 − α) ≤ 0.0102 beyond rounding). The GPU renders each chunk as its own thread block, so no
  /// tile holds one block for the whole frame. 0: off. Ignored without half_blend.
  uint32_t tile_chunk_pairs = 0;

  /// Emit pairs in order of (view depth, Gaussian index) instead of Gaussian index (RoofGS+, beyond the
  /// paper): pairs whose 32-bit keys tie (same tile and depth bin) then keep exact depth order through the
  /// stable sort, which removes the quantized key's ordering loss (docs/DESIGN.md#32-bit-sort-key). The GPU
  /// gets that order from a pass after the sort (order_equal_keys_by_depth). No effect on the image without
  /// key32, except for Gaussians at exactly equal depth.
  bool depth_order = false;

  /// All four techniques on (the paper's combination), default σ.
  static RoofgsOptions all() {
    RoofgsOptions o;
    o.key32 = o.snugbox_accutile = o.folded_coefficients = o.fast_exp = true;
    return o;
  }
};

}  // namespace rgs::runtime
