// Precise tile culling of RoofGS (docs/DESIGN.md#snugbox-and-accutile), after Speedy-Splat (Hanson et al., CVPR 2025):
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

#include "rgs/kernels/shared/blend_math.h"  // kAlphaMin
#include "rgs/kernels/shared/fast_exp.h"    // kFastExpRangeMin
#include "rgs/kernels/shared/host_device.h"
#include "rgs/kernels/shared/projection.h"

namespace rgs::kernels {

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
/// dv = (s_uv·h ± sqrt(det·(t·s_uu − h²))) · inv_s_uu, with inv_s_uu = 1/s_uu computed once per walk (a product
/// instead of two divisions a line: within an ulp of the quotient, which moves a tile only at tangency, where
/// FP32 rounding decides either way). The radicand is clamped at 0 (|h| ≤ half_u up to rounding).
RGS_HOST_DEVICE void ellipse_line_intersections(float s_uu, float inv_s_uu, float s_uv, float det, float t, float h,
                                                float* dv_lo, float* dv_hi) {
  const float root = sqrtf(fmaxf(0.f, det * (t * s_uu - h * h)));
  *dv_lo = (s_uv * h - root) * inv_s_uu;
  *dv_hi = (s_uv * h + root) * inv_s_uu;
}

}  // namespace detail

/// AccuTile's walk of one SnugBox: the box's tile rectangle cut into slices along its shorter side (tile
/// rows when it has no more rows than columns, else columns). Axis u is the walked one (slice k covers tile
/// u = k), v the other; `slice_span` gives the tiles of one slice, so slices can be walked in any order or
/// in parallel (the preprocess counts long walks' slices over a thread block, emit_large_gaussians writes
/// them a warp per chunk).
struct AccutileWalk {
  bool walk_rows;               ///< u = y (slices are tile rows), else u = x
  int u_first, u_end;           ///< slices [u_first, u_end)
  int v_first, v_end;           ///< the rectangle's extent along v
  float mean_u, mean_v;         ///< projected mean along u and v (pixels)
  float half_u, half_v;         ///< SnugBox half extents along u and v
  float s_uu, s_vv, s_uv;       ///< Σ in (u, v) order
  float inv_s_uu;               ///< 1 / s_uu
  float det, t;                 ///< accurate det(Σ), SnugBox threshold
  float du_at_vmax;             ///< u-offset of the ellipse's max-v point (its min-v point is at the negation)
};

/// The walk of `box` inside `limit`; no slices (u_end ≤ u_first) when the SnugBox rectangle is empty.
RGS_HOST_DEVICE AccutileWalk make_accutile_walk(const SnugBox& box, const TileRect& limit) {
  const TileRect r = snugbox_rect(box, limit);
  AccutileWalk w;
  w.walk_rows = (r.y_max - r.y_min) <= (r.x_max - r.x_min);
  if (w.walk_rows) {
    w.u_first = r.y_min, w.u_end = r.y_max, w.v_first = r.x_min, w.v_end = r.x_max;
    w.mean_u = box.mean_y, w.mean_v = box.mean_x, w.half_u = box.half_y, w.half_v = box.half_x;
    w.s_uu = box.cov.yy, w.s_vv = box.cov.xx;
  } else {
    w.u_first = r.x_min, w.u_end = r.x_max, w.v_first = r.y_min, w.v_end = r.y_max;
    w.mean_u = box.mean_x, w.mean_v = box.mean_y, w.half_u = box.half_x, w.half_v = box.half_y;
    w.s_uu = box.cov.xx, w.s_vv = box.cov.yy;
  }
  if (is_empty(r)) w.u_end = w.u_first;
  w.s_uv = box.cov.xy;
  w.inv_s_uu = 1.f / w.s_uu;
  w.det = box.det;
  w.t = box.t;
  w.du_at_vmax = w.s_uv * w.half_v / w.s_vv;
  return w;
}

