// Precise tile culling of RoofGS (DESIGN.md RoofGS item 4), after Speedy-Splat (Hanson et al., CVPR 2025):
// SnugBox, the tight bounding box of the ellipse where a Gaussian's alpha reaches 1/255, and AccuTile, which
// walks that box along its shorter axis one tile row (or column) at a time and emits only the tiles whose
// pixels the ellipse reaches.
//
// Geometry. A pixel at integer coordinates (x, y) receives alpha = o·exp(−q/2) with
// q = a·dx² + 2b·dx·dy + c·dy² (conic a, b, c; dx = px − x), so alpha ≥ 1/255 iff q ≤ t, t = 2·ln(255·o).
// The ellipse q ≤ t has, with Σ the dilated 2D covariance (Σ = conic⁻¹),
//   half extents      hx = sqrt(t·Σxx), hy = sqrt(t·Σyy),
//   x-extreme points  (±hx, ±Σxy·hx/Σxx), y-extreme points (±Σxy·hy/Σyy, ±hy)  (offsets from the mean),
//   on the line dy = h:  dx = (Σxy·h ± sqrt(det·(t·Σyy − h²))) / Σyy, det = Σxx·Σyy − Σxy²,
// and the same with x and y exchanged. Working from Σ rather than from the conic avoids the cancellation of
// b² − a·c for thin ellipses, and det is computed with Kahan's FMA algorithm (accurate_determinant): the
// plain xx·yy − xy² of preprocess loses ~cond·1e−7 relatively (cond = xx·yy/det reaches 1e4 for needle-like
// Gaussians), which would move the ellipse's boundary by that much.
//
// Tiles. Tile (tx, ty) holds the pixel centres [16·tx, 16·tx + 15] × [16·ty, 16·ty + 15]; a tile is emitted
// iff the ellipse meets that rectangle (the convex hull of its pixel centres), which is exactly the set of
// tiles where a pixel could pass the 1/255 alpha test, up to float rounding at tangency. (Speedy-Splat
// intersects with the half-open squares [16·tx, 16·tx + 16), which adds tiles the ellipse reaches only
// between pixel centres.) The result is further limited to a caller-given rectangle: the image's tile grid,
// and in RoofGS mode by default also the baseline 3DGS rectangle, so the culled set never contains a tile the
// baseline would not visit.
#pragma once

#include "rgs/kernels/shared/host_device.h"
#include "rgs/kernels/shared/projection.h"

