// The per-stage bytes and FLOPs model of rgs-bench (rgs/lab/roofline_model.h; docs/lab/ROOFLINE.md derives each term).
// Notation: N Gaussians, V visible, K = (degree + 1)² SH coefficients per channel, A attribute bytes per
// Gaussian, P pairs, kb key bytes (8 or 4), T tiles, X pixels.
#include "rgs/lab/roofline_model.h"

#include <algorithm>
#include <cmath>

namespace rgs::lab {

namespace {

double sh_coefficients(uint32_t degree) {
  const double d = std::min<uint32_t>(degree, 3);
  return (d + 1) * (d + 1);
}

/// The sort of a pair array of `count` entries with `key_bytes`-byte keys and 4-byte values over `bits`
/// bits (CUB onesweep): one histogram pass reads every key once, then each 8-bit pass reads and writes keys
/// and values.
double sort_bytes(double count, double key_bytes, int bits) {
  if (count <= 0 || bits <= 0) return 0;
  return count * key_bytes + double(radix_passes(bits)) * 2.0 * count * (key_bytes + 4.0);
}

}  // namespace

const char* roofline_stage_name(RooflineStage stage) {
  switch (stage) {
    case RooflineStage::kPreprocess: return "preprocess";
    case RooflineStage::kSort: return "sort";
    case RooflineStage::kRanges: return "ranges";
    case RooflineStage::kRender: return "render";
  }
  return "?";
}

double sh_colour_flops(uint32_t degree) {
  static constexpr double kBasis[4] = {0, 3, 18, 48};
  return kBasis[std::min<uint32_t>(degree, 3)] + 6.0 * sh_coefficients(degree);
}

double attribute_bytes(bool compact, uint32_t degree, bool dc_residual) {
  const double k = sh_coefficients(degree);
  return compact ? 28.0 + 3.0 * k + (dc_residual ? 3.0 : 0.0) : 44.0 + 12.0 * k;
}

int radix_passes(int sort_bits) { return sort_bits <= 0 ? 0 : (sort_bits + 7) / 8; }

double render_eval_flops(bool folded, bool fast_exp, bool depth_plane) {
  const double exp_flops = fast_exp ? kFlopsFastExp : kFlopsExpf;
  // Unfolded: dx, dy (2) + power (9) + exp + (o·e or power + ln o: 1), baseline blend. Folded: 15 FLOPs
  // per two pixels, FMA blend.
  if (folded) return 7.5 + exp_flops + kFlopsBlendFma + (depth_plane ? kFlopsBlendDepthFma : 0.0);
  return 2.0 + 9.0 + 1.0 + exp_flops + kFlopsBlend + (depth_plane ? kFlopsBlendDepth : 0.0);
}

FrameWork frame_work(const FrameWorkInputs& in) {
  const double n = double(in.gaussians);
  const double v = double(std::min(in.visible, in.gaussians));
  const double p = double(in.pairs);
  const double t = double(in.tiles);
  const double x = double(in.pixels);
  const double k = sh_coefficients(in.sh_degree);
  const bool roofgs = in.roofgs;
  const bool compact = roofgs && in.compact;
  const bool key32 = roofgs && in.key32;
  const bool folded = roofgs && in.folded;
  const bool fast_exp = roofgs && in.fast_exp;
  const double kb = key32 ? 4.0 : 8.0;
  const double a = attribute_bytes(compact, in.sh_degree, compact && in.dc_residual);
  FrameWork w;

  // Preprocess: everything before the sort.
  StageWork& pre = w.stages[int(RooflineStage::kPreprocess)];
  double flops_visible = kFlopsProjectVisible + sh_colour_flops(in.sh_degree);
  if (!roofgs) {
    // preprocess_baseline: means of all (12N), the rest of the attributes of the visible ((A − 12)V),
    // radii + tiles_touched of all (12N), depth/means2d/conic+opacity/rgb of the visible (40V);
    // inclusive scan of N uint64 (16N); duplicate_baseline: radii (4N), offsets/means2d/depth (20V) and the
    // pairs (P·(8 + 4)).
    pre.bytes = 12 * n + (a - 12) * v + 12 * n + 40 * v + 16 * n + 4 * n + 20 * v + p * (8 + 4);
    pre.flops = kFlopsViewTransform * n + (flops_visible + kFlopsTileRect) * v;
  } else {
    flops_visible += kFlopsLogf;                              // ln o for the folded/fast-exp alpha
    if (compact) flops_visible += 3 * k;                      // SH = s[d][c]·q
    if (compact && in.dc_residual) flops_visible += 3 * 2;    // DC = s[0][c]·fma(r, 1/256, q)
    if (key32) flops_visible += kFlopsDepthBin;
    // SnugBox threshold, and the AccuTile walk's setup: built once by the fused kernel (for the count and the
    // emission), twice by the separate stages (preprocess, then duplicate_roofgs rebuilds it).
    if (in.snugbox) flops_visible += kFlopsSnugThreshold + (in.fused ? 1 : 2) * kFlopsAccutileSetup;
    // AccuTile slices: a footprint of P/V tiles walked along its shorter side has about sqrt(P/V) slices:
    // sqrt(P·V) in all per walk. The separate stages walk twice (count, then emit); the fused kernel once,
    // since a walk of at most 4 slices keeps its spans from the count for the emission (the longer walks'
    // second pass, a small share of the walks, is left out).
    const double slices = in.snugbox ? (in.fused ? 1.0 : 2.0) * std::sqrt(p * v) : 0.0;
    // Large Gaussians (> kSerialTileLimit = 16 tiles), counted per work item (a chunk of up to 16 slices of a
    // walk): a 16 B list entry, then emit_large_gaussians reads the entry and means2d, cov2d, snug_t, radius,
    // depth bin, depth (52 B) and the 32 lanes of a warp rebuild the walk (tile rectangle, and the AccuTile
    // setup); the fused kernel's 20 B per large Gaussian are counted per item too (an upper bound); the slices
    // are the emission walk counted above.
    const double large = double(in.large_chunks);
    const double large_flops =
        large * kLargeItemThreads * (kFlopsTileRect + (in.snugbox ? kFlopsAccutileSetup : 0.0));
    if (in.fused) {
      // fused kernel: means of all, rest of the visible; radii of the culled (4(N − V)); store_projected of
      // the visible (depth 4, means2d 8, conic+opacity 16, colour + ln o 16, radius 4 = 48V); pairs P·(kb + 4).
      // A large Gaussian also stores cov2d, snug_t and its depth bin (20 B) for emit_large_gaussians.
      pre.bytes = 12 * n + (a - 12) * v + 4 * (n - v) + 48 * v + p * (kb + 4) + (20 + 16 + 52) * large;
      pre.flops = kFlopsViewTransform * n + flops_visible * v + kFlopsAccutileSlice * slices + large_flops;
    } else {
      // preprocess_roofgs: as the fused kernel's reads; writes radii + tiles_touched of all (12N) and 64V
      // (store_projected without the radius, plus cov2d 12, snug_t 4, depth bin 4); scan 16N;
      // duplicate_roofgs: tiles_touched (8N), offsets/means2d/cov2d/snug_t/radius/depth/depth bin (44V),
      // pairs P·(kb + 4).
      pre.bytes =
          12 * n + (a - 12) * v + 12 * n + 64 * v + 16 * n + 8 * n + 44 * v + p * (kb + 4) + (16 + 52) * large;
      pre.flops = kFlopsViewTransform * n + (flops_visible + kFlopsTileRect) * v + kFlopsAccutileSlice * slices +
                  large_flops;
    }
  }

  // Sort: CUB onesweep over sort_bits bits, no FP32 arithmetic.
  w.stages[int(RooflineStage::kSort)].bytes = sort_bytes(p, kb, in.sort_bits);

  // Ranges: clear 2 uint64 per tile (16T), read every sorted key (P·kb), write at most both ends of every
  // tile's range (16T). Depth order with the 32-bit key does it in order_equal_keys_by_depth, which also
  // reads and writes each value (8P; the reads inside runs of tied keys and their depths are left out).
  w.stages[int(RooflineStage::kRanges)].bytes =
      16 * t + p * kb + 16 * t + (key32 && in.depth_order ? 8 * p : 0.0);

  // Render: per pair its value (4) and the gathered per-Gaussian record — means2d 8, conic+opacity 16,
  // rgb 12, + ln o 4 (fast exp or folded), + depth 4 (depth plane) — each pair's record fetched once per
  // tile; the ranges (16T); the output RGBA float (16X) and depth (4X).
  StageWork& render = w.stages[int(RooflineStage::kRender)];
  const double record = 36.0 + ((folded || fast_exp) ? 4.0 : 0.0) + (in.depth_plane ? 4.0 : 0.0);
  render.bytes = p * (4 + record) + 16 * t + x * (16 + (in.depth_plane ? 4 : 0));
  // 256 pixel evaluations per pair (every pixel of the tile, no early termination: an upper bound), plus
  // the folding per pair.
  render.flops = p * (256.0 * render_eval_flops(folded, fast_exp, in.depth_plane) + (folded ? kFlopsFoldPair : 0.0));
  return w;
}

FrameWork floor_work(const FrameCensus& census, uint32_t sh_degree, CensusCell cell) {
  const double n = double(census.gaussians);
  const double v = double(census.visible);
  const double c = double(census.contributing);
  const double pairs = double(census.blending_pairs[int(cell)]);
  const double k = sh_coefficients(sh_degree);
  FrameWork w;
  StageWork& pre = w.stages[int(RooflineStage::kPreprocess)];
  pre.bytes = 12 * n + 16 * v + 3 * k * c + 24 * c;
  pre.flops = kFlopsViewTransform * n + kFlopsProjectVisible * v + sh_colour_flops(sh_degree) * c;
  w.stages[int(RooflineStage::kSort)].bytes = sort_bytes(c, 4, 32) + pairs * (8 + 8 + 4);
  StageWork& render = w.stages[int(RooflineStage::kRender)];
  render.bytes = pairs * 24 + 16 * double(census.pixels());
  render.flops = 7.5 * double(census.blended);
  render.half_flops = (kFlopsFastExp + kFlopsBlendFma) * double(census.blended);
  return w;
}

RooflinePoint roofline_point(const StageWork& work, double ms, const RooflinePeaks& peaks) {
  RooflinePoint pt;
  pt.ms = ms;
  pt.bytes = work.bytes;
  pt.flops = work.flops;
  pt.intensity = work.bytes > 0 ? work.flops / work.bytes : 0.0;
  if (ms > 0) {
    pt.gbps = work.bytes / (ms * 1e-3) / 1e9;
    pt.gflops = work.flops / (ms * 1e-3) / 1e9;
  }
  if (peaks.memory_gbps > 0) pt.pct_bandwidth = 100.0 * pt.gbps / peaks.memory_gbps;
  if (peaks.compute_gflops > 0) pt.pct_compute = 100.0 * pt.gflops / peaks.compute_gflops;
  if (peaks.ridge() > 0) pt.bound = pt.intensity < peaks.ridge() ? "memory" : "compute";
  pt.attainable_gflops = std::min(peaks.compute_gflops, pt.intensity * peaks.memory_gbps);
  if (work.flops > 0) {
    pt.pct_of_roof = pt.attainable_gflops > 0 ? 100.0 * pt.gflops / pt.attainable_gflops : 0.0;
  } else {
    pt.pct_of_roof = pt.pct_bandwidth;
  }
  if (peaks.memory_gbps > 0 && peaks.compute_gflops > 0) {
    const double half_gflops = peaks.half_gflops > 0 ? peaks.half_gflops : peaks.compute_gflops;
    pt.floor_ms = std::max(work.bytes / (peaks.memory_gbps * 1e6),
                           work.flops / (peaks.compute_gflops * 1e6) + work.half_flops / (half_gflops * 1e6));
  }
  if (pt.floor_ms > 0) pt.times_floor = ms / pt.floor_ms;
  return pt;
}

}  // namespace rgs::lab