/// Tiles [*first, *end) along v of slice k (u_first ≤ k < u_end) whose pixel-centre rectangles meet the
/// ellipse; empty when *end ≤ *first.
RGS_HOST_DEVICE void accutile_slice(const AccutileWalk& w, int k, int* first, int* end) {
  const float tile = static_cast<float>(kTileSize);
  // The slice's pixel centres span [16k, 16k + 15] in u; keep the part inside the ellipse's u-range.
  const float lo = fmaxf(static_cast<float>(k) * tile, w.mean_u - w.half_u);
  const float hi = fminf(static_cast<float>(k) * tile + (tile - 1.f), w.mean_u + w.half_u);
  if (!(lo <= hi)) {
    *first = *end = w.v_first;
    return;
  }
  const float h_lo = lo - w.mean_u;
  const float h_hi = hi - w.mean_u;
  float lo_at_lo, hi_at_lo, lo_at_hi, hi_at_hi;
  detail::ellipse_line_intersections(w.s_uu, w.inv_s_uu, w.s_uv, w.det, w.t, h_lo, &lo_at_lo, &hi_at_lo);
  detail::ellipse_line_intersections(w.s_uu, w.inv_s_uu, w.s_uv, w.det, w.t, h_hi, &lo_at_hi, &hi_at_hi);
  // The ellipse part inside the slice is convex: its v-extremes are the ellipse's own extreme points when
  // they lie inside the slice, otherwise on the slice's boundary lines.
  const float dv_max =
      (h_lo <= w.du_at_vmax && w.du_at_vmax <= h_hi) ? w.half_v : fmaxf(hi_at_lo, hi_at_hi);
  const float dv_min =
      (h_lo <= -w.du_at_vmax && -w.du_at_vmax <= h_hi) ? -w.half_v : fminf(lo_at_lo, lo_at_hi);
  tiles_meeting_interval(w.mean_v + dv_min, w.mean_v + dv_max, w.v_first, w.v_end, first, end);
}

/// SnugBox + AccuTile: calls emit(tile_x, tile_y) once for every tile inside `limit` whose pixel-centre
/// rectangle meets the ellipse of `box`, and returns how many. Walks the slices of make_accutile_walk in
/// order, intersecting the ellipse with each slice's two boundary lines. Emission order: row-major when
/// walking rows, column-major otherwise (the sort key orders pairs, so the order does not reach the image).
template <typename Emit>
RGS_HOST_DEVICE uint32_t for_each_accutile_tile(const SnugBox& box, const TileRect& limit, Emit&& emit) {
  const AccutileWalk w = make_accutile_walk(box, limit);
  uint32_t count = 0;
  for (int k = w.u_first; k < w.u_end; ++k) {
    int first, end;
    accutile_slice(w, k, &first, &end);
    for (int v = first; v < end; ++v) {
      if (w.walk_rows) {
        emit(v, k);
      } else {
        emit(k, v);
      }
      ++count;
    }
  }
  return count;
}

/// Side of the sub-tiles of the folded rasterizer: each warp shades one 8×8 quadrant of a 16×16 tile.
constexpr int kSubtileSize = kTileSize / 2;

/// Margin (in the folded power P = power + ln o) by which subtile_mask keeps sub-tiles: the fast exp exceeds
/// exp by at most a factor (1 + f)/2^f ≤ 1.0615 for any σ in [0, 1) (ln 1.0615 = 0.0597), and the folded P a
/// pixel computes differs from the exact quadratic form by < 5e−4 at contributing pixels (asserted on 3,000
/// random Gaussians up to 40 px outside the tile in test_roofgs_math.cpp); 0.1 covers both with room
/// to spare.
constexpr float kSubtilePowerMargin = 0.1f;

namespace detail {

/// Minimum over s ∈ [lo, hi] of the conic's quadratic form along a box edge where the other offset is `fixed`,
/// written without cancellation as q = k·(s − s*)² + (D/k)·fixed² with s* = slope·fixed, slope = −b/k, k the
/// coefficient of s² (a along a row, c along a column) and D = a·c − b² (both terms ≥ 0, so needle-like
/// Gaussians, whose expanded terms reach ~1e6 for q ~ 10 on flowers at 4K, lose no precision).
RGS_HOST_DEVICE float edge_min_quadratic(float k, float slope, float d_over_k, float fixed, float lo, float hi) {
  const float s_star = slope * fixed;
  const float d = fminf(fmaxf(s_star, lo), hi) - s_star;
  return fmaf(k * d, d, d_over_k * (fixed * fixed));
}

}  // namespace detail

