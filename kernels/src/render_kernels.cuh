// The render stage's kernels (3DGS renderCUDA and its RoofGS reorganization) and their launch templates, for
// the .cu files that compile variants of them: render.cu the product's (those the presets reach), the lab its
// own (lab/). One thread block per 16×16 tile; the tile's sorted Gaussians are fetched in batches into shared
// memory and blended front to back. Per-pixel rules and their order are the CPU reference's
// (runtime/src/cpu_renderer.cpp blend_tile_baseline and blend_tile_folded): skip power > 0 (P > 0),
// α = min(0.99, ·), skip α < 1/255, stop before the Gaussian that would make T < 1e−4, out = C + T·bg; the block
// stops when all its pixels are done. Everything is file-local to the including .cu file (an unnamed
// namespace): each compiles and registers only the variants it launches.
#pragma once

#include "launch_util.cuh"
#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/half_blend.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/kernels/shared/tile_culling.h"

namespace rgs::kernels {
namespace {

constexpr int kTilePixels = kTileSize * kTileSize;
/// Threads per tile of the dual-pixel kernel: 16 × 8, each shading (x, y) and (x, y + 1).
constexpr int kDualThreads = kTilePixels / 2;

/// Per-Gaussian inputs of the render stage (device arrays indexed by Gaussian id): the baseline's
/// (ProjectedArrays: colour_log_opacity null) or the RoofGS preprocess's (RoofgsProjected: rgb null).
struct RenderInputs {
  const float2* means2d;
  const float4* conic_opacity;
  const float* rgb;                   // [N, 3], baseline
  const float4* colour_log_opacity;  // [N, 4] (r, g, b, ln o), RoofGS
  const float* depths;

  /// Colour of Gaussian id (kRoofgs: from colour_log_opacity).
  template <bool kRoofgs>
  __device__ float3 colour(uint32_t id) const {
    if (kRoofgs) {
      const float4 c = colour_log_opacity[id];
      return make_float3(c.x, c.y, c.z);
    }
    return make_float3(rgb[3 * id], rgb[3 * id + 1], rgb[3 * id + 2]);
  }
};

/// Running state of one pixel.
struct Pixel {
  float T = 1.f;
  float C[3] = {0.f, 0.f, 0.f};
  float depth_sum = 0.f, weight_sum = 0.f;
  bool done = false;
};

/// Front-to-back step with an α that passed the 1/255 test (cpu_renderer.cpp blend_step).
template <bool kDepth>
__device__ inline void blend(Pixel& s, float alpha, float r, float g, float b, float depth) {
  const float test_T = s.T * (1.f - alpha);
  if (test_T < kTransmittanceMin) {
    s.done = true;
    return;
  }
  s.C[0] += r * alpha * s.T;
  s.C[1] += g * alpha * s.T;
  s.C[2] += b * alpha * s.T;
  if (kDepth) {
    const float w = alpha * s.T;
    s.depth_sum += depth * w;
    s.weight_sum += w;
  }
  s.T = test_T;
}

template <bool kDepth>
__device__ inline void store(const Pixel& s, uint32_t x, uint32_t y, const FrameParams& frame, float4* rgba,
                             float* depth) {
  const uint64_t pix = uint64_t(y) * frame.width + x;
  rgba[pix] = make_float4(s.C[0] + s.T * frame.background[0], s.C[1] + s.T * frame.background[1],
                          s.C[2] + s.T * frame.background[2], 1.f - s.T);
  if (kDepth) depth[pix] = s.weight_sum > 0.f ? s.depth_sum / s.weight_sum : 0.f;
}

/// One pixel per thread, unfolded power (3DGS renderCUDA). kFastExp: α = min(0.99, exp̂(power + ln o)).
/// kRoofgs: the inputs are the RoofGS preprocess's.
template <bool kRoofgs, bool kFastExp, bool kDepth>
__global__ void __launch_bounds__(kTilePixels)
    render_pixel_kernel(const uint64_t* __restrict__ ranges, const uint32_t* __restrict__ values, RenderInputs in,
                        FrameParams frame, float sigma, float4* __restrict__ out_rgba, float* __restrict__ out_depth) {
  const uint32_t tile_y = frame.tile_row_begin + blockIdx.y;
  const uint32_t tile = tile_y * frame.tiles_x + blockIdx.x;
  const uint32_t px = blockIdx.x * kTileSize + threadIdx.x;
  const uint32_t py = tile_y * kTileSize + threadIdx.y;
  const uint32_t rank = threadIdx.y * kTileSize + threadIdx.x;
  const bool inside = px < frame.width && py < frame.height;
  const float pixf_x = static_cast<float>(px), pixf_y = static_cast<float>(py);
  const uint64_t begin = ranges[2 * uint64_t(tile)], end = ranges[2 * uint64_t(tile) + 1];

  __shared__ uint32_t collected_id[kTilePixels];
  __shared__ float2 collected_xy[kTilePixels];
  __shared__ float4 collected_conic_opacity[kTilePixels];
  __shared__ float collected_log_opacity[kFastExp ? kTilePixels : 1];

  Pixel s;
  s.done = !inside;
  for (uint64_t batch = begin; batch < end; batch += kTilePixels) {
    if (__syncthreads_count(s.done) == kTilePixels) break;
    const uint64_t p = batch + rank;
    if (p < end) {
      const uint32_t id = values[p];
      collected_id[rank] = id;
      collected_xy[rank] = in.means2d[id];
      collected_conic_opacity[rank] = in.conic_opacity[id];
      if (kFastExp) collected_log_opacity[rank] = in.colour_log_opacity[id].w;
    }
    __syncthreads();
    const int in_batch = static_cast<int>(end - batch < kTilePixels ? end - batch : kTilePixels);
    for (int j = 0; !s.done && j < in_batch; ++j) {
      const float2 xy = collected_xy[j];
      const float4 co = collected_conic_opacity[j];
      const float power = baseline_power(Conic{co.x, co.y, co.z}, xy.x - pixf_x, xy.y - pixf_y);
      if (power > 0.f) continue;
      const float alpha = kFastExp ? fminf(kAlphaMax, fast_exp(power + collected_log_opacity[j], sigma))
                                   : fminf(kAlphaMax, co.w * expf(power));
      if (alpha < kAlphaMin) continue;
      const uint32_t id = collected_id[j];
      const float3 c = in.colour<kRoofgs>(id);
      blend<kDepth>(s, alpha, c.x, c.y, c.z, kDepth ? in.depths[id] : 0.f);
    }
  }
  if (inside) store<kDepth>(s, px, py, frame, out_rgba, out_depth);
}

/// Whether a pair passes at a pixel of folded power P (P ≤ 0 and α ≥ 1/255), and its α = min(0.99, ·) when it
/// does. The fast exp goes through fast_exp_alpha_passes (integer-domain tests, the same decisions and bits as
/// fminf(0.99, fast_exp(P)) and its 1/255 test).
template <bool kFastExp>
__device__ inline bool folded_alpha(float P, float fast_exp_bias, float* alpha) {
  if (kFastExp) return fast_exp_alpha_passes(P, fast_exp_bias, alpha);
  *alpha = fminf(kAlphaMax, expf(P));
  return !(P > 0.f) && *alpha >= kAlphaMin;
}

/// Running state of one pixel of the folded loop: the sign of T holds the stop flag (T < 0: the pixel is done
/// and −T is its final transmittance; a live T never drops below 1e−4), which saves the loop a flag and its
/// predicate juggling.
struct FoldedPixel {
  float T = 1.f;
  float C[3] = {0.f, 0.f, 0.f};
  float depth_sum = 0.f, weight_sum = 0.f;

