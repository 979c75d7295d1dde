// Analytic bytes moved and FLOPs per stage of one frame of the CUDA renderer, for rgs-bench's roofline
// (docs/lab/ROOFLINE.md "How the counts are derived" explains every term and its assumptions).
//
// The model counts what the kernels *request* from global memory and the FP32 arithmetic they *issue*, from
// quantities rgs-bench knows: Gaussian count, SH degree, attribute format, pair count, sort bits, tiles and
// pixels. It mirrors the kernels of kernels/src as of this file's last change: a kernel that changes what it
// reads, writes or computes must change the model with it. It is not a measurement: caches (L1, the 50 MB L2
// of an H100) serve part of the requested bytes, so "achieved GB/s" against the DRAM copy peak can exceed
// 100 % for data that stays in L2; early termination makes the render FLOPs an upper bound.
//
// FLOP counting convention (per PTX-level FP32 instruction, the work the FP32 pipes do): add, sub, mul, div,
// sqrt = 1; fma = 2; min, max, compare, floor/ceil, conversions and negation = 0; expf = 10 (CUDA 13
// libdevice: 4 fma + 1 add + 1 mul around an ex2.approx that runs on the SFU and is not counted); logf = 27
// (12 fma + 1 add + 2 mul); the Schraudolph fast exp = 2 (one fma). The FMA peak is counted the same way
// (2 per FMA), so the two sides of the roofline agree.
//
// It lives in the lab beside device_peaks.h (the measured roofs) and describes what the runtime's GPU pipelines
// do, so it must change with them; it is plain host code (no CUDA), built in every lab configuration so that its
// tests run without a GPU.
#pragma once

#include <cstdint>

#include "rgs/lab/frame_census.h"

namespace rgs::lab {

/// Stages timed by rgs-bench (runtime::StageTimes without the total).
enum class RooflineStage : int { kPreprocess = 0, kSort = 1, kRanges = 2, kRender = 3 };
inline constexpr int kRooflineStages = 4;

/// "preprocess", "sort", "ranges", "render".
const char* roofline_stage_name(RooflineStage stage);

/// What one frame does, as the model needs it.
struct FrameWorkInputs {
  /// The RoofGS pipeline (kernels/roofgs_pipeline.h); false: the baseline pipeline (baseline_pipeline.h).
  bool roofgs = false;
  // RoofGS switches (ignored for the baseline pipeline).
  bool compact = false;      ///< compact attributes (FP16 geometry, INT8 SH) instead of FP32
  bool dc_residual = false;  ///< the compact scene has the DC residual (format/SPEC.md §4.8): 3 B more a Gaussian
  bool fused = false;        ///< fused preprocess kernel instead of preprocess + scan + duplicate
  bool key32 = false;        ///< 32-bit keys (else 64-bit)
  bool snugbox = false;      ///< SnugBox + AccuTile tile culling
  bool folded = false;       ///< folded dual-pixel rasterizer
  bool fast_exp = false;     ///< Schraudolph exp in the rasterizer
  bool depth_order = false;  ///< tied 32-bit keys put in depth order after the sort (RoofGS+)
  /// The image has a depth plane (rgs-bench renders without one).
  bool depth_plane = false;

