// Device functions shared by the RoofGS preprocess kernels (separate and fused): reading one Gaussian from
// the compact or FP32 attributes, projecting it (the CPU reference's preprocess_cpu, step for step), and
// walking its tiles in emission order.
#pragma once

#include <cooperative_groups.h>
#include <cooperative_groups/scan.h>
#include <cuda_fp16.h>

#include <cstdint>
#include <type_traits>

#include "launch_util.cuh"
#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/sort_key.h"
#include "rgs/kernels/shared/spherical_harmonics.h"
#include "rgs/kernels/shared/tile_culling.h"

namespace rgs::kernels::detail {

namespace cg = cooperative_groups;

/// A projected Gaussian in registers (its colour is computed apart: shade_gaussian).
struct ProjectedRegs {
  float depth;
  float px, py;
  Cov2 cov;
  Conic conic;
  float opacity, log_opacity;
  int radius;
  TileRect rect;     ///< 3DGS rectangle
  float snug_t;      ///< SnugBox threshold (snugbox_accutile)
  uint32_t depth_bin;///< key32
  uint32_t tiles;    ///< pairs it emits; 0 = culled
};

__device__ inline float half_bits_to_float(uint16_t bits) { return __half2float(__ushort_as_half(bits)); }

/// The SH value q at index j = 3k + c of a block [K, 3], dequantized as s[degree(k)][c]·q: one rounded
/// product, as format::dequantize on the host.
__device__ inline float dequantize_sh_value(const CompactGaussiansView& c, int j, int8_t q) {
  return c.sh_scales[sh_degree_of_coefficient(j / 3)][j % 3] * static_cast<float>(q);
}

/// The DC value of channel j (0..2) for DC code q and residual r: s[0][j]·(q + r/256), one rounded product as
/// format::sh_dc_value on the host (q + r/256 is exact in float32).
__device__ inline float dequantize_sh_dc(const CompactGaussiansView& c, int j, int8_t q, int8_t r) {
  return c.sh_scales[0][j] * (static_cast<float>(q) + static_cast<float>(r) * (1.0f / 256.0f));
}

/// Value j of Gaussian g's SH block [K, 3] (j = 3k + c), dequantized (dequantize_sh_value, dequantize_sh_dc).
__device__ inline float dequantize_sh(const CompactGaussiansView& c, uint32_t g, int j) {
  const uint64_t k_count = uint64_t(sh_coefficients_for(int(c.sh_degree)));
  const int8_t q = c.sh[uint64_t(g) * k_count * 3 + uint64_t(j)];
  if (j < 3 && c.sh_dc_residual != nullptr) return dequantize_sh_dc(c, j, q, c.sh_dc_residual[uint64_t(g) * 3 + j]);
  return dequantize_sh_value(c, j, q);
}

/// Inclusive sum of `value` over lanes 0..lane of the calling warp (all 32 lanes call it).
__device__ inline uint32_t warp_inclusive_sum(uint32_t value, int lane) {
  for (int offset = 1; offset < 32; offset *= 2) {
    const uint32_t up = __shfl_up_sync(0xffffffffu, value, offset);
    if (lane >= offset) value += up;
  }
  return value;
}

/// Gaussian g's mean [3] (float32 in both profiles).
__device__ inline void load_mean(const GaussianSource& src, bool compact, uint32_t g, float mean[3]) {
  const float* means = compact ? src.compact.means : src.fp32.means;
  for (int a = 0; a < 3; ++a) mean[a] = means[3 * uint64_t(g) + a];
}

/// Gaussian g's geometry and opacity, dequantized in registers when compact (same values as
/// kernels::dequantize and format::dequantize: FP16 widened exactly, exp of log scales).
template <bool kCompact>
__device__ inline void load_geometry(const GaussianSource& src, uint32_t g, float mean[3], float scale[3],
                                     float q[4], float* opacity) {
  if constexpr (kCompact) {
    const CompactGaussiansView& c = src.compact;
    load_mean(src, true, g, mean);
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
    load_mean(src, false, g, mean);
    const float4 r = *reinterpret_cast<const float4*>(f.rotations + 4 * uint64_t(g));
    q[0] = r.x;
    q[1] = r.y;
    q[2] = r.z;
    q[3] = r.w;
    for (int a = 0; a < 3; ++a) scale[a] = f.scales[3 * uint64_t(g) + a];
    *opacity = f.opacities[g];
  }
}

/// Gaussian g's block of kValues int8 values at byte kValues·g of `array` (the [N, K, 3] SH, j = 3k + c, or the
/// [N, 3] DC residual), as words in block order: byte b of words[i] is value 4i + b (bytes past the block's end
/// are the next Gaussian's or the array's zero padding). The block starts at any byte (27 bytes a Gaussian at degree 2), so
/// it is read with the aligned 32-bit words that cover it (16-byte words at degree 3, whose 48-byte blocks are
/// aligned), realigned with funnel shifts: at most ⌈(kValues + 3) / 4⌉ + 1 loads instead of one per value
/// (2 at degree 0). Reads stay inside the allocation, which is padded to kCompactShPadding bytes.
template <int kValues>
__device__ inline void load_sh_words(const int8_t* array, uint32_t g, uint32_t words[(kValues + 3) / 4]) {
  constexpr int kWords = (kValues + 3) / 4;
  const uint64_t start = uint64_t(g) * uint64_t(kValues);
  if constexpr (kValues == 3 * kMaxShCoefficients) {
    const uint4* block = reinterpret_cast<const uint4*>(array + start);
#pragma unroll
    for (int i = 0; i < 3; ++i) {
      const uint4 v = __ldg(block + i);
      words[4 * i] = v.x, words[4 * i + 1] = v.y, words[4 * i + 2] = v.z, words[4 * i + 3] = v.w;
    }
  } else {
    const uint32_t* aligned = reinterpret_cast<const uint32_t*>(array + (start & ~uint64_t(3)));
    const int covering = (int(start & 3u) + kValues + 3) / 4;
    uint32_t raw[kWords + 1];
#pragma unroll
    for (int i = 0; i < kWords + 1; ++i) raw[i] = i < covering ? __ldg(aligned + i) : 0u;
    const uint32_t shift = uint32_t(start & 3u) * 8u;
#pragma unroll
    for (int i = 0; i < kWords; ++i) words[i] = __funnelshift_r(raw[i], raw[i + 1], shift);
  }
}

/// Colour of Gaussian g along the unit direction (x, y, z) at SH degree kDegree (the scene's, chosen at
/// launch: the loads, registers and basis terms are those of that degree only): the SH coefficients
/// dequantized in registers when compact (s[d][c]·q, or s[0][c]·(q + r/256) for the DC term of a scene with the
/// DC residual: one rounded product as format::dequantize on the host), then sh_to_colour.
template <bool kCompact, int kDegree>
__device__ inline void load_colour(const GaussianSource& src, uint32_t g, float x, float y, float z,
                                   float rgb[3]) {
  constexpr int kValues = 3 * (kDegree + 1) * (kDegree + 1);
  if constexpr (kCompact) {
    const CompactGaussiansView& c = src.compact;
    uint32_t words[(kValues + 3) / 4];
    load_sh_words<kValues>(c.sh, g, words);
    float sh[kMaxShCoefficients * 3];  // sh_to_colour's shape; entries past kValues are never read
#pragma unroll
    for (int j = 0; j < kValues; ++j) {
      const auto q = static_cast<int8_t>(uint8_t(words[j / 4] >> (8 * (j % 4))));
      sh[j] = dequantize_sh_value(c, j, q);
    }
    if (c.sh_dc_residual != nullptr) {  // uniform across the launch
      uint32_t residual[1];
      load_sh_words<3>(c.sh_dc_residual, g, residual);
#pragma unroll
      for (int j = 0; j < 3; ++j) {
        const auto q = static_cast<int8_t>(uint8_t(words[0] >> (8 * j)));
        sh[j] = dequantize_sh_dc(c, j, q, static_cast<int8_t>(uint8_t(residual[0] >> (8 * j))));
      }
    }
    sh_to_colour(sh, kDegree, x, y, z, rgb);
  } else {
    sh_to_colour(src.fp32.sh + uint64_t(g) * uint64_t(kValues), kDegree, x, y, z, rgb);
  }
}

/// Calls launch(std::integral_constant<int, d>{}) for SH degree d in 0..3, the degree the kernels are
/// specialized for; cudaErrorInvalidValue for any other degree (the format allows none).
template <typename Launch>
inline cudaError_t with_sh_degree(uint32_t degree, Launch&& launch) {
  switch (degree) {
    case 0: launch(std::integral_constant<int, 0>{}); return cudaSuccess;
    case 1: launch(std::integral_constant<int, 1>{}); return cudaSuccess;
    case 2: launch(std::integral_constant<int, 2>{}); return cudaSuccess;
    case 3: launch(std::integral_constant<int, 3>{}); return cudaSuccess;
    default: return cudaErrorInvalidValue;
  }
}

/// Tiles a visible Gaussian may receive under AccuTile: the grid, limited to the baseline rectangle when
/// requested (runtime cpu_renderer.cpp accutile_limit).
__device__ inline TileRect accutile_limit(const FrameParams& frame, const RoofgsFrame& roofgs,
                                          const TileRect& baseline_rect) {
  const TileRect grid{0, 0, int(frame.tiles_x), int(frame.tiles_y)};
  return roofgs.accutile_within_baseline_rect ? intersect(grid, baseline_rect) : grid;
}

/// Projects Gaussian g (preprocess_cpu's steps and order, all but the colour: shade_gaussian). Returns false
/// when it is culled. With SnugBox + AccuTile the tile count is left at 0 for count_accutile_tiles_block
/// (preprocess_gaussian does both).
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
  if (frame.antialiased) opacity *= antialias_compensation(cov, det);
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
  p->tiles = uint32_t(tile_area(rows_of_pass(rect, frame)));
  if (roofgs.snugbox_accutile) {
    float t = 0.f;
    if (!snugbox_threshold(opacity, &t)) return false;
    p->snug_t = t;
    p->tiles = 0;
  } else if (p->tiles == 0) {
    return false;  // no tile in this pass's rows
  }
  p->depth_bin = roofgs.key32 ? quantize_depth(p->depth, roofgs.quantizer) : 0u;
  return true;
}

