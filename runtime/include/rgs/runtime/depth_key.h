// The 32-bit sort key's per-frame layout (RoofgsOptions::key32; docs/DESIGN.md#32-bit-sort-key): one
// function for the CPU reference renderer and the GPU frame plan, so both quantize depth the same way.
#pragma once

#include <cstdint>
#include <optional>

#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/kernels/shared/sort_key.h"
#include "rgs/runtime/camera.h"

namespace rgs::runtime {

/// Layout of the 32-bit key tile << depth_bits | depth bin for one camera.
struct DepthKey {
  /// Tile bits b_t = ceil(log2(tiles)) and depth bits 32 − b_t.
  int tile_bits = 0, depth_bits = 0;
  /// Quantizer of view depth over [z_near, z_far] (world units) into 2^depth_bits bins.
  kernels::DepthQuantizer quantizer{0, 0, 0, 0, 0};
  /// True when the depth range [z_near, z_far] is empty (the scene sphere is behind the camera): nothing is
  /// visible.
  bool empty_depth_range = false;
  /// Gaussians with view depth outside [cull_z_min, cull_z_max] are culled: [z_near, z_far] widened by
  /// 1e-5·(|d_c| + r) + 1e-6, so that a Gaussian on the sphere's surface whose z rounds just outside is kept
  /// (its bin clamps to 0 or 2^b_d − 1, the clamp the paper keeps "against numerical round-off").
  float cull_z_min = 0, cull_z_max = 0;
};

/// The key layout for `camera` over a tiles_x × tiles_y grid: the depth range [z_near, z_far] that the
/// bounding sphere and the AABB of the means both allow (view depths of the sphere's near and far points and
/// of the AABB's corners, at least the near plane), its quantizer and culling bounds. Every mean must lie in
/// both (as in a .rgs file's metadata or converter::compute_bounds); Gaussians outside are culled.
/// Errors: kInvalidArgument (no bounds, non-finite sphere, non-finite or inverted AABB), kLimitExceeded
/// (fewer than 8 depth bits left).
Result<DepthKey> make_depth_key(const Camera& camera, const std::optional<format::SceneBounds>& bounds,
                                uint32_t tiles_x, uint32_t tiles_y);

}  // namespace rgs::runtime