  uint64_t gaussians = 0;    ///< N, Gaussians in the scene
  /// V ≤ N, Gaussians that survive culling and reach the tile stage. The renderer does not report it;
  /// rgs-bench passes N, which makes every V term an upper bound.
  uint64_t visible = 0;
  uint32_t sh_degree = 0;    ///< 0..3; K = (degree + 1)² coefficients per channel
  /// L, work items of emit_large_gaussians: chunks of up to 16 slices of the RoofGS Gaussians with more than
  /// kernels::kSerialTileLimit (16) tiles, a warp each (GpuRenderStats::large_chunks of the view).
  uint64_t large_chunks = 0;
  uint64_t pairs = 0;        ///< P, (tile, Gaussian) pairs sorted
  int sort_bits = 0;         ///< key bits the radix sort covers (GpuRenderStats::sort_bits)
  uint64_t tiles = 0;        ///< T = tiles_x · tiles_y (16×16 pixels each)
  uint64_t pixels = 0;       ///< W · H
};

/// Bytes requested from global memory (reads + writes) and FLOPs of one stage of one frame: `flops` at the
/// FP32 rate, `half_flops` at the binary16 (half2) rate where one exists (RooflinePeaks::half_gflops).
struct StageWork {
  double bytes = 0;
  double flops = 0;
  double half_flops = 0;
};

/// The four stages of one frame, indexed by RooflineStage.
struct FrameWork {
  StageWork stages[kRooflineStages];
  const StageWork& operator[](RooflineStage s) const { return stages[static_cast<int>(s)]; }
};

// Per-item FLOP counts of the model (docs/lab/ROOFLINE.md has the derivation of each).

/// expf as compiled by CUDA 13 (4 fma + add + mul; the SFU ex2 is not counted).
inline constexpr double kFlopsExpf = 10;
/// logf as compiled by CUDA 13 (12 fma + add + 2 mul).
inline constexpr double kFlopsLogf = 27;
/// Schraudolph fast exp: one fma (clamps and floor are not FLOPs).
inline constexpr double kFlopsFastExp = 2;
/// View transform p_cam = R·p + t, done for every Gaussian (9 mul + 9 add).
inline constexpr double kFlopsViewTransform = 18;
/// The rest of the 3DGS projection of a visible Gaussian: 3D covariance 78, EWA 2D covariance 77,
/// determinant 3, conic 4, radius 9, pixel mean 8, tile rectangle 18, SH view direction 12.
inline constexpr double kFlopsProjectVisible = 209;
/// Tile rectangle recomputed by a separate duplicate kernel.
inline constexpr double kFlopsTileRect = 18;
/// Depth bin of the 32-bit key (2 sub, div, mul).
inline constexpr double kFlopsDepthBin = 4;
/// SnugBox threshold 2·ln(255·o): 2 mul + logf.
inline constexpr double kFlopsSnugThreshold = 2 + kFlopsLogf;
/// One AccuTile walk's setup: SnugBox (2 mul, 2 sqrt, Kahan determinant 6) and the walk's rectangle and
/// extreme point (14). Once per visible Gaussian in the fused kernel, twice with the separate stages.
inline constexpr double kFlopsAccutileSetup = 24;
/// One AccuTile slice: interval ends 7, two ellipse–line intersections 20, tile interval 6.
inline constexpr double kFlopsAccutileSlice = 33;
/// Front-to-back blend of one pixel, baseline form: T·(1 − α) 2, C += c·α·T for 3 channels 9.
inline constexpr double kFlopsBlend = 11;
/// The folded rasterizer's blend (blend_step_fma): w = α·T 1, T − w 1, C = fma(c, w, C) for 3 channels 6.
inline constexpr double kFlopsBlendFma = 8;
/// Extra blend work with a depth plane: w = α·T, depth·w and 2 sums (baseline form); fma(depth, w, ·) and
/// one sum (folded form, w already there).
inline constexpr double kFlopsBlendDepth = 4;
inline constexpr double kFlopsBlendDepthFma = 3;
/// Folding C1..C6 of one (Gaussian, tile) pair at the shared-memory load (tile-local mean 2, C1..C6 19).
inline constexpr double kFlopsFoldPair = 21;
/// Lanes of the warp emit_large_gaussians gives a work item, each of which rebuilds the large Gaussian's walk.
inline constexpr double kLargeItemThreads = 32;

/// FLOPs of SH colour of degree d: basis (0, 3, 18, 48) + 3 channels × (K products, K − 1 sums, + 0.5).
double sh_colour_flops(uint32_t degree);

/// Bytes per Gaussian of the attributes the preprocess reads: FP32 44 + 12·K (mean 12, rotation 16, scale 12,
/// opacity 4, SH 12·K), compact 28 + 3·K (mean 12, rotation 8, scale 6, opacity 2, SH 3·K), + 3 with the DC
/// residual (compact only).
double attribute_bytes(bool compact, uint32_t degree, bool dc_residual = false);

/// Radix-sort passes of CUB's onesweep DeviceRadixSort over `sort_bits` key bits: ceil(sort_bits / 8)
/// (8-bit digits, ONESWEEP_RADIX_BITS of CUB's tuning policies for keys of ≥ 4 bytes); 0 for 0 bits.
int radix_passes(int sort_bits);

/// FLOPs of one (pair, pixel) evaluation in the render stage, every evaluation assumed to blend (upper
/// bound): unfolded 2 (dx, dy) + 9 (power) + exp, then o·e (expf: 1) or power + ln o (fast exp: 1), + blend
/// (11); folded 7.5 (5 fma for the first pixel, 2 fma + 1 add for the second, halved) + exp + FMA blend (9).
/// Baseline 33, fast exp 25, folded 26.5, folded + fast exp 18.5; + 4 (folded: + 3) with a depth plane.
double render_eval_flops(bool folded, bool fast_exp, bool depth_plane);

/// Bytes and FLOPs of every stage of one frame (formulas in roofline_model.cpp and docs/lab/ROOFLINE.md).
FrameWork frame_work(const FrameWorkInputs& in);

/// The work one frame cannot avoid whatever the algorithm, from its census (docs/lab/ROOFLINE.md#the-true-floor):
/// preprocess: read every mean (12 B) to cull, the rest of the geometry of the visible Gaussians (rotation,
/// scale, opacity: 16 B, compact) to project them, the SH (3K B) of the contributing ones, and write a 24 B
/// splat record (mean 8, conic and ln o 8, colour 6, pad 2) for each contributing one; FLOPs: view transform
/// of all, projection of the visible, SH colour of the contributing. Sort: the contributing Gaussians sorted
/// once by depth (32-bit keys and values), and the pairs of `cell` that blend emitted in that order (8 B)
/// and placed by a one-pass counting sort on the cell (read 8 B, write 4 B), which also gives each cell's
/// range (ranges: no work). Render: the blending pairs' records loaded once per cell (24 B) and the RGBA
/// float32 image written (16 B per pixel); per blended (pixel, Gaussian) the folded power in FP32 (7.5
/// FLOPs), the fast exp and the FMA blend at the half2 rate (10 FLOPs). No pixel is evaluated for a
/// Gaussian that does not blend there.
FrameWork floor_work(const FrameCensus& census, uint32_t sh_degree, CensusCell cell = CensusCell::k16);

/// Measured roofs, 10^9 units.
struct RooflinePeaks {
  double memory_gbps = 0;     ///< bandwidth roof, GB/s
  double compute_gflops = 0;  ///< FP32 compute roof, GFLOP/s
  /// binary16 compute roof (half2 FMA), GFLOP/s; 0 when not measured: half_flops then run at compute_gflops.
  double half_gflops = 0;
  /// Ridge point, FLOP per byte: compute_gflops / memory_gbps (0 without a bandwidth).
  double ridge() const { return memory_gbps > 0 ? compute_gflops / memory_gbps : 0.0; }
};

/// One stage placed on the roofline.
struct RooflinePoint {
  double ms = 0;             ///< measured stage time (median)
  double bytes = 0, flops = 0;
  double gbps = 0;           ///< bytes / time
  double gflops = 0;         ///< flops / time
  double intensity = 0;      ///< FLOP per byte (0 when no bytes)
  double pct_bandwidth = 0;  ///< gbps / peak bandwidth · 100
  double pct_compute = 0;    ///< gflops / peak compute · 100
  /// The roof above the point: "memory" when intensity < ridge (the bandwidth roof is the lower one there),
  /// else "compute"; "unknown" without both peaks.
  const char* bound = "unknown";
  /// Attainable GFLOP/s at this intensity, min(compute peak, intensity · bandwidth peak), and the share of it
  /// the stage reached (for a stage without FLOPs: pct_bandwidth).
  double attainable_gflops = 0;
  double pct_of_roof = 0;
  /// The stage's roofline floor, ms: max(bytes / bandwidth peak, FLOPs / compute peak + half FLOPs / half
  /// peak), the time the work takes at the roofs (0 without both peaks); and the measured time over it (0
  /// when the floor is 0).
  double floor_ms = 0;
  double times_floor = 0;
};

/// Places `work`, timed at `ms` milliseconds, against `peaks`. A non-positive time gives zero rates.
RooflinePoint roofline_point(const StageWork& work, double ms, const RooflinePeaks& peaks);

}  // namespace rgs::lab