/// Colour of visible Gaussian g, stored with its ln o (ProjectedRegs::log_opacity) to out.colour_log_opacity:
/// its SH seen along the unit direction from the camera centre to its mean (preprocess_cpu's last step). Apart
/// from project_gaussian so that the fused kernel can publish its block's pair count before this work, the SH
/// being needed by the rasterizer only.
template <bool kCompact, int kDegree>
__device__ inline void shade_gaussian(const GaussianSource& src, uint32_t g, const FrameParams& frame,
                                      float log_opacity, const RoofgsProjected& out) {
  float mean[3];
  load_mean(src, kCompact, g, mean);
  float dir[3] = {mean[0] - frame.camera_centre[0], mean[1] - frame.camera_centre[1],
                  mean[2] - frame.camera_centre[2]};
  const float length = sqrtf(dir[0] * dir[0] + dir[1] * dir[1] + dir[2] * dir[2]);
  for (float& d : dir) d = d / length;
  float rgb[3];
  load_colour<kCompact, kDegree>(src, g, dir[0], dir[1], dir[2], rgb);
  reinterpret_cast<float4*>(out.colour_log_opacity)[g] = make_float4(rgb[0], rgb[1], rgb[2], log_opacity);
}

/// Stores the per-Gaussian outputs the later stages read, but the colour and ln o (shade_gaussian).
__device__ inline void store_projected(const ProjectedRegs& p, uint32_t g, const RoofgsProjected& out) {
  out.depths[g] = p.depth;
  reinterpret_cast<float2*>(out.means2d)[g] = make_float2(p.px, p.py);
  reinterpret_cast<float4*>(out.conic_opacity)[g] = make_float4(p.conic.a, p.conic.b, p.conic.c, p.opacity);
  out.radii[g] = p.radius;
}

