// RoofGS math against independent formulations: AccuTile tile sets vs a brute-force per-tile ellipse test,
// 32-bit key bit allocation and depth quantization, folded coefficients and the dual-pixel update vs direct
// evaluation, and the fast exp's error bound.
#include <algorithm>
#include <array>
#include <cmath>
#include <iterator>
#include <limits>
#include <random>
#include <set>
#include <utility>
#include <vector>

#include "render_test_util.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/sort_key.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/kernels/shared/tile_culling.h"

namespace rgs::test {
namespace {

namespace k = rgs::kernels;

/// Bounds of a sphere at (0, 0, z) with radius r, its AABB the sphere's box.
format::SceneBounds sphere_bounds(float z, float r) {
  format::SceneBounds b;
  b.sphere_center[2] = z;
  b.sphere_radius = r;
  for (int a = 0; a < 3; ++a) {
    b.aabb_min[a] = b.sphere_center[a] - r;
    b.aabb_max[a] = b.sphere_center[a] + r;
  }
  return b;
}
using TileSet = std::set<std::pair<int, int>>;

/// Minimum over the tile's pixel-centre rectangle [16tx, 16tx+15] × [16ty, 16ty+15] of the quadratic form
/// q(d) = dᵀ·Σ⁻¹·d (d = pixel − mean), in double. A convex quadratic's minimum over a box is 0 if the box
/// holds the mean, otherwise on one of the four edges, where it is a 1D quadratic minimized in closed form.
double min_quadratic_over_tile(const k::Cov2& cov, float px, float py, int tx, int ty) {
  const double det = double(cov.xx) * cov.yy - double(cov.xy) * cov.xy;
  const double A = cov.yy / det, B = -double(cov.xy) / det, C = cov.xx / det;
  const double x0 = 16.0 * tx - px, x1 = 16.0 * tx + 15 - px;
  const double y0 = 16.0 * ty - py, y1 = 16.0 * ty + 15 - py;
  if (x0 <= 0 && 0 <= x1 && y0 <= 0 && 0 <= y1) return 0;
  auto q = [&](double dx, double dy) { return A * dx * dx + 2 * B * dx * dy + C * dy * dy; };
  double best = std::numeric_limits<double>::infinity();
  for (double dx : {x0, x1}) {  // vertical edges: minimize over dy
    const double dy = std::clamp(-B * dx / C, y0, y1);
    best = std::min(best, q(dx, dy));
  }
  for (double dy : {y0, y1}) {  // horizontal edges: minimize over dx
    const double dx = std::clamp(-B * dy / A, x0, x1);
    best = std::min(best, q(dx, dy));
  }
  return best;
}

/// Brute force (tests only): every tile of `limit` whose pixel-centre rectangle meets q ≤ t.
TileSet brute_force_tiles(const k::Cov2& cov, float px, float py, float t, const k::TileRect& limit,
                          std::vector<double>* margins) {
  TileSet tiles;
  for (int ty = limit.y_min; ty < limit.y_max; ++ty) {
    for (int tx = limit.x_min; tx < limit.x_max; ++tx) {
      const double m = min_quadratic_over_tile(cov, px, py, tx, ty);
      if (m <= t) tiles.insert({tx, ty});
      if (margins) margins->push_back(std::fabs(m - t) / t);
    }
  }
  return tiles;
}

/// Random dilated 2D covariance: eigenvalues log-uniform in [1e-3, 1e4] px² (ratios up to 1e7: very thin
/// ellipses), random orientation, plus the 0.3 dilation as in preprocess.
k::Cov2 random_cov(std::mt19937& rng) {
  std::uniform_real_distribution<double> log_eig(-3.0, 4.0), angle(0.0, 3.141592653589793);
  const double l1 = std::pow(10.0, log_eig(rng)), l2 = std::pow(10.0, log_eig(rng));
  const double a = angle(rng), c = std::cos(a), s = std::sin(a);
  return k::Cov2{float(c * c * l1 + s * s * l2 + 0.3), float(c * s * (l1 - l2)), float(s * s * l1 + c * c * l2 + 0.3)};
}

TEST_CASE("AccuTile tile sets equal a brute-force per-tile ellipse test, and stay inside the baseline rect") {
  std::mt19937 rng(20261121);
  std::uniform_int_distribution<int> side(1, 300);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int cases = 0, culled = 0, mismatches = 0, borderline_mismatches = 0, thin = 0;
  uint64_t tiles_accutile = 0, tiles_baseline = 0, outside_baseline_unclipped = 0;
  for (int iter = 0; iter < 6000; ++iter) {
    const int W = side(rng), H = side(rng);
    const int gx = k::tile_count_for(W), gy = k::tile_count_for(H);
    // Means on and off screen (up to 150 px outside).
    const float px = float(-150 + unit(rng) * (W + 300)), py = float(-150 + unit(rng) * (H + 300));
    const k::Cov2 cov = random_cov(rng);
    const float det = k::determinant(cov);
    if (!(det > 0)) continue;
    // Opacities log-uniform in [1e-3, 1]: some at or below 1/255 (culled).
    const float opacity = float(std::pow(10.0, -3.0 * unit(rng)));
    ++cases;
    const double ratio = std::max(cov.xx, cov.yy) / (double(det) / std::max(cov.xx, cov.yy));
    if (ratio > 1e3) ++thin;
    float t = 0;
    if (!k::snugbox_threshold(opacity, &t)) {
      CHECK(opacity <= k::kAlphaMin * 1.0001f);
      ++culled;
      continue;
    }
    const k::TileRect grid{0, 0, gx, gy};
    const k::TileRect baseline = k::tile_rect(px, py, k::screen_radius(cov, det), gx, gy);
    const k::SnugBox box = k::make_snugbox(px, py, cov, t);
    for (bool clip : {true, false}) {
      const k::TileRect limit = clip ? k::intersect(grid, baseline) : grid;
      TileSet accutile;
      const uint32_t count = k::for_each_accutile_tile(box, limit, [&](int tx, int ty) {
        const bool fresh = accutile.insert({tx, ty}).second;
        CHECK(fresh);  // each tile once
      });
      CHECK(count == accutile.size());
      std::vector<double> margins;
      const TileSet brute = brute_force_tiles(cov, px, py, t, limit, nullptr);
      if (accutile != brute) {
        // Allowed only at tangency, where FP32 rounding decides: the tile's minimum of q is within 1e-4·t of t.
        TileSet diff;
        std::set_symmetric_difference(accutile.begin(), accutile.end(), brute.begin(), brute.end(),
                                      std::inserter(diff, diff.begin()));
        for (auto [tx, ty] : diff) {
          const double m = min_quadratic_over_tile(cov, px, py, tx, ty);
          ++mismatches;
          if (std::fabs(m - t) <= 1e-4 * t) ++borderline_mismatches;
          CHECK_MESSAGE(std::fabs(m - t) <= 1e-4 * t, "tile (" << tx << "," << ty << ") min q " << m << " vs t " << t
                                                               << " px " << px << " py " << py << " cov " << cov.xx
                                                               << " " << cov.xy << " " << cov.yy);
        }
      }
      for (auto [tx, ty] : accutile) {
        CHECK(tx >= limit.x_min);
        CHECK(tx < limit.x_max);
        CHECK(ty >= limit.y_min);
        CHECK(ty < limit.y_max);
        if (!clip && (tx < baseline.x_min || tx >= baseline.x_max || ty < baseline.y_min || ty >= baseline.y_max)) {
          ++outside_baseline_unclipped;
        }
      }
      if (clip) {
        tiles_accutile += accutile.size();
        tiles_baseline += uint64_t(k::tile_area(baseline));
      }
    }
  }
  MESSAGE("AccuTile vs brute force: " << cases << " Gaussians (" << culled << " culled at o <= 1/255, " << thin
                                      << " with axis ratio > 1e3), " << mismatches << " tile mismatches ("
                                      << borderline_mismatches << " at tangency); tiles " << tiles_accutile
                                      << " vs baseline rect " << tiles_baseline << "; unclipped sets had "
                                      << outside_baseline_unclipped << " tiles outside the baseline rect");
  CHECK(cases > 5000);
  CHECK(mismatches == borderline_mismatches);
  CHECK(mismatches <= 3);
  CHECK(tiles_accutile < tiles_baseline);
}

TEST_CASE("AccuTile: a hand-checked thin diagonal ellipse and a Gaussian outside the image") {
  // Σ with eigenvalues 1e4 and 0.3 along the diagonal: a long thin streak from the top-left to the bottom-right
  // tile of a 4×4 grid. Its box covers all 16 tiles, but only the diagonal band is touched.
  const double l1 = 1e4, l2 = 0.3;
  const k::Cov2 cov{float((l1 + l2) / 2), float((l1 - l2) / 2), float((l1 + l2) / 2)};
  float t = 0;
  REQUIRE(k::snugbox_threshold(0.9f, &t));
  const k::SnugBox box = k::make_snugbox(31.5f, 31.5f, cov, t);
  const k::TileRect grid{0, 0, 4, 4};
  TileSet got;
  k::for_each_accutile_tile(box, grid, [&](int tx, int ty) { got.insert({tx, ty}); });
  const TileSet diagonal = {{0, 0}, {1, 1}, {2, 2}, {3, 3}, {0, 1}, {1, 0}, {1, 2}, {2, 1}, {2, 3}, {3, 2}};
  // The streak is ~3.3·sqrt(0.3)·sqrt(2) ≈ 2.6 px wide across the diagonal: near the tile corners it touches
  // the neighbours of the diagonal tiles, never the far corners.
  for (auto tile : got) CHECK(diagonal.count(tile) == 1);
  CHECK(got.count({0, 0}) == 1);
  CHECK(got.count({3, 3}) == 1);
  CHECK(got.count({0, 3}) == 0);
  CHECK(got.count({3, 0}) == 0);
  CHECK(got == brute_force_tiles(cov, 31.5f, 31.5f, t, grid, nullptr));
  // Mean far left of the image, footprint not reaching it: no tile.
  const k::SnugBox away = k::make_snugbox(-100.f, 20.f, k::Cov2{100.f, 0.f, 100.f}, t);
  CHECK(k::for_each_accutile_tile(away, grid, [](int, int) {}) == 0);
  // o <= 1/255 is culled explicitly.
  CHECK_FALSE(k::snugbox_threshold(1.f / 255.f, &t));
  CHECK_FALSE(k::snugbox_threshold(0.f, &t));
}

TEST_CASE("32-bit key: resolution-adaptive bits at 1080p, 4K and 8K") {
  struct Case {
    int w, h, tile_bits;
  };
  for (const Case c : {Case{1920, 1080, 13}, Case{3840, 2160, 15}, Case{7680, 4320, 17}, Case{16, 16, 0},
                       Case{32, 16, 1}, Case{1024, 1024, 12}, Case{1040, 1024, 13}}) {
    CAPTURE(c.w);
    const uint32_t tiles = uint32_t(k::tile_count_for(c.w) * k::tile_count_for(c.h));
    CHECK(k::key32_tile_bits(tiles) == c.tile_bits);
    CHECK(k::key32_depth_bits(tiles) == 32 - c.tile_bits);
    // The same through the renderer's frame setup.
    format::GaussianCloud cloud;
    add_gaussian(&cloud, 0.f, 0.f, 5.f, 0.1f, 0.5f, 0.f, 0.f, 0.f);
    runtime::RenderOptions options;
    options.roofgs.key32 = true;
    options.scene_bounds = sphere_bounds(5.f, 2.f);
    const auto frame = runtime::setup_frame(cloud, identity_camera(uint32_t(c.w), uint32_t(c.h), 1000.f), options);
    REQUIRE(frame.ok());
    CHECK(frame->key.tile_bits == c.tile_bits);
    CHECK(frame->key.depth_bits == 32 - c.tile_bits);
    // Depth range from the sphere: [max(0.2, 5 − 2), 5 + 2].
    CHECK(frame->key.quantizer.z_near == 3.f);
    CHECK(frame->key.quantizer.z_far == 7.f);
  }
  // 1080p: 120×68 = 8160 tiles → the largest tile id 8159 fits 13 bits and 2^19 − 1 depth bins remain.
  const k::DepthQuantizer q = k::make_depth_quantizer(1.f, 81.f, 19);
  CHECK(q.max_bin == (1u << 19) - 1);
  CHECK(k::make_key32(8159, q.max_bin, 19) == 0xffffffffu - ((8191u - 8159u) << 19));
}

TEST_CASE("32-bit key: Gaussians outside the scene sphere's depth range are culled, its surface is kept") {
  // Sphere centre (0, 0, 5), radius 2, identity camera: [z_near, z_far] = [3, 7].
  format::GaussianCloud cloud;
  for (float z : {2.5f, 3.f, 5.f, 7.f, 7.5f}) add_gaussian(&cloud, 0.f, 0.f, z, 0.05f, 0.9f, 0.f, 0.f, 0.f);
  runtime::RenderOptions options;
  options.roofgs.key32 = true;
  options.scene_bounds = sphere_bounds(5.f, 2.f);
  const runtime::Camera cam = identity_camera(64, 48, 50.f);
  auto frame = runtime::setup_frame(cloud, cam, options);
  REQUIRE(frame.ok());
  runtime::RenderStats stats;
  const auto g = runtime::preprocess_cpu(cloud, cam, *frame, options, &stats);
  CHECK(g[0].tiles_touched == 0);  // z = 2.5 < 3
  CHECK(g[1].tiles_touched > 0);   // on the near surface: bin 0
  CHECK(g[1].depth_bin == 0);
  CHECK(g[2].depth_bin == uint32_t(std::floor(0.5 * frame->key.quantizer.max_level)));
  CHECK(g[3].tiles_touched > 0);  // on the far surface: the last bin
  CHECK(g[3].depth_bin == frame->key.quantizer.max_bin);
  CHECK(g[4].tiles_touched == 0);  // z = 7.5 > 7
  CHECK(stats.culled_depth_range == 2);
  // The rendered keys carry the bins: 64×48 → 4×3 = 12 tiles → 4 tile bits, 28 depth bits.
  CHECK(frame->key.tile_bits == 4);
  auto bins = runtime::bin_and_sort_cpu(g, *frame, options);
  REQUIRE(bins.ok());
  for (size_t p = 0; p < bins->keys.size(); ++p) {
    CHECK(bins->keys[p] < (uint64_t{1} << 32));
    CHECK((bins->keys[p] & ((1u << 28) - 1)) == g[bins->values[p]].depth_bin);
  }
  // Sphere behind the camera: nothing is visible, no error.
  options.scene_bounds = sphere_bounds(-10.f, 2.f);
  const auto out = render_ok(cloud, cam, options);
  CHECK(out.stats.visible == 0);
  CHECK(out.stats.culled_depth_range == 5);
}

TEST_CASE("32-bit key: the AABB of the means narrows the sphere's depth range, and only where it lies inside") {
  // Identity camera: view depth = world z. Sphere (0, 0, 5), radius 2: [3, 7].
  format::GaussianCloud cloud;
  for (float z : {3.5f, 4.f, 5.f, 6.f, 6.5f}) add_gaussian(&cloud, 0.f, 0.f, z, 0.05f, 0.9f, 0.f, 0.f, 0.f);
  runtime::RenderOptions options;
  options.roofgs.key32 = true;
  format::SceneBounds bounds = sphere_bounds(5.f, 2.f);
  bounds.aabb_min[2] = 4.f;  // the means' box spans z in [4, 6]
  bounds.aabb_max[2] = 6.f;
  options.scene_bounds = bounds;
  const runtime::Camera cam = identity_camera(64, 48, 50.f);
  const auto frame = runtime::setup_frame(cloud, cam, options);
  REQUIRE(frame.ok());
  CHECK(frame->key.quantizer.z_near == 4.f);
  CHECK(frame->key.quantizer.z_far == 6.f);
  runtime::RenderStats stats;
  const auto g = runtime::preprocess_cpu(cloud, cam, *frame, options, &stats);
  CHECK(g[1].depth_bin == 0);  // on the box's near face
  CHECK(g[2].depth_bin == uint32_t(std::floor(0.5 * frame->key.quantizer.max_level)));
  CHECK(g[3].depth_bin == frame->key.quantizer.max_bin);  // on its far face
  CHECK(stats.culled_depth_range == 2);  // 3.5 and 6.5 lie outside the box the bounds promise
  // [z_near, z_far] of the key for `b` seen by `camera`.
  const auto depth_range = [&](const format::SceneBounds& b, const runtime::Camera& camera) {
    options.scene_bounds = b;
    const auto setup = runtime::setup_frame(cloud, camera, options);
    REQUIRE(setup.ok());
    return std::array<float, 2>{setup->key.quantizer.z_near, setup->key.quantizer.z_far};
  };
  // A box wider than the sphere leaves the sphere's range; a camera turned sideways sees the box's x extent.
  bounds.aabb_min[2] = 1.f;
  bounds.aabb_max[2] = 9.f;
  CHECK(depth_range(bounds, cam) == std::array<float, 2>{3.f, 7.f});
  runtime::Camera side = cam;  // looks along world +x: view z = world x + 5
  side.rotation = {0, 0, -1, 0, 1, 0, 1, 0, 0};
  side.translation = {0, 0, 5};
  bounds = sphere_bounds(0.f, 2.f);
  bounds.aabb_min[0] = -0.5f;
  bounds.aabb_max[0] = 1.f;
  CHECK(depth_range(bounds, side) == std::array<float, 2>{4.5f, 6.f});
}

TEST_CASE("depth quantization: monotonic, clamped, and ordered by tile first") {
  std::mt19937 rng(7);
  for (int bits : {15, 17, 19, 21, 32}) {
    CAPTURE(bits);
    const k::DepthQuantizer q = k::make_depth_quantizer(0.7f, 83.f, bits);
    CHECK(k::quantize_depth(0.7f, q) == 0);
    CHECK(k::quantize_depth(83.f, q) == q.max_bin);
    CHECK(k::quantize_depth(-5.f, q) == 0);           // below: clamped
    CHECK(k::quantize_depth(1e9f, q) == q.max_bin);   // above: clamped
    CHECK(k::quantize_depth(NAN, q) == 0);
    std::uniform_real_distribution<float> depth(0.5f, 84.f);
    std::vector<float> d(200000);
    for (float& v : d) v = depth(rng);
    d.push_back(0.7f);
    d.push_back(std::nextafter(0.7f, 1.f));
    d.push_back(std::nextafter(83.f, 0.f));
    std::sort(d.begin(), d.end());
    uint32_t previous = 0;
    for (float v : d) {
      const uint32_t bin = k::quantize_depth(v, q);
      CHECK(bin >= previous);
      previous = bin;
      if (bin < previous) break;
    }
    // Two depths a full bin width apart never share a bin (bits ≤ 24, where the level is exact in float).
    if (bits <= 24) {
      const float step = (83.f - 0.7f) / q.max_level;
      CHECK(k::quantize_depth(40.f + 2.f * step, q) > k::quantize_depth(40.f, q));
    }
  }
  // Tile in the high bits: any key of tile 5 sorts before any key of tile 6.
  CHECK(k::make_key32(5, (1u << 19) - 1, 19) < k::make_key32(6, 0, 19));
  CHECK(k::make_key64(5, 1e30f) < k::make_key64(6, 0.2f));
  CHECK(k::make_key64(5, 0.3f) < k::make_key64(5, 0.30001f));
}

TEST_CASE("folded coefficients in tile-local coordinates and the dual-pixel update equal the direct power") {
  // Reference: the baseline power of the same float conic evaluated in double, plus ln o. FP32 folding cannot
  // beat the rounding of its largest intermediate term, so the error is measured in units of
  // eps·S, S = (|a|(|u|+16)² + 2|b|(|u|+16)(|v|+16) + |c|(|v|+16)²)/2 + |ln o| (a bound on every term of the
  // expansion for tile-local pixels 0..15 and 0..16 for the second row), eps = 2^-23.
  std::mt19937 rng(99);
  std::uniform_real_distribution<double> local(-40.0, 56.0), unit(0.0, 1.0);
  const double eps = std::ldexp(1.0, -23);
  double worst_units = 0, worst_dual_units = 0, worst_direct = 0, worst_abs_coords = 0;
  for (int iter = 0; iter < 3000; ++iter) {
    const k::Cov2 cov = random_cov(rng);
    const float det = k::determinant(cov);
    if (!(det > 0)) continue;
    const k::Conic conic = k::conic_from_covariance(cov, det);
    const float opacity = float(0.004 + 0.996 * unit(rng));
    const float log_o = std::log(opacity);
    const float u = float(local(rng)), v = float(local(rng));  // mean relative to the tile origin
    const k::FoldedCoefficients c = k::fold_coefficients(conic, u, v, log_o);
    const double su = std::fabs(u) + 16, sv = std::fabs(v) + 16;
    const double scale = 0.5 * (std::fabs(conic.a) * su * su + 2 * std::fabs(conic.b) * su * sv +
                                std::fabs(conic.c) * sv * sv) + std::fabs(log_o);
    // A 4K tile far from the origin, for the absolute-coordinate comparison.
    const float ox = 3600.f, oy = 2000.f;
    const k::FoldedCoefficients c_abs = k::fold_coefficients(conic, u + ox, v + oy, log_o);
    auto direct = [&](int x, int y) {
      const double dx = double(u) - x, dy = double(v) - y;
      return -0.5 * (conic.a * dx * dx + conic.c * dy * dy) - double(conic.b) * dx * dy + log_o;
    };
    for (int y = 0; y < 16; y += 2) {
      for (int x = 0; x < 16; ++x) {
        const k::PixelTerms terms = k::pixel_terms(float(x), float(y));
        const float p0 = k::folded_power(c, terms);
        const float p1 = k::dual_pixel_power(p0, c, terms);
        const float p1_direct = k::folded_power(c, k::pixel_terms(float(x), float(y + 1)));
        worst_units = std::max(worst_units, std::fabs(p0 - direct(x, y)) / (eps * scale));
        worst_units = std::max(worst_units, std::fabs(p1 - direct(x, y + 1)) / (eps * scale));
        worst_dual_units = std::max(worst_dual_units, std::fabs(double(p1) - p1_direct) / (eps * scale));
        // In the contributing range, absolute errors (what alpha sees).
        if (direct(x, y) >= -std::log(255.0)) {
          worst_direct = std::max(worst_direct, std::fabs(p0 - direct(x, y)));
          const float p_abs = k::folded_power(c_abs, k::pixel_terms(float(x) + ox, float(y) + oy));
          worst_abs_coords = std::max(worst_abs_coords, std::fabs(p_abs - direct(x, y)));
        }
      }
    }
  }
  MESSAGE("folded P vs direct power: max error " << worst_units << " eps*S, dual-pixel vs direct folded "
                                                 << worst_dual_units << " eps*S; on P in [-ln 255, 0]: max |dP| "
                                                 << worst_direct << " tile-local vs " << worst_abs_coords
                                                 << " in absolute coordinates of a 4K tile");
  CHECK(worst_units < 16);
  CHECK(worst_dual_units < 16);
  // Contributing pairs: |dP| ≤ 5e-4 changes alpha by ≤ 0.05 %, ≤ 0.13 of an 8-bit level even at alpha 0.99
  // (the largest errors come from means 40 px outside the tile with S ~ 1e3).
  CHECK(worst_direct < 5e-4);
  // Tile-local is what makes it exact: in absolute coordinates the error is orders of magnitude larger.
  CHECK(worst_abs_coords > 100 * worst_direct);
}

TEST_CASE("fast exp: max relative error <= 0.0315 over [-ln 255, 0] (1e6+1 points)") {
  const int n = 1000000;
  double worst = 0, mean_signed = 0;
  double worst_zero_mean = 0, mean_signed_zero_mean = 0;
  for (int i = 0; i <= n; ++i) {
    const float P = float(double(k::kFastExpRangeMin) * i / n);
    const double exact = std::exp(double(P));
    const double rel = (double(k::fast_exp(P)) - exact) / exact;
    worst = std::max(worst, std::fabs(rel));
    mean_signed += rel;
    const double rel2 = (double(k::fast_exp(P, k::kFastExpSigmaZeroMean)) - exact) / exact;
    worst_zero_mean = std::max(worst_zero_mean, std::fabs(rel2));
    mean_signed_zero_mean += rel2;
  }
  mean_signed /= (n + 1);
  mean_signed_zero_mean /= (n + 1);
  MESSAGE("fast exp sigma=0.045677: max rel error " << worst << ", mean " << mean_signed
                                                    << "; sigma=0.05798: max " << worst_zero_mean << ", mean "
                                                    << mean_signed_zero_mean);
  CHECK(worst <= k::kFastExpMaxRelativeError);
  CHECK(worst > 0.02);  // it is an approximation: a broken implementation returning expf would pass above
  CHECK(std::fabs(mean_signed_zero_mean) < std::fabs(mean_signed));
  // Outside the range: clamped, defined, tiny.
  CHECK(k::fast_exp(-1000.f) < 1e-37f);
  CHECK(k::fast_exp(-1000.f) >= 0.f);
  CHECK(k::fast_exp(-30.f) < k::kAlphaMin);
}

/// The reference form of the folded fast-exp alpha (cpu_renderer.cpp folded_alpha with fast_exp on).
float reference_fast_exp_alpha(float P, float sigma) {
  if (P > 0.f) return -1.f;
  const float alpha = fminf(k::kAlphaMax, k::fast_exp(P, sigma));
  return alpha < k::kAlphaMin ? -1.f : alpha;
}

TEST_CASE("fast_exp_alpha: bit for bit the reference alpha for every tested non-NaN float, three sigmas") {
  // σ = 0 makes exp̂(0) = 1, so the 0.99 clamp is reached (with the two calibrated σ, exp̂(P ≤ 0) ≤ 0.97).
  for (float sigma : {k::kFastExpSigmaMinMax, k::kFastExpSigmaZeroMean, 0.f}) {
    const float bias = k::fast_exp_bias(sigma);
    uint64_t probes = 0, mismatches = 0, contributing = 0, clamped = 0;
    const auto probe = [&](uint32_t bits) {
      const float P = k::uint_as_float(bits);
      if (std::isnan(P)) return;  // the reference leaves NaN to libm's fmaxf; fast_exp_alpha skips it (below)
      const float expected = reference_fast_exp_alpha(P, sigma);
      mismatches += k::float_as_uint(expected) != k::float_as_uint(k::fast_exp_alpha(P, bias));
      contributing += expected >= 0.f;
      clamped += expected == k::kAlphaMax;
      ++probes;
    };
    // Every 257th bit pattern of the float line (16.7 million values: both signs, zeros, subnormals,
    // infinities, NaNs), then every pattern around the points where exp̂ crosses 1/255 and 0.99, fast_exp's
    // clamp at -87, and 0.
    for (uint64_t u = 0; u <= 0xffffffffull; u += 257) probe(uint32_t(u));
    for (float edge : {std::log(k::kAlphaMin), std::log(k::kAlphaMax), k::kFastExpClampMin, 0.f, -0.f}) {
      const int64_t u = k::float_as_uint(edge);
      for (int64_t d = -20000; d <= 20000; ++d) probe(uint32_t(u + d));
    }
    CHECK_MESSAGE(mismatches == 0, "sigma " << sigma << ": " << mismatches << " of " << probes);
    // The probes reach all outcomes: skipped, exp̂(P) itself and, with σ = 0, the clamp to 0.99.
    CHECK(probes > contributing);
    CHECK(contributing > clamped);
    CHECK((clamped > 0) == (sigma == 0.f));
  }
  const float bias = k::fast_exp_bias(k::kFastExpSigmaMinMax);
  CHECK(k::fast_exp_alpha(std::numeric_limits<float>::quiet_NaN(), bias) == -1.f);
  CHECK(k::fast_exp_alpha(1e-30f, bias) == -1.f);
  CHECK(k::fast_exp_alpha(-std::numeric_limits<float>::infinity(), bias) == -1.f);
  CHECK(k::fast_exp_alpha(0.f, bias) == k::fast_exp(0.f));
}

/// Whether any pixel centre of the side × side square at tile-local (x0, y0) passes the 1/255 test as the
/// folded rasterizer evaluates it: the fast exp with σ = 0 (the most generous) or the paper's σ, or expf.
bool any_pixel_passes(const k::FoldedCoefficients& f, int x0, int y0, int side) {
  const float bias_zero = k::fast_exp_bias(0.f), bias_paper = k::fast_exp_bias(k::kFastExpSigmaMinMax);
  for (int y = y0; y < y0 + side; ++y) {
    for (int x = x0; x < x0 + side; ++x) {
      const float P = k::folded_power(f, k::pixel_terms(float(x), float(y)));
      if (k::fast_exp_alpha(P, bias_zero) >= 0.f || k::fast_exp_alpha(P, bias_paper) >= 0.f ||
          (P <= 0.f && std::fmin(k::kAlphaMax, std::exp(P)) >= k::kAlphaMin)) {
        return true;
      }
    }
  }
  return false;
}

TEST_CASE("subtile_mask: no pixel of a cleared quadrant passes the 1/255 test (random Gaussians, needles too)") {
  // Means up to 40 px outside the tile, covariance eigenvalues 1e-3..1e4 px² at any angle, opacities 0.004..1;
  // every pixel of every quadrant the mask clears is evaluated as the rasterizer does (folded P, then the fast
  // exp with σ = 0, the most generous one, and with the paper's σ, and expf).
  std::mt19937 rng(77);
  std::uniform_real_distribution<double> local(-40.0, 56.0), unit(0.0, 1.0);
  uint64_t quadrants = 0, cleared = 0, kept_without_pixel = 0, violations = 0;
  for (int iter = 0; iter < 20000; ++iter) {
    const k::Cov2 cov = random_cov(rng);
    const float det = k::determinant(cov);
    if (!(det > 0)) continue;
    const k::Conic conic = k::conic_from_covariance(cov, det);
    const float log_o = std::log(float(0.004 + 0.996 * unit(rng)));
    const float u = float(local(rng)), v = float(local(rng));
    const k::FoldedCoefficients f = k::fold_coefficients(conic, u, v, log_o);
    const uint32_t mask = k::subtile_mask(conic, u, v, log_o);
    for (int q = 0; q < 4; ++q) {
      const bool any_pixel = any_pixel_passes(f, (q % 2) * 8, (q / 2) * 8, 8);
      ++quadrants;
      if (!(mask >> q & 1u)) {
        ++cleared;
        violations += any_pixel;
      } else {
        kept_without_pixel += !any_pixel;
      }
    }
  }
  MESSAGE("subtile_mask: " << cleared << " of " << quadrants << " quadrants cleared, " << kept_without_pixel
                           << " kept without a passing pixel (the margin and the box's continuous extent)");
  CHECK(violations == 0);
  // It culls (a mask of all ones would pass the check above), and keeps few quadrants it could have cleared.
  CHECK(cleared > quadrants / 4);
  CHECK(kept_without_pixel < (quadrants - cleared) / 10);
}

TEST_CASE("block_mask: no pixel of a cleared 4x4 block passes the 1/255 test (random Gaussians, needles too)") {
  // The generator of the subtile_mask case, plus small round Gaussians (eigenvalues 0.05..4 px², the dense
  // scenes' kind) placed in and around the tile, where the blocks clear most.
  std::mt19937 rng(78);
  std::uniform_real_distribution<double> local(-40.0, 56.0), near(-3.0, 19.0), unit(0.0, 1.0);
  uint64_t blocks = 0, cleared = 0, cleared_in_kept_quadrant = 0, violations = 0;
  uint64_t small_blocks = 0, small_cleared = 0, small_kept_without_pixel = 0;
  for (int iter = 0; iter < 20000; ++iter) {
    const bool small = iter % 2 == 1;
    k::Cov2 cov = random_cov(rng);
    if (small) {
      const float l1 = float(0.05 + 3.95 * unit(rng)), l2 = float(0.05 + 3.95 * unit(rng));
      const float angle = float(3.14159265 * unit(rng)), c = std::cos(angle), s = std::sin(angle);
      cov = k::Cov2{c * c * l1 + s * s * l2, c * s * (l1 - l2), s * s * l1 + c * c * l2};
    }
    const float det = k::determinant(cov);
    if (!(det > 0)) continue;
    const k::Conic conic = k::conic_from_covariance(cov, det);
    const float log_o = std::log(float(0.004 + 0.996 * unit(rng)));
    const float u = float(small ? near(rng) : local(rng)), v = float(small ? near(rng) : local(rng));
    const k::FoldedCoefficients f = k::fold_coefficients(conic, u, v, log_o);
    const uint32_t quadrants = k::subtile_mask(conic, u, v, log_o);
    const uint32_t mask = k::block_mask(conic, u, v, log_o);
    for (int b = 0; b < k::kCullBlocksPerTile; ++b) {
      const int bx = b % k::kCullBlocksPerSide, by = b / k::kCullBlocksPerSide;
      const bool any_pixel =
          any_pixel_passes(f, bx * k::kCullBlockSize, by * k::kCullBlockSize, k::kCullBlockSize);
      ++blocks;
      small_blocks += small;
      if (!(mask >> b & 1u)) {
        ++cleared;
        small_cleared += small;
        violations += any_pixel;
        cleared_in_kept_quadrant += (quadrants >> (bx / 2 + 2 * (by / 2))) & 1u;
      } else {
        small_kept_without_pixel += small && !any_pixel;
      }
    }
  }
  MESSAGE("block_mask: " << cleared << " of " << blocks << " blocks cleared (" << cleared_in_kept_quadrant
                         << " in quadrants subtile_mask keeps); small round Gaussians: " << small_cleared << " of "
                         << small_blocks << " cleared, " << small_kept_without_pixel
                         << " kept without a passing pixel");
  CHECK(violations == 0);
  // It culls beyond the quadrants, and on the small round Gaussians its box is tight: few blocks kept that it
  // could have cleared (a needle keeps the blocks of its box).
  CHECK(cleared_in_kept_quadrant > (blocks - cleared) / 4);
  CHECK(small_kept_without_pixel < (small_blocks - small_cleared) / 4);
}

TEST_CASE("tile chunks: chunk size and count, and the merge of chunks") {
  using kernels::ChunkPixel;
  // K = max(tile_chunk_pairs, ⌈pairs / 2048⌉); 0 when off or when large Gaussians hold more than half the pairs.
  CHECK(kernels::frame_chunk_pairs(6'555'764, 0, 0) == 0);
  CHECK(kernels::frame_chunk_pairs(1'000, 0, 2048) == 2048);
  CHECK(kernels::frame_chunk_pairs(2048ull * 2048, 0, 2048) == 2048);
  CHECK(kernels::frame_chunk_pairs(2048ull * 2048 + 1, 0, 2048) == 2049);
  CHECK(kernels::frame_chunk_pairs(6'555'764, 1'000, 2048) == 3202);  // taebak view 0 at 1080p
  CHECK(kernels::frame_chunk_pairs(~0ull, 0, 1) == 0xffffffffu);
  CHECK(kernels::frame_chunk_pairs(1'000'000, 500'000, 2048) == 2048);
  CHECK(kernels::frame_chunk_pairs(1'000'000, 500'001, 2048) == 0);
  CHECK(kernels::tile_chunk_count(5000, 0) == 1);
  CHECK(kernels::tile_chunk_count(2048, 2048) == 1);
  CHECK(kernels::tile_chunk_count(2049, 2048) == 2);
  CHECK(kernels::tile_chunk_count(21'140, 3202) == 7);

  // Merging a first chunk into the default pixel gives its values exactly.
  ChunkPixel first;
  first.C[0] = 0.3f, first.C[1] = 0.1f, first.C[2] = 0.7f;
  first.T = 0.25f, first.depth_sum = 1.5f, first.weight_sum = 0.75f;
  ChunkPixel acc;
  kernels::merge_chunk(acc, first);
  CHECK(acc.C[0] == first.C[0]);
  CHECK(acc.C[2] == first.C[2]);
  CHECK(acc.T == first.T);
  CHECK(acc.depth_sum == first.depth_sum);
  CHECK_FALSE(acc.done);
  // The next chunk goes behind it: C += T·C', T ·= T'.
  ChunkPixel second;
  second.C[0] = 0.5f, second.T = 0.5f, second.weight_sum = 0.5f, second.done = true;
  kernels::merge_chunk(acc, second);
  CHECK(acc.C[0] == 0.3f + 0.25f * 0.5f);
  CHECK(acc.C[1] == 0.1f);
  CHECK(acc.T == 0.125f);
  CHECK(acc.weight_sum == 0.75f + 0.25f * 0.5f);
  CHECK(acc.done);
  // A pixel that stopped takes nothing from the chunks after.
  const ChunkPixel before = acc;
  kernels::merge_chunk(acc, first);
  CHECK(acc.C[0] == before.C[0]);
  CHECK(acc.T == before.T);
}

}  // namespace
}  // namespace rgs::test