/// Sub-tile culling of the folded rasterizer (beyond the paper): bit (qx + 2·qy) of the result is set when the
/// Gaussian may reach alpha ≥ 1/255 at some pixel centre of the tile's 8×8 quadrant (qx, qy), i.e. when the
/// largest P = ln o − q/2 over the quadrant's pixel-centre box [8·qx, 8·qx + 7] × [8·qy, 8·qy + 7] (tile-local)
/// is at least ln(1/255) − kSubtilePowerMargin. q = a·dx² + 2b·dx·dy + c·dy² is the conic's quadratic form,
/// (dx, dy) = pixel − mean; its minimum over a box is 0 when the box holds the mean, else on an edge
/// (detail::edge_min_quadratic). A cleared bit is conservative: every pixel of that quadrant fails the 1/255
/// test (fast exp or expf), so skipping the pair there changes no output bit (tested on real pairs in
/// test_render_real.cpp, on random Gaussians in test_roofgs_math.cpp, and on the GPU). Caveat: the test is
/// against the exact quadratic form; where the rasterizer's folded FP32 P is itself off by more than the margin
/// (needle-like Gaussians on tiles ~1,000 px from their mean, which only 3σ rectangles hand them), a pixel
/// that passed by rounding alone is skipped (one pixel of one 4K flowers view, by 0.0015).
/// @param conic        conic (a, b, c) of the Gaussian (positive definite), pixel⁻² units
/// @param u, v         tile-local projected mean (mean − 16·(tx, ty)), pixels
/// @param log_opacity  ln o
RGS_HOST_DEVICE uint32_t subtile_mask(const Conic& conic, float u, float v, float log_opacity) {
  // D = a·c − b² with Kahan's FMA algorithm (accurate_determinant): it stays accurate for thin ellipses.
  const float w = conic.b * conic.b;
  const float det = fmaf(conic.a, conic.c, -w) + fmaf(-conic.b, conic.b, w);
  const float inv_a = 1.f / conic.a, inv_c = 1.f / conic.c;
  const float slope_x = -conic.b * inv_a, d_over_a = det * inv_a;
  const float slope_y = -conic.b * inv_c, d_over_c = det * inv_c;
  // P = ln o − q/2 ≥ ln(1/255) − margin  ⟺  q ≤ 2·(ln o + ln 255 + margin).
  const float q_limit = 2.f * (log_opacity - kFastExpRangeMin + kSubtilePowerMargin);
  constexpr float kLast = static_cast<float>(kSubtileSize - 1);
  uint32_t mask = 0;
  for (int qy = 0; qy < 2; ++qy) {
    const float dy0 = static_cast<float>(qy * kSubtileSize) - v, dy1 = dy0 + kLast;
    for (int qx = 0; qx < 2; ++qx) {
      const float dx0 = static_cast<float>(qx * kSubtileSize) - u, dx1 = dx0 + kLast;
      float q_min = 0.f;
      if (!(dx0 <= 0.f && 0.f <= dx1 && dy0 <= 0.f && 0.f <= dy1)) {
        q_min = fminf(fminf(detail::edge_min_quadratic(conic.a, slope_x, d_over_a, dy0, dx0, dx1),
                            detail::edge_min_quadratic(conic.a, slope_x, d_over_a, dy1, dx0, dx1)),
                      fminf(detail::edge_min_quadratic(conic.c, slope_y, d_over_c, dx0, dy0, dy1),
                            detail::edge_min_quadratic(conic.c, slope_y, d_over_c, dx1, dy0, dy1)));
      }
      if (q_min <= q_limit) mask |= 1u << (qx + 2 * qy);
    }
  }
  return mask;
}

