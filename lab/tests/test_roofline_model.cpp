// The roofline model of rgs-bench (runtime/include/rgs/lab/roofline_model.h) against values computed by hand from
// the formulas of docs/lab/ROOFLINE.md, so that a changed term shows up here.
#include <doctest/doctest.h>

#include <cstring>

#include "rgs/lab/roofline_model.h"

namespace {

using namespace rgs::lab;

const StageWork& stage(const FrameWork& w, RooflineStage s) { return w[s]; }

TEST_CASE("roofline model: per-item counts") {
  CHECK(radix_passes(0) == 0);
  CHECK(radix_passes(1) == 1);
  CHECK(radix_passes(32) == 4);  // RoofGS 32-bit key
  CHECK(radix_passes(45) == 6);  // baseline at 1080p: 32 + 13 bits
  CHECK(radix_passes(47) == 6);  // baseline at 4K: 32 + 15 bits
  CHECK(radix_passes(64) == 8);
  // SH: basis + 3 channels × (K products, K − 1 sums, + 0.5).
  CHECK(sh_colour_flops(0) == 6);
  CHECK(sh_colour_flops(1) == 27);
  CHECK(sh_colour_flops(2) == 72);
  CHECK(sh_colour_flops(3) == 144);
  // docs/DESIGN.md#the-rgs-format / the paper: 236 B per Gaussian in FP32 at degree 3, 76 B compact.
  CHECK(attribute_bytes(false, 3) == 236);
  CHECK(attribute_bytes(true, 3) == 76);
  CHECK(attribute_bytes(false, 0) == 56);
  CHECK(attribute_bytes(true, 2) == 55);
  CHECK(attribute_bytes(true, 0, true) == 34);
  CHECK(attribute_bytes(false, 0, true) == 56);  // the residual is a compact section
  CHECK(render_eval_flops(false, false, false) == 33);
  CHECK(render_eval_flops(false, true, false) == 25);
  CHECK(render_eval_flops(true, false, false) == 25.5);
  CHECK(render_eval_flops(true, true, false) == 17.5);
  CHECK(render_eval_flops(false, false, true) == 37);
  CHECK(render_eval_flops(true, true, true) == 20.5);
}

TEST_CASE("roofline model: baseline frame, hand-computed") {
  // N = V = 1000 Gaussians of SH degree 0 (A = 56 B), P = 5000 pairs, 45 sort bits (6 passes), 10×10 tiles,
  // 160×160 pixels.
  FrameWorkInputs in;
  in.gaussians = in.visible = 1000;
  in.sh_degree = 0;
  in.pairs = 5000;
  in.sort_bits = 45;
  in.tiles = 100;
  in.pixels = 160 * 160;
  in.fast_exp = true;  // ignored by the baseline pipeline
  const FrameWork w = frame_work(in);
  // preprocess: 44N + (A − 12 + 60)V + 12P = 44,000 + 104,000 + 60,000.
  CHECK(stage(w, RooflineStage::kPreprocess).bytes == 208000);
  // 18N + (209 + 6 + 18)V.
  CHECK(stage(w, RooflineStage::kPreprocess).flops == 251000);
  // sort: 8P + 6 · 2 · 12P = 40,000 + 720,000.
  CHECK(stage(w, RooflineStage::kSort).bytes == 760000);
  CHECK(stage(w, RooflineStage::kSort).flops == 0);
  // ranges: 8P + 32T.
  CHECK(stage(w, RooflineStage::kRanges).bytes == 43200);
  // render: P(4 + 36) + 16T + 16X = 200,000 + 1,600 + 409,600; FLOPs 256 · 33 per pair.
  CHECK(stage(w, RooflineStage::kRender).bytes == 611200);
  CHECK(stage(w, RooflineStage::kRender).flops == 42240000);
}

TEST_CASE("roofline model: RoofGS frame with every technique, hand-computed") {
  // N = 1000, V = 800, SH degree 3 compact (A = 76 B), P = 3200 pairs, 32-bit key (4 passes).
  FrameWorkInputs in;
  in.roofgs = in.compact = in.fused = in.key32 = in.snugbox = in.folded = in.fast_exp = true;
  in.gaussians = 1000;
  in.visible = 800;
  in.sh_degree = 3;
  in.pairs = 3200;
  in.sort_bits = 32;
  in.tiles = 100;
  in.pixels = 160 * 160;
  const FrameWork w = frame_work(in);
  // fused: 12N + (A − 12)V + 4(N − V) + 48V + P(4 + 4) = 12,000 + 51,200 + 800 + 38,400 + 25,600.
  CHECK(stage(w, RooflineStage::kPreprocess).bytes == 128000);
  // 18N + V(209 + 144 + 27 ln o + 48 SH dequant + 4 depth bin + 29 SnugBox t + 24 walk setup, once)
  //   + 33 · sqrt(P·V) slices (walked once: short walks keep their spans) = 18,000 + 800 · 485 + 33 · 1,600.
  CHECK(stage(w, RooflineStage::kPreprocess).flops == 458800);
  // The separate stages build the walk twice, walk its slices twice and recompute the tile rectangle:
  // + 800 · (24 + 18) + 33 · 1,600.
  FrameWorkInputs separate = in;
  separate.fused = false;
  CHECK(stage(frame_work(separate), RooflineStage::kPreprocess).flops == 458800 + 800 * 42 + 33 * 1600);
  // sort: 4P + 4 · 2 · 8P.
  CHECK(stage(w, RooflineStage::kSort).bytes == 217600);
  // ranges: 4P + 32T.
  CHECK(stage(w, RooflineStage::kRanges).bytes == 16000);
  // render: P(4 + 40) + 16T + 16X; FLOPs P(256 · 17.5 + 21).
  CHECK(stage(w, RooflineStage::kRender).bytes == 552000);
  CHECK(stage(w, RooflineStage::kRender).flops == 14403200);
}

TEST_CASE("roofline model: large Gaussians (emit_large_gaussians) add their list and walk rebuilds") {
  FrameWorkInputs in;
  in.roofgs = in.fused = in.snugbox = true;
  in.gaussians = in.visible = 1000;
  in.pairs = 3200;
  in.sort_bits = 40;
  const FrameWork without = frame_work(in);
  in.large_chunks = 10;
  const FrameWork with = frame_work(in);
  // Fused: 20 B stored + 16 B entry + 52 B read per work item; 32 lanes × (18 + 24) FLOPs.
  CHECK(stage(with, RooflineStage::kPreprocess).bytes - stage(without, RooflineStage::kPreprocess).bytes == 880);
  CHECK(stage(with, RooflineStage::kPreprocess).flops - stage(without, RooflineStage::kPreprocess).flops == 13440);
  in.fused = false;
  in.snugbox = false;
  const FrameWork separate = frame_work(in);
  in.large_chunks = 0;
  const FrameWork separate_without = frame_work(in);
  // Separate: 16 B entry + 52 B read; 32 × 18 FLOPs.
  CHECK(stage(separate, RooflineStage::kPreprocess).bytes -
            stage(separate_without, RooflineStage::kPreprocess).bytes == 680);
  CHECK(stage(separate, RooflineStage::kPreprocess).flops -
            stage(separate_without, RooflineStage::kPreprocess).flops == 5760);
  CHECK(stage(separate, RooflineStage::kRender).bytes == stage(separate_without, RooflineStage::kRender).bytes);
}

TEST_CASE("roofline model: separate stages, FP32 attributes, depth order") {
  // The separate RoofGS stages with every technique off except depth order: N = V = 100, degree 1 (A = 92),
  // P = 400, 64-bit keys over 40 bits (5 passes). The 64-bit key holds the exact depth, so depth order adds
  // nothing; with the 32-bit key it adds order_equal_keys_by_depth to the sort.
  FrameWorkInputs in;
  in.roofgs = in.depth_order = true;
  in.gaussians = in.visible = 100;
  in.sh_degree = 1;
  in.pairs = 400;
  in.sort_bits = 40;
  in.tiles = 16;
  in.pixels = 64 * 64;
  const FrameWork w = frame_work(in);
  // 12N + 80V + 12N + 64V + 16N + 8N + 44V + 12P = 1,200 + 8,000 + 1,200 + 6,400 + 1,600 + 800 + 4,400
  //   + 4,800.
  CHECK(stage(w, RooflineStage::kPreprocess).bytes == 28400);
  // 18N + (209 + 27 + 27 + 18)V.
  CHECK(stage(w, RooflineStage::kPreprocess).flops == 29900);
  // 8P + 5 · 2 · 12P.
  CHECK(stage(w, RooflineStage::kSort).bytes == 51200);
  // 32-bit keys over 32 bits: 4P + 4 · 2 · 8P; the ranges with the depth order pass: 16T + 4P + 16T + 8P.
  in.key32 = true;
  in.sort_bits = 32;
  const FrameWork w32 = frame_work(in);
  CHECK(stage(w32, RooflineStage::kSort).bytes == 1600 + 25600);
  CHECK(stage(w32, RooflineStage::kRanges).bytes == 256 + 1600 + 256 + 3200);
  // P(4 + 36) + 16T + 16X; 256 · 33 per pair.
  CHECK(stage(w, RooflineStage::kRender).bytes == 16000 + 256 + 65536);
  CHECK(stage(w, RooflineStage::kRender).flops == 400.0 * 256 * 33);
}

TEST_CASE("roofline model: empty frame and visible clamped to N") {
  FrameWorkInputs in;
  in.gaussians = 10;
  in.visible = 50;  // more than N: taken as N
  in.tiles = 4;
  in.pixels = 1024;
  const FrameWork w = frame_work(in);
  CHECK(stage(w, RooflineStage::kPreprocess).bytes == 44 * 10 + (56 - 12 + 60) * 10);
  CHECK(stage(w, RooflineStage::kSort).bytes == 0);
  CHECK(stage(w, RooflineStage::kRender).flops == 0);
  CHECK(stage(w, RooflineStage::kRender).bytes == 16 * 4 + 16 * 1024);
}

TEST_CASE("roofline point: rates, percentages and the bounding roof") {
  const RooflinePeaks peaks{2000, 50000};  // GB/s, GFLOP/s
  CHECK(peaks.ridge() == 25);
  // 1 GB and 20 GFLOP in 1 ms: 1000 GB/s, 20,000 GFLOP/s, 20 FLOP/B < 25: memory bound.
  RooflinePoint p = roofline_point(StageWork{1e9, 2e10}, 1.0, peaks);
  CHECK(p.gbps == doctest::Approx(1000));
  CHECK(p.gflops == doctest::Approx(20000));
  CHECK(p.intensity == doctest::Approx(20));
  CHECK(p.pct_bandwidth == doctest::Approx(50));
  CHECK(p.pct_compute == doctest::Approx(40));
  CHECK(std::strcmp(p.bound, "memory") == 0);
  CHECK(p.attainable_gflops == doctest::Approx(40000));
  CHECK(p.pct_of_roof == doctest::Approx(50));
  // Floor: 1 GB at 2000 GB/s = 0.5 ms > 20 GFLOP at 50,000 GFLOP/s = 0.4 ms; measured 1 ms is 2x the floor.
  CHECK(p.floor_ms == doctest::Approx(0.5));
  CHECK(p.times_floor == doctest::Approx(2.0));
  // 100 FLOP/B: compute bound, attainable = the compute peak.
  p = roofline_point(StageWork{1e8, 1e10}, 0.5, peaks);
  CHECK(std::strcmp(p.bound, "compute") == 0);
  CHECK(p.attainable_gflops == doctest::Approx(50000));
  CHECK(p.pct_of_roof == doctest::Approx(40));
  CHECK(p.floor_ms == doctest::Approx(0.2));  // 10 GFLOP at 50,000 GFLOP/s; the 0.1 GB take 0.05 ms
  CHECK(p.times_floor == doctest::Approx(2.5));
  // No FLOPs (the sort): memory bound, the share of the roof is the share of the bandwidth.
  p = roofline_point(StageWork{3e9, 0}, 2.0, peaks);
  CHECK(p.intensity == 0);
  CHECK(std::strcmp(p.bound, "memory") == 0);
  CHECK(p.pct_of_roof == doctest::Approx(75));
  // No time or no peaks: zero rates, bound unknown.
  p = roofline_point(StageWork{1e9, 1e9}, 0.0, RooflinePeaks{});
  CHECK(p.gbps == 0);
  CHECK(std::strcmp(p.bound, "unknown") == 0);
  CHECK(p.floor_ms == 0);
  CHECK(p.times_floor == 0);
  // binary16 work at its own roof: 10 GFLOP FP32 (0.2 ms) + 20 GFLOP half at 100,000 GFLOP/s (0.2 ms).
  const RooflinePeaks with_half{2000, 50000, 100000};
  p = roofline_point(StageWork{1e8, 1e10, 2e10}, 0.8, with_half);
  CHECK(p.floor_ms == doctest::Approx(0.4));
  CHECK(p.times_floor == doctest::Approx(2.0));
  // Without a half peak the half work runs at the FP32 roof.
  p = roofline_point(StageWork{1e8, 1e10, 2e10}, 0.8, peaks);
  CHECK(p.floor_ms == doctest::Approx(0.6));
}

TEST_CASE("true floor: hand-computed from a census") {
  // N = 1000 Gaussians of SH degree 1 (K = 4), V = 800 visible, C = 500 contributing; 100 × 80 pixels;
  // 3000 / 5000 / 9000 blending (cell, Gaussian) pairs at 16×16 / 8×8 / 4×4; 40,000 (pixel, Gaussian) blends.
  FrameCensus c;
  c.width = 100;
  c.height = 80;
  c.gaussians = 1000;
  c.visible = 800;
  c.contributing = 500;
  c.blended = 40000;
  c.blending_pairs[0] = 3000;
  c.blending_pairs[1] = 5000;
  c.blending_pairs[2] = 9000;
  const FrameWork w = floor_work(c, 1);
  // preprocess: 12N + 16V + 3K·C + 24C = 12,000 + 12,800 + 6,000 + 12,000.
  CHECK(stage(w, RooflineStage::kPreprocess).bytes == 42800);
  // 18N + 209V + 27C = 18,000 + 167,200 + 13,500.
  CHECK(stage(w, RooflineStage::kPreprocess).flops == 198700);
  // sort: the depth sort of C (4C + 4 passes · 2 · 8C = 68C = 34,000) and 20 B per 16×16 pair (60,000).
  CHECK(stage(w, RooflineStage::kSort).bytes == 94000);
  CHECK(stage(w, RooflineStage::kRanges).bytes == 0);
  // render: 24 B per pair + 16 B per pixel = 72,000 + 128,000; 7.5 FP32 and 10 half FLOPs per blend.
  CHECK(stage(w, RooflineStage::kRender).bytes == 200000);
  CHECK(stage(w, RooflineStage::kRender).flops == 300000);
  CHECK(stage(w, RooflineStage::kRender).half_flops == 400000);
  // 4×4 cells: only the pair terms change.
  const FrameWork w4 = floor_work(c, 1, CensusCell::k4);
  CHECK(stage(w4, RooflineStage::kSort).bytes == 34000 + 9000 * 20);
  CHECK(stage(w4, RooflineStage::kRender).bytes == 9000 * 24 + 128000);
}

}  // namespace
