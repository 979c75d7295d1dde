// The 32-bit sort key's per-frame layout, shared by the CPU reference and the GPU frame plan.
#include "rgs/runtime/depth_key.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace rgs::runtime {

namespace {

namespace k = rgs::kernels;

/// A 32-bit key must keep at least this many depth bits (b_t ≤ 24); every image validate_camera accepts
/// (32768² → 22 tile bits) satisfies it.
constexpr int kMinKeyDepthBits = 8;

}  // namespace

Result<DepthKey> make_depth_key(const Camera& camera, const std::optional<format::SceneBounds>& bounds, uint32_t tiles_x,
                                uint32_t tiles_y) {
  DepthKey key;
  RGS_RETURN_ERROR_IF(!bounds, StatusCode::kInvalidArgument,
                      "render: the 32-bit key needs scene bounds (RenderOptions::scene_bounds)");
  const format::SceneBounds& b = *bounds;
  RGS_RETURN_ERROR_IF(!std::isfinite(b.sphere_radius) || b.sphere_radius < 0 || !std::isfinite(b.sphere_center[0]) ||
                          !std::isfinite(b.sphere_center[1]) || !std::isfinite(b.sphere_center[2]),
                      StatusCode::kInvalidArgument, "render: scene bounding sphere is not finite");
  for (int a = 0; a < 3; ++a) {
    RGS_RETURN_ERROR_IF(!std::isfinite(b.aabb_min[a]) || !std::isfinite(b.aabb_max[a]) || b.aabb_min[a] > b.aabb_max[a],
                        StatusCode::kInvalidArgument, "render: scene AABB is not finite, or its min exceeds its max");
  }
  const uint32_t num_tiles = tiles_x * tiles_y;
  key.tile_bits = k::key32_tile_bits(num_tiles);
  key.depth_bits = 32 - key.tile_bits;
  RGS_RETURN_ERROR_IF(key.depth_bits < kMinKeyDepthBits, StatusCode::kLimitExceeded,
                      "render: " + std::to_string(num_tiles) + " tiles leave only " +
                          std::to_string(key.depth_bits) + " depth bits in a 32-bit key");
  // View-space depths (the z row of R·p + t, in double, once per camera) of the sphere centre and of the
  // AABB's corners. Every mean lies in both (format::validate checks them against the AABB), so the range is
  // their intersection: on taebak's aerial views the AABB's range is the narrower one, which leaves fewer
  // pairs in runs of tied keys (docs/lab/TRIED.md#tried-and-not-kept).
  const auto& R = camera.rotation;
  const auto view_depth = [&](double x, double y, double z) {
    return double(R[6]) * x + double(R[7]) * y + double(R[8]) * z + camera.translation[2];
  };
  const double d_c = view_depth(b.sphere_center[0], b.sphere_center[1], b.sphere_center[2]);
  double box_near = std::numeric_limits<double>::infinity(), box_far = -box_near, magnitude = 0;
  for (int corner = 0; corner < 8; ++corner) {
    const double p[3] = {(corner & 1) ? b.aabb_max[0] : b.aabb_min[0], (corner & 2) ? b.aabb_max[1] : b.aabb_min[1],
                         (corner & 4) ? b.aabb_max[2] : b.aabb_min[2]};
    const double z = view_depth(p[0], p[1], p[2]);
    box_near = std::min(box_near, z);
    box_far = std::max(box_far, z);
    magnitude = std::max(magnitude, std::fabs(R[6] * p[0]) + std::fabs(R[7] * p[1]) + std::fabs(R[8] * p[2]));
  }
  const float z_near = static_cast<float>(std::max({double(camera.near_plane), d_c - b.sphere_radius, box_near}));
  const float z_far = static_cast<float>(std::min(d_c + b.sphere_radius, box_far));
  key.empty_depth_range = !(z_far > z_near);
  key.quantizer = k::make_depth_quantizer(z_near, key.empty_depth_range ? z_near + 1.f : z_far,
                                            key.depth_bits);
  // Means inside the bounds can still round to a depth just outside [z_near, z_far] through the float view
  // transform, whose error grows with its terms; keep them (their bin clamps) rather than cull them.
  const double margin =
      1e-5 * std::max(std::fabs(d_c) + b.sphere_radius, magnitude + std::fabs(camera.translation[2])) + 1e-6;
  key.cull_z_min = static_cast<float>(double(z_near) - margin);
  key.cull_z_max = static_cast<float>(double(z_far) + margin);
  return key;
}

}  // namespace rgs::runtime