/// A lane counts the tiles of a walk with at most this many slices alone, and keeps their spans for the
/// emission; longer walks get the block's help (count_accutile_tiles_block).
constexpr int kSoloSlices = 4;

/// The tiles of a visible Gaussian as slices: AccuTile's walk (SnugBox + AccuTile), or the rows of its 3DGS
/// rectangle. Emission order is slice by slice, ascending along each slice, which is the CPU reference's
/// order (cpu_renderer.cpp for_each_tile_of) whether the slices are walked by one thread or by warps.
struct TileWalk {
  bool accutile;
  AccutileWalk walk;  ///< accutile only
  TileRect rect;      ///< rectangle only: slices are its rows
  /// accutile: the spans of slices u_first + i (i < kSoloSlices) kept from the count (empty past u_end), so
  /// the emission does not intersect the ellipse again. Set by count_accutile_tiles_block for short walks.
  bool spans_kept = false;
  int kept_first[kSoloSlices], kept_end[kSoloSlices];

  __device__ int slice_begin() const { return accutile ? walk.u_first : rect.y_min; }
  __device__ int slice_end() const { return accutile ? walk.u_end : rect.y_max; }
  /// Tiles [*first, *end) of slice k along the slice.
  __device__ void span(int k, int* first, int* end) const {
    if (accutile) {
      accutile_slice(walk, k, first, end);
    } else {
      *first = rect.x_min;
      *end = rect.x_max;
    }
  }
  /// Tile id of position v in slice k.
  __device__ uint32_t tile(int k, int v, uint32_t tiles_x) const {
    const bool k_is_row = !accutile || walk.walk_rows;
    return k_is_row ? uint32_t(k) * tiles_x + uint32_t(v) : uint32_t(v) * tiles_x + uint32_t(k);
  }
};