  __device__ bool live() const { return T > 0.f; }
  /// The final state in the pixel kernel's form, for store().
  __device__ Pixel finished() const {
    Pixel p;
    p.T = fabsf(T);
    p.C[0] = C[0], p.C[1] = C[1], p.C[2] = C[2];
    p.depth_sum = depth_sum, p.weight_sum = weight_sum;
    return p;
  }
};

/// Front-to-back step of the folded loop, the RoofGS form of cpu_renderer.cpp blend_step_fma (w = α·T,
/// T' = T − w, C += c·w as one FMA per channel), without branches since a warp's pixels rarely agree. `alpha`
/// is the pair's α when it passes and 0 when it does not; no separate liveness test is needed:
/// - live pixel, α = 0: w = +0, T' = T ≥ 1e−4 (a live T never drops below it), so nothing stops and C gains c·0;
/// - live pixel, α > 0: blend_step_fma's take or stop;
/// - done pixel (T < 0): T' = T·(1 − α) < 0 < 1e−4 counts as a stop, which adds c·0 and keeps T = −|T|.
/// So the bits are those of blend_step_fma (C + 0 = C exactly), at the same instructions for every pixel.
template <bool kDepth>
__device__ inline void blend_predicated(FoldedPixel& s, float alpha, float r, float g, float b, float depth) {
  const float w = alpha * s.T;
  const float test_T = s.T - w;
  const bool stop = test_T < kTransmittanceMin;
  const float w_taken = stop ? 0.f : w;
  s.C[0] = fmaf(r, w_taken, s.C[0]);
  s.C[1] = fmaf(g, w_taken, s.C[1]);
  s.C[2] = fmaf(b, w_taken, s.C[2]);
  if (kDepth) {
    s.depth_sum = fmaf(depth, w_taken, s.depth_sum);
    s.weight_sum += w_taken;
  }
  s.T = stop ? -fabsf(s.T) : test_T;
}

/// One (Gaussian, tile) pair as the folded loop reads it from shared memory: 16-byte words at one base address,
/// so a pair costs one load a word and no address arithmetic.
/// - FP32 blending: [C1 C2 C3 C4] [C5 C6 r g] [b depth · ·];
/// - binary16 blending (kHalf): [C1 C2 C3 C4] [C5 C6 (r, g) (b, ·)], the colour as binary16 pairs, read by
///   the half2 instructions through operand swizzles (half2_low, half2_high), and [depth · · ·] only with depth:
///   two loads a pair without it.
template <bool kHalf, bool kDepth>
struct PairRecord {
  float4 c1234;
  float4 c56rg;
  float4 bd;
};
template <>
struct PairRecord<true, false> {
  float4 c1234;
  float4 c56rg;
};
/// A record that never passes: P = −1e30 at every pixel (no infinities, so 0·x stays 0), below exp̂'s
/// 1/255 pattern, expf's and half2_alpha's (2^v = 0). The loop pads its pair lists with it to a multiple of
/// kUnroll.
constexpr float kNeverPasses = -1e30f;
/// Pairs per step of the folded loop: the pixels' liveness is tested once per step (a done pixel is left
/// unchanged by blend_predicated, so testing less often changes no bit) and the loads of the step overlap;
/// with binary16 blending a step is a colour window.
constexpr int kUnroll = kColourWindowEntries;

/// The record at `address`, an address of the block's shared-memory window (__cvta_generic_to_shared), loaded
/// 16 bytes at a time by ld.shared straight from that register: the walk lists hold such addresses, so a listed
/// pair costs no address arithmetic.
template <typename Record>
__device__ inline Record load_record(uint32_t address) {
  Record r;
  asm volatile("ld.shared.v4.f32 {%0, %1, %2, %3}, [%8];\n\tld.shared.v4.f32 {%4, %5, %6, %7}, [%8+16];"
               : "=f"(r.c1234.x), "=f"(r.c1234.y), "=f"(r.c1234.z), "=f"(r.c1234.w), "=f"(r.c56rg.x), "=f"(r.c56rg.y),
                 "=f"(r.c56rg.z), "=f"(r.c56rg.w)
               : "r"(address)
               : "memory");
  if constexpr (sizeof(Record) > 32) {
    asm volatile("ld.shared.v4.f32 {%0, %1, %2, %3}, [%4+32];"
                 : "=f"(r.bd.x), "=f"(r.bd.y), "=f"(r.bd.z), "=f"(r.bd.w)
                 : "r"(address)
                 : "memory");
  }
  return r;
}

/// Stores `value` at `address` of the block's shared-memory window (st.shared from that register) where `store`
/// holds: one predicated store, no branch.
__device__ inline void store_shared_u16_if(bool store, uint32_t address, uint16_t value) {
  asm volatile(
      "{\n\t.reg .pred p;\n\tsetp.ne.u32 p, %0, 0;\n\t@p st.shared.u16 [%1], %2;\n\t}" ::"r"(uint32_t(store)),
      "r"(address), "h"(value)
      : "memory");
}

/// `value` as the compiler cannot recompute it: a shared-window address computed once a batch, which it would
/// otherwise rebuild from the CTA's id at every use (five instructions) when registers run short.
__device__ inline uint32_t opaque(uint32_t value) {
  uint32_t result;
  asm volatile("mov.b32 %0, %1;" : "=r"(result) : "r"(value));
  return result;
}

/// Blends the records at shared addresses address_of(0), …, address_of(padded − 1) (padded: a
/// multiple of kUnroll) into the thread's two pixels, testing their liveness once per kUnroll pairs.
template <bool kFastExp, bool kDepth, typename AddressOf>
__device__ inline void blend_pairs(int padded, AddressOf address_of, const PixelTerms& terms, float fast_exp_bias,
                                   FoldedPixel& first, FoldedPixel& second) {
  using Record = PairRecord<false, kDepth>;
  for (int k = 0; k < padded; k += kUnroll) {
    if (!first.live() && !second.live()) break;
#pragma unroll
    for (int i = 0; i < kUnroll; ++i) {
      const Record r = load_record<Record>(address_of(k + i));
      const float4 c1234 = r.c1234, c56rg = r.c56rg;
      const FoldedCoefficients f{c1234.x, c1234.y, c1234.z, c1234.w, c56rg.x, c56rg.y};
      const float p_first = folded_power(f, terms);
      const float p_second = dual_pixel_power(p_first, f, terms);
      float a_first, a_second;
      const bool hit_first = folded_alpha<kFastExp>(p_first, fast_exp_bias, &a_first);
      const bool hit_second = folded_alpha<kFastExp>(p_second, fast_exp_bias, &a_second);
      const float4 bd = r.bd;
      blend_predicated<kDepth>(first, hit_first ? a_first : 0.f, c56rg.z, c56rg.w, bd.x, bd.y);
      blend_predicated<kDepth>(second, hit_second ? a_second : 0.f, c56rg.z, c56rg.w, bd.x, bd.y);
    }
  }
}

/// The two pixels of a folded-loop thread under half-precision blending (half_blend.h): T and the colour
/// window as binary16 pairs, the closed windows' colour and the depth sums (kDepth) in FP32.
struct HalfFoldedPixels {
  HalfPixelPair s;
  float depth_sum[2] = {0.f, 0.f}, weight_sum[2] = {0.f, 0.f};

