// Sort keys of the (tile, Gaussian) pairs: the baseline 64-bit key tile << 32 | float_bits(depth), and the
// RoofGS 32-bit key with resolution-adaptive bit allocation (paper §"Resolution-Adaptive Sorting-Key
// Encoding", Eq. depth_quant; docs/DESIGN.md#32-bit-sort-key).
#pragma once

#include "rgs/kernels/shared/host_device.h"

namespace rgs::kernels {

/// Baseline 3DGS key: tile id in the high 32 bits, the IEEE-754 bits of the view-space depth in the low
/// 32 bits. Depths are > 0 (culled at the near plane), so their bit patterns order like the floats.
RGS_HOST_DEVICE uint64_t make_key64(uint32_t tile, float depth) {
  return (static_cast<uint64_t>(tile) << 32) | float_as_uint(depth);
}

/// Tile bits of the 32-bit key: b_t = ceil(log2(num_tiles)) (0 for a single tile). 1080p: 8,160 tiles →
/// 13; 4K: 32,400 → 15; 8K (7680×4320): 129,600 → 17. `num_tiles` ≥ 1.
RGS_HOST_DEVICE int key32_tile_bits(uint32_t num_tiles) {
  int bits = 0;
  while (bits < 32 && (uint64_t{1} << bits) < num_tiles) ++bits;
  return bits;
}

/// Depth bits of the 32-bit key: b_d = 32 − b_t.
RGS_HOST_DEVICE int key32_depth_bits(uint32_t num_tiles) { return 32 - key32_tile_bits(num_tiles); }

/// Per-camera depth quantization of the 32-bit key. Built by make_depth_quantizer().
struct DepthQuantizer {
  float z_near;      ///< view-space depth of bin 0
  float z_far;       ///< view-space depth of the last bin; z_far > z_near
  float max_level;   ///< 2^b_d − 1 as a float (rounded to float for b_d > 24)
  uint32_t max_bin;  ///< 2^b_d − 1 as an integer (the clamp bound)
  int depth_bits;    ///< b_d
};

/// Quantizer for `depth_bits` bits over [z_near, z_far]. The range comes from the scene's bounds: the paper's
/// bounding sphere (centre at view-space depth d_c, radius r), z_near = max(near plane, d_c − r), z_far =
/// d_c + r, narrowed to the view depths of the AABB of the means (runtime::make_depth_key); callers cull
/// Gaussians outside it (paper: they "do not participate in sorting").
RGS_HOST_DEVICE DepthQuantizer make_depth_quantizer(float z_near, float z_far, int depth_bits) {
  DepthQuantizer q;
  q.z_near = z_near;
  q.z_far = z_far;
  q.depth_bits = depth_bits;
  q.max_bin = depth_bits >= 32 ? 0xffffffffu : static_cast<uint32_t>((uint64_t{1} << depth_bits) - 1);
  q.max_level = static_cast<float>(q.max_bin);
  return q;
}

/// Paper Eq. depth_quant: q = clamp(floor((d − z_near) / (z_far − z_near) · (2^b_d − 1)), 0, 2^b_d − 1),
/// evaluated in FP32 in exactly this order (subtract, subtract, divide, multiply, floor); the clamp happens on
/// the float before the conversion, so out-of-range or NaN depths give 0 or 2^b_d − 1, never undefined
/// behaviour. Monotonically non-decreasing in d.
RGS_HOST_DEVICE uint32_t quantize_depth(float depth, const DepthQuantizer& q) {
  const float level = floorf((depth - q.z_near) / (q.z_far - q.z_near) * q.max_level);
  if (!(level > 0.f)) return 0;  // also NaN
  if (level >= q.max_level) return q.max_bin;
  return static_cast<uint32_t>(level);
}

/// RoofGS 32-bit key: the tile id in the high b_t bits, the quantized depth in the low b_d bits.
/// `tile` < 2^b_t and `depth_bin` ≤ 2^b_d − 1.
RGS_HOST_DEVICE uint32_t make_key32(uint32_t tile, uint32_t depth_bin, int depth_bits) {
  if (depth_bits >= 32) return depth_bin;
  return static_cast<uint32_t>((static_cast<uint64_t>(tile) << depth_bits) | depth_bin);
}

}  // namespace rgs::kernels