/// Limits an AccuTile walk to the tile rows [row_begin, row_end): its slices when it walks rows, else every
/// slice's span. The walk keeps the whole frame's direction and per-slice arithmetic, so it visits exactly the
/// whole frame's tiles of those rows. Both pairs are computed and the walk's direction selects one: a reference
/// to either member would put the walk in local memory, stored and reloaded at addresses that differ by lane.
__device__ inline void restrict_to_rows(AccutileWalk* w, int row_begin, int row_end) {
  const int u_first = max(w->u_first, row_begin), v_first = max(w->v_first, row_begin);
  const int u_end = max(u_first, min(w->u_end, row_end)), v_end = max(v_first, min(w->v_end, row_end));
  if (w->walk_rows) {
    w->u_first = u_first, w->u_end = u_end;
  } else {
    w->v_first = v_first, w->v_end = v_end;
  }
}

/// The walk of a projected Gaussian over the tile rows of this pass (FrameParams::tile_row_begin/end), built
/// from its whole-frame rectangle p.rect.
__device__ inline TileWalk make_tile_walk(const ProjectedRegs& p, const FrameParams& frame,
                                          const RoofgsFrame& roofgs) {
  TileWalk w;
  w.accutile = roofgs.snugbox_accutile;
  w.rect = rows_of_pass(p.rect, frame);
  if (w.accutile) {
    w.walk = make_accutile_walk(make_snugbox(p.px, p.py, p.cov, p.snug_t), accutile_limit(frame, roofgs, p.rect));
    restrict_to_rows(&w.walk, int(frame.tile_row_begin), int(frame.tile_row_end));
  }
  return w;
}

/// What a pair needs besides its tile: the Gaussian, its key's depth part, and where its pairs start.
struct PairSource {
  uint32_t g;
  uint32_t depth_bin;  ///< key32
  float depth;         ///< 64-bit keys
  uint64_t offset;     ///< position of the Gaussian's first pair
};

/// Destination of the pairs: 32- or 64-bit keys, values, and the capacity (positions ≥ capacity are skipped,
/// so an undersized buffer is detected by the caller from the pair total without out-of-bounds writes).
struct PairSink {
  uint64_t capacity;
  uint64_t* keys64;
  uint32_t* keys32;
  uint32_t* values;

  __device__ void write(uint64_t position, uint32_t tile, const PairSource& s, const RoofgsFrame& roofgs) const {
    if (position >= capacity) return;
    if (roofgs.key32) {
      keys32[position] = make_key32(tile, s.depth_bin, roofgs.key_depth_bits);
    } else {
      keys64[position] = make_key64(tile, s.depth);
    }
    values[position] = s.g;
  }
};

/// Writes all pairs of one Gaussian from the calling thread.
__device__ inline void emit_pairs_serial(const TileWalk& w, const PairSource& s, const PairSink& sink,
                                         const FrameParams& frame, const RoofgsFrame& roofgs) {
  uint64_t position = s.offset;
  if (w.spans_kept) {
#pragma unroll
    for (int i = 0; i < kSoloSlices; ++i) {  // unrolled: the kept spans stay in registers
      for (int v = w.kept_first[i]; v < w.kept_end[i]; ++v) {
        sink.write(position++, w.tile(w.walk.u_first + i, v, frame.tiles_x), s, roofgs);
      }
    }
    return;
  }
  for (int k = w.slice_begin(); k < w.slice_end(); ++k) {
    int first, end;
    w.span(k, &first, &end);
    for (int v = first; v < end; ++v) sink.write(position++, w.tile(k, v, frame.tiles_x), s, roofgs);
  }
}

