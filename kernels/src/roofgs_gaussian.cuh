// Device functions shared by the RoofGS preprocess kernels (separate and fused): reading one Gaussian from
// the compact or FP32 attributes, projecting it (the CPU reference's preprocess_cpu, step for step), and
// walking its tiles in emission order.
#pragma once

#include <cuda_fp16.h>

#include <cstdint>

#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/sort_key.h"
#include "rgs/kernels/shared/spherical_harmonics.h"
#include "rgs/kernels/shared/tile_culling.h"

namespace rgs::kernels::detail {

/// A projected Gaussian in registers.
struct ProjectedRegs {
  float depth;
  float px, py;
  Cov2 cov;
  Conic conic;
  float opacity, log_opacity;
  float rgb[3];
  int radius;
  TileRect rect;     ///< 3DGS rectangle
  float snug_t;      ///< SnugBox threshold (snugbox_accutile)
  uint32_t depth_bin;///< key32
  uint32_t tiles;    ///< pairs it emits; 0 = culled
};

__device__ inline float half_bits_to_float(uint16_t bits) { return __half2float(__ushort_as_half(bits)); }

/// Value j of Gaussian g's SH block [K, 3] (j = 3k + c), dequantized as s[degree(k)][c]·q: one rounded
/// product, as format::dequantize on the host.
__device__ inline float dequantize_sh(const CompactGaussiansView& c, uint32_t g, int j) {
  const uint64_t k_count = uint64_t(sh_coefficients_for(int(c.sh_degree)));
  const int8_t q = c.sh[uint64_t(g) * k_count * 3 + uint64_t(j)];
  return c.sh_scales[sh_degree_of_coefficient(j / 3)][j % 3] * static_cast<float>(q);
}

/// Gaussian g's geometry and opacity, dequantized in registers when compact (same values as
/// kernels::dequantize and format::dequantize: FP16 widened exactly, exp of log scales).
template <bool kCompact>
__device__ inline void load_geometry(const GaussianSource& src, uint32_t g, float mean[3], float scale[3],
                                     float q[4], float* opacity) {
  if constexpr (kCompact) {
    const CompactGaussiansView& c = src.compact;
    for (int a = 0; a < 3; ++a) mean[a] = c.means[3 * uint64_t(g) + a];
    // 8-byte rotation and 2-byte loads; the 6-byte scale is read as three halves.
    const uint2 r = *reinterpret_cast<const uint2*>(c.rotations + 4 * uint64_t(g));
    q[0] = half_bits_to_float(uint16_t(r.x & 0xffffu));
    q[1] = half_bits_to_float(uint16_t(r.x >> 16));
    q[2] = half_bits_to_float(uint16_t(r.y & 0xffffu));
    q[3] = half_bits_to_float(uint16_t(r.y >> 16));
    for (int a = 0; a < 3; ++a) {
      const float v = half_bits_to_float(c.scales[3 * uint64_t(g) + a]);
      scale[a] = c.scale_encoding == CompactScaleEncoding::kLog ? expf(v) : v;
    }
    *opacity = half_bits_to_float(c.opacities[g]);
  } else {
    const Fp32GaussiansView& f = src.fp32;
    for (int a = 0; a < 3; ++a) mean[a] = f.means[3 * uint64_t(g) + a];
    const float4 r = *reinterpret_cast<const float4*>(f.rotations + 4 * uint64_t(g));
    q[0] = r.x;
    q[1] = r.y;
    q[2] = r.z;
    q[3] = r.w;
    for (int a = 0; a < 3; ++a) scale[a] = f.scales[3 * uint64_t(g) + a];
    *opacity = f.opacities[g];
  }
}

/// Colour of Gaussian g along the unit direction (x, y, z): the SH coefficients dequantized in registers
/// when compact (s[d][c]·q, one rounded product as on the host), then sh_to_colour.
template <bool kCompact>
__device__ inline void load_colour(const GaussianSource& src, uint32_t g, float x, float y, float z,
                                   float rgb[3]) {
  const uint32_t degree = kCompact ? src.compact.sh_degree : src.fp32.sh_degree;
  const int k_count = sh_coefficients_for(int(degree));
  if constexpr (kCompact) {
    float sh[kMaxShCoefficients * 3];
#pragma unroll
    for (int j = 0; j < kMaxShCoefficients * 3; ++j) sh[j] = j < k_count * 3 ? dequantize_sh(src.compact, g, j) : 0.f;
    sh_to_colour(sh, int(degree), x, y, z, rgb);
  } else {
    sh_to_colour(src.fp32.sh + uint64_t(g) * uint64_t(k_count) * 3, int(degree), x, y, z, rgb);
  }
}

/// Tiles a visible Gaussian may receive under AccuTile: the grid, limited to the baseline rectangle when
/// requested (runtime cpu_renderer.cpp accutile_limit).
__device__ inline TileRect accutile_limit(const FrameParams& frame, const RoofgsFrame& roofgs,
                                          const TileRect& baseline_rect) {
  const TileRect grid{0, 0, int(frame.tiles_x), int(frame.tiles_y)};
  return roofgs.accutile_within_baseline_rect ? intersect(grid, baseline_rect) : grid;
}

/// Projects Gaussian g (preprocess_cpu's steps and order). Returns false when it is culled.
template <bool kCompact>
__device__ inline bool project_gaussian(const GaussianSource& src, uint32_t g, const FrameParams& frame,
                                        const RoofgsFrame& roofgs, ProjectedRegs* p) {
  float mean[3], scale[3], q[4], opacity;
  load_geometry<kCompact>(src, g, mean, scale, q, &opacity);
  float p_cam[3];
  world_to_camera(frame.view_rotation, frame.view_translation, mean, p_cam);
  if (!(p_cam[2] > frame.near_plane)) return false;
  if (roofgs.key32 &&
      (roofgs.empty_depth_range || p_cam[2] < roofgs.cull_z_min || p_cam[2] > roofgs.cull_z_max)) {
    return false;
  }
  float cov3d[6];
  covariance_3d(scale, q, cov3d);
  const Cov2 cov = ewa_covariance_2d(cov3d, frame.view_rotation, p_cam, frame.fx, frame.fy, frame.ewa_clamp);
  const float det = determinant(cov);
  if (det == 0.f) return false;
  const Conic conic = conic_from_covariance(cov, det);
  const int radius = screen_radius(cov, det);
  float px, py;
  project_to_pixel(p_cam, frame.fx, frame.fy, frame.cx, frame.cy, &px, &py);
  if (!isfinite(px) || !isfinite(py) || !isfinite(conic.a) || !isfinite(conic.b) || !isfinite(conic.c)) {
    return false;
  }
  const TileRect rect = tile_rect(px, py, radius, int(frame.tiles_x), int(frame.tiles_y));
  if (tile_area(rect) == 0) return false;

  p->depth = p_cam[2];
  p->px = px;
  p->py = py;
  p->cov = cov;
  p->conic = conic;
  p->opacity = opacity;
  p->log_opacity = logf(opacity);
  p->radius = radius;
  p->rect = rect;
  p->snug_t = 0.f;
  p->tiles = uint32_t(tile_area(rect));
  if (roofgs.snugbox_accutile) {
    float t = 0.f;
    if (!snugbox_threshold(opacity, &t)) return false;
    p->snug_t = t;
    const SnugBox box = make_snugbox(px, py, cov, t);
    p->tiles = for_each_accutile_tile(box, accutile_limit(frame, roofgs, rect), [](int, int) {});
    if (p->tiles == 0) return false;
  }
  float dir[3] = {mean[0] - frame.camera_centre[0], mean[1] - frame.camera_centre[1],
                  mean[2] - frame.camera_centre[2]};
  const float length = sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  for (float& d : dir) d = d / length;
  load_colour<kCompact>(src, g, dir[0], dir[1], dir[2], p->rgb);
  p->depth_bin = roofgs.key32 ? quantize_depth(p->depth, roofgs.quantizer) : 0u;
  return true;
}

/// Stores the per-Gaussian outputs the later stages read.
__device__ inline void store_projected(const ProjectedRegs& p, uint32_t g, const RoofgsProjected& out) {
  out.depths[g] = p.depth;
  reinterpret_cast<float2*>(out.means2d)[g] = make_float2(p.px, p.py);
  reinterpret_cast<float4*>(out.conic_opacity)[g] = make_float4(p.conic.a, p.conic.b, p.conic.c, p.opacity);
  out.log_opacities[g] = p.log_opacity;
  out.rgb[3 * uint64_t(g)] = p.rgb[0];
  out.rgb[3 * uint64_t(g) + 1] = p.rgb[1];
  out.rgb[3 * uint64_t(g) + 2] = p.rgb[2];
  out.radii[g] = p.radius;
}

/// Calls emit(tile_x, tile_y) for each tile of a visible Gaussian in emission order: its 3DGS rectangle
/// row-major, or AccuTile's walk (cpu_renderer.cpp for_each_tile_of).
template <typename Emit>
__device__ inline void for_each_tile(float px, float py, const Cov2& cov, float snug_t, const TileRect& rect,
                                     const FrameParams& frame, const RoofgsFrame& roofgs, Emit&& emit) {
  if (roofgs.snugbox_accutile) {
    const SnugBox box = make_snugbox(px, py, cov, snug_t);
    for_each_accutile_tile(box, accutile_limit(frame, roofgs, rect), emit);
    return;
  }
  for (int ty = rect.y_min; ty < rect.y_max; ++ty) {
    for (int tx = rect.x_min; tx < rect.x_max; ++tx) emit(tx, ty);
  }
}

/// Writes the pairs of one Gaussian starting at `offset` (skipping positions ≥ capacity).
__device__ inline void emit_pairs(const ProjectedRegs& p, uint32_t g, uint64_t offset, uint64_t capacity,
                                  const FrameParams& frame, const RoofgsFrame& roofgs, uint64_t* keys64,
                                  uint32_t* keys32, uint32_t* values) {
  for_each_tile(p.px, p.py, p.cov, p.snug_t, p.rect, frame, roofgs, [&](int tx, int ty) {
    if (offset < capacity) {
      const uint32_t tile = uint32_t(ty) * frame.tiles_x + uint32_t(tx);
      if (roofgs.key32) {
        keys32[offset] = make_key32(tile, p.depth_bin, roofgs.key_depth_bits);
      } else {
        keys64[offset] = make_key64(tile, p.depth);
      }
      values[offset] = g;
    }
    ++offset;
  });
}

}  // namespace rgs::kernels::detail