namespace rgs::kernels {

/// The smallest alpha a Gaussian may contribute with (3DGS skips alpha < 1/255).
constexpr float kAlphaMin = 1.0f / 255.0f;

/// SnugBox threshold t = 2·ln(255·o) of a Gaussian with opacity o: its pixels reach alpha ≥ 1/255 only where
/// the quadratic form q ≤ t. Returns false (cull the Gaussian) when o ≤ 1/255 or t is not positive, since such
/// a Gaussian can never pass the 1/255 test.
RGS_HOST_DEVICE bool snugbox_threshold(float opacity, float* t) {
  if (!(opacity > kAlphaMin)) return false;
  *t = 2.f * logf(255.f * opacity);
  return *t > 0.f;
}

/// Tiles k whose pixel-centre span [16k, 16k + 15] meets the closed interval [lo, hi] (pixel coordinates),
/// limited to [limit_min, limit_max). Writes the half-open range [*first, *end); empty when *end <= *first.
/// Computed as first = ceil((lo − 15)/16), end = floor(hi/16) + 1, clamped in float before conversion so
/// that huge or non-finite bounds stay defined.
RGS_HOST_DEVICE void tiles_meeting_interval(float lo, float hi, int limit_min, int limit_max, int* first,
                                            int* end) {
  const float tile = static_cast<float>(kTileSize);
  const float f = fminf(fmaxf(ceilf((lo - (tile - 1.f)) / tile), static_cast<float>(limit_min)),
                        static_cast<float>(limit_max));
  const float e = fminf(fmaxf(floorf(hi / tile) + 1.f, static_cast<float>(limit_min)),
                        static_cast<float>(limit_max));
  *first = static_cast<int>(f);
  *end = static_cast<int>(e);
}

/// xx·yy − xy² with Kahan's FMA algorithm (error ≤ 1.5 ulp of the result, even when the two products almost
/// cancel): w = xy², e = fma(−xy, xy, w) = w − xy² exactly, det = fma(xx, yy, −w) + e.
RGS_HOST_DEVICE float accurate_determinant(const Cov2& cov) {
  const float w = cov.xy * cov.xy;
  const float e = fmaf(-cov.xy, cov.xy, w);
  const float f = fmaf(cov.xx, cov.yy, -w);
  return f + e;
}

/// SnugBox of a Gaussian: the ellipse q ≤ t around the pixel-space mean.
struct SnugBox {
  float mean_x, mean_y;  ///< projected mean in pixels
  float half_x, half_y;  ///< sqrt(t·Σxx), sqrt(t·Σyy)
  Cov2 cov;              ///< dilated 2D covariance Σ
  float det;             ///< accurate_determinant(Σ) (> 0 for a dilated covariance)
  float t;               ///< 2·ln(255·o) > 0
};

/// Builds the SnugBox of a Gaussian with mean (px, py), dilated 2D covariance `cov` (positive definite) and
/// threshold `t` (> 0, from snugbox_threshold()).
RGS_HOST_DEVICE SnugBox make_snugbox(float px, float py, const Cov2& cov, float t) {
  SnugBox box;
  box.mean_x = px;
  box.mean_y = py;
  box.half_x = sqrtf(t * cov.xx);
  box.half_y = sqrtf(t * cov.yy);
  box.cov = cov;
  box.det = accurate_determinant(cov);
  box.t = t;
  return box;
}

/// Tile rectangle of the SnugBox: tiles whose pixel-centre rectangle meets the box
/// [px − hx, px + hx] × [py − hy, py + hy], limited to `limit` (the grid, possibly further intersected with
/// the baseline rectangle).
RGS_HOST_DEVICE TileRect snugbox_rect(const SnugBox& box, const TileRect& limit) {
  TileRect r;
  tiles_meeting_interval(box.mean_x - box.half_x, box.mean_x + box.half_x, limit.x_min, limit.x_max, &r.x_min,
                         &r.x_max);
  tiles_meeting_interval(box.mean_y - box.half_y, box.mean_y + box.half_y, limit.y_min, limit.y_max, &r.y_min,
                         &r.y_max);
  return r;
}

namespace detail {

/// Offsets dv of the two points where the line du = h meets the ellipse, for the axis pair (u, v):
/// dv = (s_uv·h ± sqrt(det·(t·s_uu − h²))) / s_uu. The radicand is clamped at 0 (|h| ≤ half_u up to rounding).
RGS_HOST_DEVICE void ellipse_line_intersections(float s_uu, float s_uv, float det, float t, float h, float* dv_lo,
                                                float* dv_hi) {
  const float root = sqrtf(fmaxf(0.f, det * (t * s_uu - h * h)));
  *dv_lo = (s_uv * h - root) / s_uu;
  *dv_hi = (s_uv * h + root) / s_uu;
}

/// AccuTile along axis u (the walked axis) with v the other axis. Emits emit(u_tile, v_tile) for every tile
/// of rect [u_first, u_end) × [v_first, v_end) whose pixel-centre rectangle meets the ellipse.
template <typename Emit>
RGS_HOST_DEVICE uint32_t accutile_walk(float mean_u, float mean_v, float half_u, float half_v, float s_uu,
                                       float s_vv, float s_uv, float det, float t, int u_first, int u_end,
                                       int v_first, int v_end, Emit&& emit) {
  const float tile = static_cast<float>(kTileSize);
  // u-offset of the ellipse's max-v point; its min-v point is at the negated offset.
  const float du_at_vmax = s_uv * half_v / s_vv;
  uint32_t count = 0;
  for (int k = u_first; k < u_end; ++k) {
    // The slice's pixel centres span [16k, 16k + 15] in u; keep the part inside the ellipse's u-range.
    const float lo = fmaxf(static_cast<float>(k) * tile, mean_u - half_u);
    const float hi = fminf(static_cast<float>(k) * tile + (tile - 1.f), mean_u + half_u);
    if (!(lo <= hi)) continue;
    const float h_lo = lo - mean_u;
    const float h_hi = hi - mean_u;
    float lo_at_lo, hi_at_lo, lo_at_hi, hi_at_hi;
    ellipse_line_intersections(s_uu, s_uv, det, t, h_lo, &lo_at_lo, &hi_at_lo);
    ellipse_line_intersections(s_uu, s_uv, det, t, h_hi, &lo_at_hi, &hi_at_hi);
    // The ellipse part inside the slice is convex: its v-extremes are the ellipse's own extreme points when
    // they lie inside the slice, otherwise on the slice's boundary lines.
    const float dv_max = (h_lo <= du_at_vmax && du_at_vmax <= h_hi) ? half_v : fmaxf(hi_at_lo, hi_at_hi);
    const float dv_min = (h_lo <= -du_at_vmax && -du_at_vmax <= h_hi) ? -half_v : fminf(lo_at_lo, lo_at_hi);
    int first, end;
    tiles_meeting_interval(mean_v + dv_min, mean_v + dv_max, v_first, v_end, &first, &end);
    for (int v = first; v < end; ++v) {
      emit(k, v);
      ++count;
    }
  }
  return count;
}

}  // namespace detail

/// SnugBox + AccuTile: calls emit(tile_x, tile_y) once for every tile inside `limit` whose pixel-centre
/// rectangle meets the ellipse of `box`, and returns how many. Walks the SnugBox rectangle along its shorter
/// side (tile rows when it has no more rows than columns, else columns), intersecting the ellipse with each
/// slice's two boundary lines. Emission order: row-major when walking rows, column-major otherwise (the sort
/// key orders pairs, so the order does not reach the image).
template <typename Emit>
RGS_HOST_DEVICE uint32_t for_each_accutile_tile(const SnugBox& box, const TileRect& limit, Emit&& emit) {
  const TileRect r = snugbox_rect(box, limit);
  if (is_empty(r)) return 0;
  const bool walk_rows = (r.y_max - r.y_min) <= (r.x_max - r.x_min);
  if (walk_rows) {
    return detail::accutile_walk(box.mean_y, box.mean_x, box.half_y, box.half_x, box.cov.yy, box.cov.xx,
                                 box.cov.xy, box.det, box.t, r.y_min, r.y_max, r.x_min, r.x_max,
                                 [&emit](int ty, int tx) { emit(tx, ty); });
  }
  return detail::accutile_walk(box.mean_x, box.mean_y, box.half_x, box.half_y, box.cov.xx, box.cov.yy,
                               box.cov.xy, box.det, box.t, r.x_min, r.x_max, r.y_min, r.y_max,
                               [&emit](int tx, int ty) { emit(tx, ty); });
}

/// Intersection of two tile rectangles (may be empty).
RGS_HOST_DEVICE TileRect intersect(const TileRect& a, const TileRect& b) {
  return TileRect{max_int(a.x_min, b.x_min), max_int(a.y_min, b.y_min), min_int(a.x_max, b.x_max),
                  min_int(a.y_max, b.y_max)};
}

}  // namespace rgs::kernels