/// Shared memory of count_accutile_tiles_block for a block of kThreads threads: the block's long walks, their
/// slices' running offsets in one flat range, and their tile counts.
template <int kThreads>
struct LongWalks {
  AccutileWalk walk[kThreads];
  uint32_t first_slice[kThreads + 1];  ///< walk h's slices are flat indices [first_slice[h], first_slice[h + 1])
  uint32_t count[kThreads];
  uint32_t size;
};

/// Tile count of each thread's AccuTile walk (the count for_each_accutile_tile returns). A walk of at most
/// kSoloSlices slices is counted by its thread, which keeps the spans in the walk (TileWalk::kept_first/
/// kept_end) for the emission. The longer walks of the block are counted by the whole block: their slices
/// are laid end to end and dealt over the threads, so that a Gaussian spanning the screen (135 slices at 4K,
/// each with two square roots and four divisions), or a warp with ten of them, does not hold the block for
/// the time of all their slices in one thread or one warp. All threads of the block must call it; `active`
/// false for a thread without a walk. Counts are integer sums, so the order of the atomics does not matter.
template <int kThreads>
__device__ inline uint32_t count_accutile_tiles_block(TileWalk* tile_walk, bool active,
                                                      LongWalks<kThreads>& shared) {
  const AccutileWalk& walk = tile_walk->walk;
  const uint32_t thread = threadIdx.x;
  const int slices = active ? walk.u_end - walk.u_first : 0;
  const bool long_walk = slices > kSoloSlices;
  uint32_t count = 0;
  if (active && !long_walk) {
#pragma unroll
    for (int i = 0; i < kSoloSlices; ++i) {
      int first = 0, end = 0;
      if (i < slices) accutile_slice(walk, walk.u_first + i, &first, &end);
      tile_walk->kept_first[i] = first;
      tile_walk->kept_end[i] = end;
      count += end > first ? uint32_t(end - first) : 0u;
    }
    tile_walk->spans_kept = true;
  }
  if (thread == 0) shared.size = 0;
  // Most blocks hold no long walk: the barrier that publishes the reset also tells every thread whether one does.
  if (!__syncthreads_or(long_walk)) return count;  // uniform over the block
  uint32_t h = 0;
  if (long_walk) {
    h = atomicAdd(&shared.size, 1u);
    shared.walk[h] = walk;
    shared.count[h] = 0;
  }
  __syncthreads();
  const uint32_t longs = shared.size;
  if (thread < 32) {  // running offsets of the long walks' slices, 32 walks per step
    uint32_t carry = 0;
    for (uint32_t base = 0; base < longs; base += 32) {
      const uint32_t i = base + thread;
      const uint32_t own = i < longs ? uint32_t(shared.walk[i].u_end - shared.walk[i].u_first) : 0u;
      const uint32_t inclusive = warp_inclusive_sum(own, int(thread));
      if (i < longs) shared.first_slice[i] = carry + inclusive - own;
      carry += __shfl_sync(0xffffffffu, inclusive, 31);
    }
    if (thread == 0) shared.first_slice[longs] = carry;
  }
  __syncthreads();
  const uint32_t total = shared.first_slice[longs];
  uint32_t walk_of = 0;  // the long walk of flat slice f: first_slice[walk_of] ≤ f < first_slice[walk_of + 1]
  for (uint32_t f = thread; f < total; f += kThreads) {
    while (shared.first_slice[walk_of + 1] <= f) ++walk_of;  // f only grows
    const AccutileWalk& w = shared.walk[walk_of];
    int lo, hi;
    accutile_slice(w, w.u_first + int(f - shared.first_slice[walk_of]), &lo, &hi);
    if (hi > lo) atomicAdd(&shared.count[walk_of], uint32_t(hi - lo));
  }
  __syncthreads();
  return long_walk ? shared.count[h] : count;
}