/// Side of the blocks of block culling: each group of 8 lanes of the folded rasterizer shades one 4×4 block.
constexpr int kCullBlockSize = kSubtileSize / 2;
/// Blocks along a tile side (4) and per tile (16).
constexpr int kCullBlocksPerSide = kTileSize / kCullBlockSize;
constexpr int kCullBlocksPerTile = kCullBlocksPerSide * kCullBlocksPerSide;

namespace detail {

/// Bits j (0 ≤ j < kCullBlocksPerSide) of the blocks whose pixel-centre span [4j, 4j + 3] lies within h of c
/// (tile-local pixels): dist(c, span)² ≤ h2 = h², with no square root. A NaN or infinite h2, or a NaN c, keeps
/// every block; a mean so far away that dist² overflows keeps none.
RGS_HOST_DEVICE uint32_t block_span_bits(float c, float h2) {
  uint32_t bits = 0;
  for (int j = 0; j < kCullBlocksPerSide; ++j) {
    const float first = static_cast<float>(j * kCullBlockSize), last = first + float(kCullBlockSize - 1);
    const float d = fmaxf(fmaxf(first - c, c - last), 0.f);
    if (!(d * d > h2)) bits |= 1u << j;
  }
  return bits;
}

}  // namespace detail

/// Block culling (beyond the paper), the finer form of subtile_mask for Gaussians small next to a quadrant:
/// bit (bx + 4·by) is set when the 4×4 block (bx, by), pixels [4·bx, 4·bx + 3] × [4·by, 4·by + 3] (tile-local),
/// meets the bounding box of the ellipse q ≤ q_limit of subtile_mask (the same margin), so a cleared bit is
/// conservative as subtile_mask's are (the same caveat): skipping the pair on that block changes no output bit.
/// The smallest q on the column dx = const is dx²·D/c (D = a·c − b²), so the box's half extents are
/// sqrt(q_limit·c/D) and sqrt(q_limit·a/D), compared squared with each block's distance from the mean. Tight
/// for the small round Gaussians of dense scenes; a long thin one keeps the blocks of its box. The rasterizer
/// computes the mask as it loads each pair, so its cost counts: intersecting the box with subtile_mask's
/// quadrants where it reaches all four clears a few more blocks of tilted Gaussians, but a warp would run the
/// quadrant test whenever one of its 32 pairs needed it; and the squared comparison in place of two square
/// roots keeps the kernel at 64 registers, eight blocks an SM (both measured on taebak:
/// docs/lab/TRIED.md#tried-and-not-kept).
/// @param conic          conic (a, b, c) of the Gaussian (positive definite), pixel⁻² units
/// @param u, v           tile-local projected mean, pixels
/// @param log_opacity    ln o
RGS_HOST_DEVICE uint32_t block_mask(const Conic& conic, float u, float v, float log_opacity) {
  const float w = conic.b * conic.b;
  const float det = fmaf(conic.a, conic.c, -w) + fmaf(-conic.b, conic.b, w);
  const float q_limit = 2.f * (log_opacity - kFastExpRangeMin + kSubtilePowerMargin);
  const float scale = q_limit / det;  // half extents² = q_limit·c/D and q_limit·a/D
  const uint32_t columns = detail::block_span_bits(u, scale * conic.c);
  const uint32_t rows = detail::block_span_bits(v, scale * conic.a);
  // Row bit r to bit 4r; the product places a copy of the column bits in each kept row (no carries: < 16).
  const uint32_t row_starts = (rows & 1u) | (rows & 2u) << 3 | (rows & 4u) << 6 | (rows & 8u) << 9;
  return columns * row_starts;
}

/// Intersection of two tile rectangles (may be empty).
RGS_HOST_DEVICE TileRect intersect(const TileRect& a, const TileRect& b) {
  return TileRect{max_int(a.x_min, b.x_min), max_int(a.y_min, b.y_min), min_int(a.x_max, b.x_max),
                  min_int(a.y_max, b.y_max)};
}

}  // namespace rgs::kernels