  __device__ bool live() const { return half_pair_live(s); }
  /// Pixel i (0: (x, y), 1: (x, y + 1)) in the pixel kernel's form, for store().
  __device__ Pixel finished(int i) const {
    const auto lane = [i](Half2Bits h) { return half_to_float(static_cast<uint16_t>(h >> (16 * i))); };
    Pixel p;
    p.T = fabsf(lane(s.T));
    for (int c = 0; c < 3; ++c) p.C[c] = half_pixel_colour(s, i, c);
    p.depth_sum = depth_sum[i], p.weight_sum = weight_sum[i];
    return p;
  }
};

/// blend_pairs with half-precision blending: the same walk, the records' coefficients those of the power in
/// base 2 (exp2_coefficients), α from half2_alpha and one blend_half2 for both pixels; each step of kUnroll
/// pairs is a colour window (half_blend.h), closed at its end.
template <bool kDepth, typename AddressOf>
__device__ inline void blend_pairs_half(int padded, AddressOf address_of, const PixelTerms& terms,
                                        HalfFoldedPixels& pixels) {
  using Record = PairRecord<true, kDepth>;
  for (int k = 0; k < padded; k += kUnroll) {
    if (!pixels.live()) break;
#pragma unroll
    for (int i = 0; i < kUnroll; ++i) {
      const Record r = load_record<Record>(address_of(k + i));
      const float4 c1234 = r.c1234, c56rg = r.c56rg;
      const FoldedCoefficients f{c1234.x, c1234.y, c1234.z, c1234.w, c56rg.x, c56rg.y};  // of v
      const float v_first = folded_power(f, terms);
      const float v_second = dual_pixel_power(v_first, f, terms);
      const Half2Bits alpha = half2_alpha(v_first, v_second);
      const Half2Bits rg = float_as_uint(c56rg.z), b = float_as_uint(c56rg.w);
      const Half2Bits w = blend_half2(pixels.s, alpha, half2_low(rg), half2_high(rg), half2_low(b));
      if constexpr (kDepth) {
        const float depth = r.bd.x;
        for (int p = 0; p < 2; ++p) {
          const float wp = half_to_float(static_cast<uint16_t>(w >> (16 * p)));
          pixels.depth_sum[p] = fmaf(depth, wp, pixels.depth_sum[p]);
          pixels.weight_sum[p] += wp;
        }
      }
    }
    close_colour_window(pixels.s);
  }
}

/// A chunk record's word `word` of thread `rank` in slot `slot` (TileChunks::records: [slot, word, thread]).
template <bool kDepth>
__device__ inline uint32_t* chunk_word(const TileChunks& chunks, uint32_t slot, int word, int rank) {
  constexpr uint32_t kWords = kDepth ? 11 : 7;  // tile_chunk_record_words
  return chunks.records + (uint64_t(slot) * kWords + uint32_t(word)) * kDualThreads + uint32_t(rank);
}

/// A chunk block's end. Stores this thread's two pixels in the chunk's record slot (T as binary16 pairs, the sign of T
/// the stop flag; the colours in FP32; kDepth: the depth sums) and counts the block as arrived; the tile's last chunk
/// block to arrive then merges the tile's records in chunk order (merge_chunk, as the CPU reference's
/// blend_tile_folded_half) and stores the pixels. The threadfence pattern: every block fences its stores before its
/// arrival is counted, and the merging block reads the records past L1.
template <bool kDepth>
__device__ inline void finish_chunk(const TileChunks& chunks, uint32_t tile, uint32_t chunk, uint32_t tile_chunks,
                                    const HalfFoldedPixels& pixels, uint32_t x, uint32_t y, const FrameParams& frame,
                                    float4* out_rgba, float* out_depth) {
  __shared__ bool last;
  const int rank = int(threadIdx.x);
  const uint32_t first_slot = chunks.first_item[tile];
  *chunk_word<kDepth>(chunks, first_slot + chunk, 0, rank) = pixels.s.T;
  for (int p = 0; p < 2; ++p) {
    for (int c = 0; c < 3; ++c) {
      *chunk_word<kDepth>(chunks, first_slot + chunk, 1 + 3 * p + c, rank) =
          __float_as_uint(half_pixel_colour(pixels.s, p, c));
    }
  }
  if (kDepth) {
    for (int p = 0; p < 2; ++p) {
      *chunk_word<kDepth>(chunks, first_slot + chunk, 7 + p, rank) = __float_as_uint(pixels.depth_sum[p]);
      *chunk_word<kDepth>(chunks, first_slot + chunk, 9 + p, rank) = __float_as_uint(pixels.weight_sum[p]);
    }
  }
  __threadfence();
  __syncthreads();
  if (rank == 0) last = atomicAdd(chunks.arrivals + tile, 1u) == tile_chunks - 1;
  __syncthreads();
  if (!last) return;
  __threadfence();
  ChunkPixel merged[2];
  for (uint32_t c = 0; c < tile_chunks; ++c) {
    const uint32_t slot = first_slot + c;
    HalfPixelPair record;  // the window sums +0: the colours are the record's
    record.T = __ldcg(chunk_word<kDepth>(chunks, slot, 0, rank));
    for (int p = 0; p < 2; ++p) {
      for (int c = 0; c < 3; ++c) {
        record.C[p][c] = __uint_as_float(__ldcg(chunk_word<kDepth>(chunks, slot, 1 + 3 * p + c, rank)));
      }
    }
    for (int p = 0; p < 2; ++p) {
      float depth_sum = 0.f, weight_sum = 0.f;
      if (kDepth) {
        depth_sum = __uint_as_float(__ldcg(chunk_word<kDepth>(chunks, slot, 7 + p, rank)));
        weight_sum = __uint_as_float(__ldcg(chunk_word<kDepth>(chunks, slot, 9 + p, rank)));
      }
      merge_chunk(merged[p], chunk_pixel_of_half(record, p, depth_sum, weight_sum));
    }
  }
  for (int p = 0; p < 2; ++p) {
    if (!(x < frame.width && y + uint32_t(p) < frame.height)) continue;
    Pixel s;
    s.T = merged[p].T;
    for (int k = 0; k < 3; ++k) s.C[k] = merged[p].C[k];
    s.depth_sum = merged[p].depth_sum, s.weight_sum = merged[p].weight_sum;
    store<kDepth>(s, x, y + uint32_t(p), frame, out_rgba, out_depth);
  }
}

/// Which pairs each lane of the folded rasterizer walks.
enum class Cull {
  kNone,   ///< every pair of the tile
  kBlock,  ///< the pairs whose block_mask holds the lane group's 4×4 block
};

/// Lanes per group of the folded rasterizer: 8 lanes shade a 4×4 block, two vertically adjacent pixels each.
constexpr int kGroupLanes = kCullBlockSize * kCullBlockSize / 2;
constexpr int kGroupsPerWarp = 32 / kGroupLanes;

/// Pair `p` of a batch as the folded kernel's shared record: the coefficients folded at the tile's origin
/// (origin_x, origin_y), in base 2 with kHalf, the colour (binary16 pairs with kHalf) and the depth; with kCulls
/// its block_mask in *mask (0 otherwise). Past the batch's end (p ≥ end): `never` and mask 0.
template <bool kHalf, bool kDepth, bool kCulls>
__device__ __forceinline__ PairRecord<kHalf, kDepth> load_folded_record(const RenderInputs& in,
                                                                        const uint32_t* __restrict__ values,
                                                                        uint64_t p, uint64_t end, float origin_x,
                                                                        float origin_y,
                                                                        const PairRecord<kHalf, kDepth>& never,
                                                                        uint32_t* mask) {
  PairRecord<kHalf, kDepth> record = never;
  if (p < end) {
    const uint32_t id = values[p];
    const float2 mean = in.means2d[id];
    const float4 co = in.conic_opacity[id];
    const Conic conic{co.x, co.y, co.z};
    const float4 colour = in.colour_log_opacity[id];
    const float u = mean.x - origin_x, v = mean.y - origin_y, log_opacity = colour.w;
    FoldedCoefficients f = fold_coefficients(conic, u, v, log_opacity);
    if (kHalf) f = exp2_coefficients(f);
    record.c1234 = make_float4(f.c1, f.c2, f.c3, f.c4);
    if constexpr (kHalf) {  // the colour as binary16 pairs for blend_half2
      record.c56rg = make_float4(f.c5, f.c6, uint_as_float(half2_pack(colour.x, colour.y)),
                                 uint_as_float(half2_pack(colour.z, 0.f)));
      if constexpr (kDepth) record.bd = make_float4(in.depths[id], 0.f, 0.f, 0.f);
    } else {
      record.c56rg = make_float4(f.c5, f.c6, colour.x, colour.y);
      record.bd = make_float4(colour.z, kDepth ? in.depths[id] : 0.f, 0.f, 0.f);
    }
    if (kCulls) *mask = block_mask(conic, u, v, log_opacity);
  }
  return record;
}

/// The walk lists of one batch of `in_batch` pairs for the lists of warp `warp` (its lane groups' with block
/// culling, the warp's own otherwise), built from the pairs' masks (collected_mask) into walk_lists; this lane
/// walks list `list`. @return the length of this lane's list; *keeps_all becomes false (warp-uniform) unless
/// every list of the warp holds the whole batch.
template <Cull kCull, int kListsPerWarp, int kListStride, int kRecordBytes, int kBatch>
__device__ __forceinline__ int list_kept_pairs(uint16_t (*walk_lists)[kListStride], const uint32_t* collected_mask,
                                               uint32_t records_address, int in_batch, int warp, int lane, int list,
                                               bool* keeps_all) {
  const int group = lane / kGroupLanes, in_group = lane % kGroupLanes;
  const uint32_t lanes_below = (1u << lane) - 1u;
  // Each list of this warp in batch order: slot s is kept when the list's bit of its mask is set. A lane that
  // keeps its slot stores it at the list's cursor (the shared address of its next entry) plus its rank among
  // the kept lanes, by a predicated store: no branch a list, and no two lanes store to one address.
  const uint32_t lists_address =
      opaque(static_cast<uint32_t>(__cvta_generic_to_shared(walk_lists[warp * kListsPerWarp])));
  constexpr uint32_t kListBytes = kListStride * sizeof(uint16_t);
  uint32_t cursors[kListsPerWarp];
#pragma unroll
  for (int g = 0; g < kListsPerWarp; ++g) cursors[g] = lists_address + uint32_t(g) * kListBytes;
  for (int base = 0; base < in_batch; base += 32) {
    const uint32_t slot_mask = collected_mask[base + lane];
    const auto entry = uint16_t(records_address + uint32_t((base + lane) * kRecordBytes));
#pragma unroll
    for (int g = 0; g < kListsPerWarp; ++g) {
      // Block culling: group g's block (block_x, block_y) as bit block_x + 4·block_y; else the quadrant.
      const int bit = kCull == Cull::kBlock
                          ? (2 * (warp % 2) + g % 2) + kCullBlocksPerSide * (2 * (warp / 2) + g / 2)
                          : warp;
      const bool keep = (slot_mask >> bit) & 1u;
      const uint32_t kept = __ballot_sync(0xffffffffu, keep);
      store_shared_u16_if(keep, cursors[g] + 2u * __popc(kept & lanes_below), entry);
      cursors[g] += 2u * __popc(kept);
    }
  }
  int counts[kListsPerWarp];
#pragma unroll
  for (int g = 0; g < kListsPerWarp; ++g) {
    counts[g] = int((cursors[g] - lists_address - uint32_t(g) * kListBytes) / 2u);
  }
  int count = counts[0];
#pragma unroll
  for (int g = 0; g < kListsPerWarp; ++g) {
    if (group == g) count = counts[g];
    *keeps_all = *keeps_all && counts[g] == in_batch;
  }
  // The lanes 0..kUnroll − 1 of the list's first group pad it with the never-passing record.
  const bool pads = kCull == Cull::kBlock || group == 0;
  if (pads && in_group < kUnroll && count % kUnroll != 0 && in_group >= count % kUnroll) {
    walk_lists[list][count - count % kUnroll + in_group] = uint16_t(records_address + kBatch * kRecordBytes);
  }
  __syncwarp();
  return count;
}

/// RoofGS rasterizer: coefficients folded per Gaussian at the shared-memory load, in tile-local coordinates; pixel
/// terms hoisted; each thread shades (x, y) and (x, y + 1) with P(x, y + 1) = P(x, y) + C2·x + C3·(2y + 1) + C5; alpha
/// tested in the integer domain (fast_exp_alpha_passes); blending without branches (blend_predicated). 128 threads per
/// tile: warp w shades the 8×8 quadrant (w mod 2, w / 2), its lane group g = l / 8 the 4×4 block (g mod 2, g / 2) of
/// that quadrant, lane l the pixels (i mod 4, 2·(i / 4)) of the block (i = l mod 8) and the ones below. Culling (beyond
/// the paper): the thread that loads a pair also computes its block_mask, and each lane group walks only the pairs
/// whose mask holds its pixels, listed in batch order with ballots; the other pairs cannot pass the 1/255 test there,
/// so the output bits are the same (up to the caveat of subtile_mask; with kHalf the colour windows follow the lists).
/// A warp whose lists keep every pair of a batch walks the slots directly. Lane groups of one warp walk lists of
/// different lengths: the warp takes as many steps as the longest, each step serving up to four pairs, one per group.
/// Eight blocks an SM (64 registers): the block-culled kernel needs no more (block_mask without square roots), and the
/// unculled one runs faster with them than with the 40 ptxas picks by itself (docs/lab/TRIED.md#tried-and-not-kept).
/// Long tiles (kHalf with TileChunks, beyond the paper): a chunk block blends its chunk of the tile's list from T = 1
/// and finish_chunk merges the tile's chunks; the grid has TileChunks::item_rows rows of such blocks first. kHalf
/// (RasterOptions::half_blend, beyond the paper): a thread's two pixels keep α, T and the colour window as binary16
/// pairs and one half2 instruction blends both (blend_pairs_half), each step closing its colour window into FP32
/// (docs/RENDERER.md#colour-windows). Nine blocks an SM (56 registers) were no faster with it, ten (48) slower
/// (docs/lab/TRIED.md#tried-and-not-kept).
template <bool kFastExp, bool kDepth, Cull kCull, bool kHalf>
__global__ void __launch_bounds__(kDualThreads, 8)
    render_folded_kernel(const uint64_t* __restrict__ ranges, const uint32_t* __restrict__ values, RenderInputs in,
                         TileChunks chunks, FrameParams frame, float sigma, float4* __restrict__ out_rgba,
                         float* __restrict__ out_depth) {
  constexpr int kWarps = kDualThreads / 32;
  constexpr int kListsPerWarp = kCull == Cull::kBlock ? kGroupsPerWarp : 1;
  constexpr bool kCulls = kCull != Cull::kNone;
  // Pairs per batch: with block culling two for each thread to load, since a block waits at a barrier for its
  // slowest lane group once per batch and the groups' lists of different lengths even out over more pairs
  // (batches of 128, 384 and 512 measured: docs/lab/TRIED.md#tried-and-not-kept).
  constexpr int kBatch = static_cast<int>(walk_batch_pairs(kCull == Cull::kBlock));  // the colour windows' batches
  static_assert(kBatch % kDualThreads == 0);
  constexpr int kLoads = kBatch / kDualThreads;
  // Entries per walk list: a batch's slots plus 2, so that the 4 lists a warp reads at once start in 4
  // different banks (an odd stride in words).
  constexpr int kListStride = kBatch + 2;
  // This block's tile and pairs [begin, end): with chunks, the first item_rows rows of blocks take the listed
  // chunks of the long tiles in row-major order (those past the list's end return at once), the rest one tile
  // each of the pass's rows, (x, tile_row_begin + y − item_rows), which leaves a listed tile to its chunks.
  const bool chunk_block = blockIdx.y < chunks.item_rows;
  uint32_t tile_x = blockIdx.x, tile_y = frame.tile_row_begin + blockIdx.y - chunks.item_rows, chunk = 0;
  if (chunk_block) {
    const uint32_t index = blockIdx.y * frame.tiles_x + blockIdx.x;
    if (index >= *chunks.item_count) return;
    const uint2 item = chunks.items[index];
    tile_x = item.x % frame.tiles_x, tile_y = item.x / frame.tiles_x, chunk = item.y;
  }
  const uint32_t tile = tile_y * frame.tiles_x + tile_x;
  uint64_t begin = ranges[2 * uint64_t(tile)], end = ranges[2 * uint64_t(tile) + 1];
  const uint32_t tile_chunks = tile_chunk_count(end - begin, chunks.chunk_pairs);  // 1 without chunks
  if (tile_chunks > 1) {
    if (!chunk_block) return;  // the row-major block of a listed tile
    begin += uint64_t(chunk) * chunks.chunk_pairs;
    if (end - begin > chunks.chunk_pairs) end = begin + chunks.chunk_pairs;
  }
  const int rank = int(threadIdx.x), warp = rank / 32, lane = rank % 32;
  const int group = lane / kGroupLanes, in_group = lane % kGroupLanes;
  const int block_x = 2 * (warp % 2) + group % 2, block_y = 2 * (warp / 2) + group / 2;
  const int lx = block_x * kCullBlockSize + in_group % kCullBlockSize;
  const int ly = block_y * kCullBlockSize + 2 * (in_group / kCullBlockSize);
  const uint32_t x = tile_x * kTileSize + uint32_t(lx);
  const uint32_t y = tile_y * kTileSize + uint32_t(ly);
  const float origin_x = static_cast<float>(tile_x * kTileSize);
  const float origin_y = static_cast<float>(tile_y * kTileSize);
  const PixelTerms terms = pixel_terms(static_cast<float>(lx), static_cast<float>(ly));
  const float fast_exp_bias = kFastExp && !kHalf ? rgs::kernels::fast_exp_bias(sigma) : 0.f;

  // Slot s < kBatch holds the batch's pair s; slot kBatch is the padding record.
  using Record = PairRecord<kHalf, kDepth>;
  constexpr int kRecordBytes = static_cast<int>(sizeof(Record));
  __shared__ Record records[kBatch + 1];
  __shared__ uint32_t collected_mask[kCulls ? kBatch : 1];
  // Shared addresses of the slots each list walks, in batch order, padded to a multiple of kUnroll.
  __shared__ uint16_t walk_lists[kCulls ? kWarps * kListsPerWarp : 1][kListStride];
  Record never{};
  never.c56rg.y = kNeverPasses;
  if (rank == 0) records[kBatch] = never;  // visible after the first barrier below
  // The records' shared-window address: the whole block's static shared memory lies below 2^16 bytes (with the
  // window's reserved first kilobyte), so a slot's address fits the lists' 16 bits. On sm_90 the address also
  // carries the block's rank in its cluster from bit 24 on, 0 here: the kernel is never launched in clusters.
  static_assert(sizeof(records) + sizeof(collected_mask) + sizeof(walk_lists) + 1024 < 65536);
  const auto records_address = static_cast<uint32_t>(__cvta_generic_to_shared(records));
  // The list this lane walks: its group's (block culling) or its warp's.
  const int list = kCull == Cull::kBlock ? warp * kGroupsPerWarp + group : warp;

  FoldedPixel first, second;
  HalfFoldedPixels pair;
  if (!(x < frame.width && y < frame.height)) {  // outside the image: done from the start
    first.T = -1.f;
    pair.s.T |= 0x8000u;
  }
  if (!(x < frame.width && y + 1 < frame.height)) {
    second.T = -1.f;
    pair.s.T |= 0x80000000u;
  }
  for (uint64_t batch = begin; batch < end; batch += kBatch) {
    const bool live = kHalf ? pair.live() : first.live() || second.live();
    if (__syncthreads_count(!live) == kDualThreads) break;
    // One pair at a time: the two loads' gathers, folds and masks unrolled held more registers at once than
    // the walk needs (docs/lab/TRIED.md#tried-and-not-kept).
#pragma unroll 1
    for (int l = 0; l < kLoads; ++l) {
      const int slot = rank + l * kDualThreads;
      const uint64_t p = batch + uint64_t(slot);
      uint32_t mask = 0;
      const Record record = load_folded_record<kHalf, kDepth, kCulls>(in, values, p, end, origin_x, origin_y, never,
                                                                       &mask);
      records[slot] = record;  // slots past the batch's end get the padding record
      if (kCulls) collected_mask[slot] = mask;
    }
    __syncthreads();
    const int in_batch = static_cast<int>(end - batch < kBatch ? end - batch : kBatch);
    int count = in_batch;
    bool keeps_all = true;  // warp-uniform: every list of the warp holds the whole batch
    if (kCulls) {
      count = list_kept_pairs<kCull, kListsPerWarp, kListStride, kRecordBytes, kBatch>(
          walk_lists, collected_mask, records_address, in_batch, warp, lane, list, &keeps_all);
    }
    const int padded = (count + kUnroll - 1) / kUnroll * kUnroll;  // ≤ kBatch
    const uint16_t* addresses = walk_lists[kCulls ? list : 0];
    const auto in_order = [records_address](int k) { return records_address + uint32_t(k * kRecordBytes); };
    const auto listed = [addresses](int k) { return uint32_t(addresses[k]); };
    if (kHalf) {
      if (!kCulls || keeps_all) {  // warp-uniform
        blend_pairs_half<kDepth>(padded, in_order, terms, pair);
      } else {
        blend_pairs_half<kDepth>(padded, listed, terms, pair);
      }
    } else if (!kCulls || keeps_all) {
      blend_pairs<kFastExp, kDepth>(padded, in_order, terms, fast_exp_bias, first, second);
    } else {
      blend_pairs<kFastExp, kDepth>(padded, listed, terms, fast_exp_bias, first, second);
    }
  }
  if constexpr (kHalf) {
    if (tile_chunks > 1) {
      finish_chunk<kDepth>(chunks, tile, chunk, tile_chunks, pair, x, y, frame, out_rgba, out_depth);
      return;
    }
  }
  if (x < frame.width && y < frame.height) {
    store<kDepth>(kHalf ? pair.finished(0) : first.finished(), x, y, frame, out_rgba, out_depth);
  }
  if (x < frame.width && y + 1 < frame.height) {
    store<kDepth>(kHalf ? pair.finished(1) : second.finished(), x, y + 1, frame, out_rgba, out_depth);
  }
}

template <bool kRoofgs, bool kFastExp>
void launch_pixel(const uint64_t* ranges, const uint32_t* values, const RenderInputs& in, const FrameParams& frame,
                  float sigma, const ImageView& image, cudaStream_t stream) {
  const dim3 grid(frame.tiles_x, frame.tile_row_end - frame.tile_row_begin), block(kTileSize, kTileSize);
  auto* rgba = reinterpret_cast<float4*>(image.rgba);
  if (image.depth != nullptr) {
    render_pixel_kernel<kRoofgs, kFastExp, true>
        <<<grid, block, 0, stream>>>(ranges, values, in, frame, sigma, rgba, image.depth);
  } else {
    render_pixel_kernel<kRoofgs, kFastExp, false>
        <<<grid, block, 0, stream>>>(ranges, values, in, frame, sigma, rgba, nullptr);
  }
}

/// Where the folded kernel finds its tiles and pairs: the ranges, the long tiles' chunks and the sorted values.
struct FoldedLists {
  const uint64_t* ranges;
  TileChunks chunks;
  const uint32_t* values;
};

template <bool kFastExp, Cull kCull, bool kHalf>
void launch_folded(const FoldedLists& lists, const RenderInputs& in, const FrameParams& frame, float sigma,
                   const ImageView& image, cudaStream_t stream) {
  // One block per tile of the pass's rows, and with chunks item_rows rows of blocks before them for the listed
  // chunks.
  const dim3 grid(frame.tiles_x, frame.tile_row_end - frame.tile_row_begin + lists.chunks.item_rows),
      block(kDualThreads);
  auto* rgba = reinterpret_cast<float4*>(image.rgba);
  if (image.depth != nullptr) {
    render_folded_kernel<kFastExp, true, kCull, kHalf>
        <<<grid, block, 0, stream>>>(lists.ranges, lists.values, in, lists.chunks, frame, sigma, rgba, image.depth);
  } else {
    render_folded_kernel<kFastExp, false, kCull, kHalf>
        <<<grid, block, 0, stream>>>(lists.ranges, lists.values, in, lists.chunks, frame, sigma, rgba, nullptr);
  }
}

}  // namespace
}  // namespace rgs::kernels