/// The preprocess of Gaussian g but its colour (shade_gaussian): projection, tile walk and tile count. Called
/// by every thread of the block (count_accutile_tiles_block); threads with g ≥ count get nothing. Returns true
/// when the Gaussian is visible (p->tiles > 0).
template <bool kCompact, int kThreads>
__device__ inline bool preprocess_gaussian(const GaussianSource& src, uint32_t g, const FrameParams& frame,
                                           const RoofgsFrame& roofgs, LongWalks<kThreads>& long_walks,
                                           ProjectedRegs* p, TileWalk* walk) {
  bool visible = g < src.count && project_gaussian<kCompact>(src, g, frame, roofgs, p);
  if (visible) *walk = make_tile_walk(*p, frame, roofgs);
  if (roofgs.snugbox_accutile) {  // the same for the whole launch
    p->tiles = count_accutile_tiles_block(walk, visible, long_walks);
    visible = visible && p->tiles > 0;
  }
  if (!visible) p->tiles = 0;
  return visible;
}

/// Adds the tiles of the calling warp's Gaussians with more than kSubtileLargeTiles tiles to *counter
/// (the automatic sub-tile culling's measure): a warp sum, one atomic per warp that has any. Every lane of the
/// warp calls it, with 0 for a culled Gaussian.
__device__ inline void count_large_pairs(uint32_t tiles, unsigned long long* counter) {
  const uint32_t large_tiles = __reduce_add_sync(0xffffffffu, tiles > kSubtileLargeTiles ? tiles : 0u);
  if (large_tiles != 0 && threadIdx.x % 32 == 0) atomicAdd(counter, static_cast<unsigned long long>(large_tiles));
}

/// Rebuilds the tile walk of Gaussian g from the per-Gaussian arrays (what duplicate_roofgs and
/// emit_large_gaussians read): the same inputs as in the preprocess, so the same walk.
__device__ inline TileWalk load_tile_walk(const RoofgsProjected& in, uint32_t g, const FrameParams& frame,
                                          const RoofgsFrame& roofgs) {
  ProjectedRegs p;
  const float2 mean = reinterpret_cast<const float2*>(in.means2d)[g];
  p.px = mean.x;
  p.py = mean.y;
  p.cov = Cov2{in.cov2d[3 * uint64_t(g)], in.cov2d[3 * uint64_t(g) + 1], in.cov2d[3 * uint64_t(g) + 2]};
  p.snug_t = in.snug_t[g];
  p.rect = tile_rect(p.px, p.py, in.radii[g], int(frame.tiles_x), int(frame.tiles_y));
  return make_tile_walk(p, frame, roofgs);
}

/// Emits the pairs of Gaussian g (kSerialTileLimit tiles or fewer) from this thread, or lists it for
/// emit_large_gaussians, which spreads a large Gaussian over warps, one per chunk of its walk. Without the
/// list, one thread would write a screen-filling Gaussian's 32,400 pairs at 4K while the rest of the GPU
/// waits for it. A Gaussian whose items do not all fit the list writes its pairs itself.
__device__ inline void emit_or_defer(const TileWalk& walk, const PairSource& source, uint32_t tiles,
                                     const PairSink& sink, const LargeGaussianList& large, const FrameParams& frame,
                                     const RoofgsFrame& roofgs) {
  if (tiles > kSerialTileLimit && large.capacity > 0) {
    const uint32_t slices = uint32_t(walk.slice_end() - walk.slice_begin());
    const uint32_t per_chunk = large_chunk_slices(slices, tiles);
    const uint32_t chunks = (slices + per_chunk - 1) / per_chunk;
    // One atomic per group of converged lanes (all on one counter, which serialized them), each lane
    // taking its place in the group's range; the items' order does not reach the output.
    const cg::coalesced_group lanes = cg::coalesced_threads();
    const uint32_t before = cg::exclusive_scan(lanes, chunks);
    unsigned long long first = 0;
    if (lanes.thread_rank() == lanes.num_threads() - 1) {
      first = atomicAdd(large.count, static_cast<unsigned long long>(before + chunks));
    }
    const unsigned long long i = lanes.shfl(first, lanes.num_threads() - 1) + before;
    const bool fits = i + chunks <= large.capacity;
    // Items of a Gaussian that does not fit whole are marked unused, and its thread writes the pairs itself.
    for (uint32_t c = 0; c < chunks && i + c < large.capacity; ++c) {
      const uint32_t first = c * per_chunk;
      large.items[i + c] = LargeGaussian{source.offset, fits ? source.g : kNoLargeGaussian, uint16_t(first),
                                         uint16_t(min(per_chunk, slices - first))};
    }
    if (fits) return;
  }
  if (tiles > 0) emit_pairs_serial(walk, source, sink, frame, roofgs);
}

}  // namespace rgs::kernels::detail
