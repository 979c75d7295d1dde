// Long tiles blended in chunks (beyond the paper; runtime::RoofgsOptions::tile_chunk_pairs): the rule that the
// CPU reference and the GPU rasterizer share.
//
// A tile whose sorted list holds more than K pairs is blended as ⌈n / K⌉ chunks of K consecutive pairs of that
// list (the last one shorter), K = frame_chunk_pairs: the preset's chunk size, or more in a frame of so many
// pairs that tiles of that size are not what holds the render up. Each chunk is blended front to back from
// T = 1 with the per-pixel rules (skip α < 1/255, stop before the pair that would make T < 1e−4); then the
// chunks are merged front to back in list order (merge_chunk). On the GPU each chunk is a thread block, so a
// tile of thousands of pairs no longer holds one block busy long after the rest of the frame's work is done
// (taebak's horizon tiles at 1080p: docs/RENDERER.md#the-cuda-renderer, "Long tiles in chunks").
//
// A pixel that stopped in a chunk takes nothing from the later ones, so a pixel that stops in the first chunk
// keeps the unchunked blend's bits. Elsewhere the result differs from it by rounding, and by what a pixel takes
// where the unchunked blend stopped: the pair it stopped before (T·(1 − α) < 1e−4), which a later chunk, whose
// own T starts at 1, may take with weight α·T < α·1e−4/(1 − α), at most 0.0102 at the binary16 α clamp
// 0.990234 (a colour c adds c times that, and 3DGS colours are clamped below at 0 only); after it the
// transmittance over the chunks is below 1e−4, so everything later weighs less than 1e−4 in all.
#pragma once

#include "rgs/kernels/shared/half_blend.h"
#include "rgs/kernels/shared/host_device.h"

namespace rgs::kernels {

/// Pairs a chunk of the fastest preset holds at least: a small part of a 1080p frame's work for one block, so
/// that a late long tile ends soon after the rest of the frame. Frames of more than 1024 · kTileChunksPerFrame
/// pairs (taebak at every size) take a larger K (frame_chunk_pairs). Other minimums measured:
/// docs/lab/TRIED.md#tried-and-not-kept.
constexpr uint32_t kTileChunkPairs = 1024;

/// A frame's chunks hold at least 1/kTileChunksPerFrame of its pairs. A chunk block that starts from T = 1
/// cannot stop where the chunks before it made the pixels opaque, so chunks cost work on tiles that are long
/// but not late; this keeps them to the tiles that are long against the frame (taebak at 8K: none).
constexpr uint64_t kTileChunksPerFrame = 2048;

/// Gaussians with more tiles than this are large: the sub-tile culling's measure (kernels::kSubtileLargeTiles).
constexpr uint32_t kChunkLargeTiles = 32;

/// The chunk size K of a frame of `frame_pairs` pairs, `large_pairs` of them from Gaussians with more than
/// kChunkLargeTiles tiles: max(tile_chunk_pairs, ⌈frame_pairs / kTileChunksPerFrame⌉); 0 (off) when
/// tile_chunk_pairs is 0 or large Gaussians hold more than half of the pairs. Their tiles go opaque within
/// their first chunk, and every later chunk, which starts from T = 1, would blend until it goes opaque too
/// (flowers ×53: docs/lab/TRIED.md#tried-and-not-kept). Depends on the frame's content only, so the
/// CPU reference and the GPU chunk alike.
RGS_HOST_DEVICE uint32_t frame_chunk_pairs(uint64_t frame_pairs, uint64_t large_pairs, uint32_t tile_chunk_pairs) {
  if (tile_chunk_pairs == 0 || large_pairs > frame_pairs / 2) return 0;
  const uint64_t share = frame_pairs / kTileChunksPerFrame + (frame_pairs % kTileChunksPerFrame != 0);
  if (share <= tile_chunk_pairs) return tile_chunk_pairs;
  return share > 0xffffffffu ? 0xffffffffu : static_cast<uint32_t>(share);
}

/// Chunks of a tile of `pairs` pairs: 1 when chunk_pairs is 0 (chunking off) or pairs ≤ chunk_pairs, else
/// ⌈pairs / chunk_pairs⌉.
RGS_HOST_DEVICE uint32_t tile_chunk_count(uint64_t pairs, uint32_t chunk_pairs) {
  if (chunk_pairs == 0 || pairs <= chunk_pairs) return 1;
  return static_cast<uint32_t>((pairs + chunk_pairs - 1) / chunk_pairs);
}

/// A pixel's blend over one chunk, or over the chunks merged so far: colour sum C (linear RGB), transmittance
/// T, the depth sums Σ w·z and Σ w, and whether the stop rule ended it.
struct ChunkPixel {
  float C[3] = {0.f, 0.f, 0.f};
  float T = 1.f;
  float depth_sum = 0.f, weight_sum = 0.f;
  bool done = false;
};

/// Pixel `lane` (0: (x, y), 1: (x, y + 1)) of a thread's chunk blended in binary16 (half_blend.h): T as
/// HalfPixelPair holds it (the sign the stop flag), its colour (half_pixel_colour), and its FP32 depth sums.
RGS_HOST_DEVICE ChunkPixel chunk_pixel_of_half(const HalfPixelPair& s, int lane, float depth_sum, float weight_sum) {
  const uint16_t T = static_cast<uint16_t>(s.T >> (16 * lane));
  ChunkPixel p;
  for (int c = 0; c < 3; ++c) p.C[c] = half_pixel_colour(s, lane, c);
  p.T = fabsf(half_to_float(T));
  p.depth_sum = depth_sum, p.weight_sum = weight_sum;
  p.done = (T & 0x8000u) != 0;
  return p;
}

/// Appends `next`, a chunk blended from T = 1, behind `acc` (the "over" operator): C += T·C′, the depth sums
/// likewise, T ·= T′, one rounding each (fmaf); a done `acc` takes nothing. Merging a first chunk into a
/// default ChunkPixel gives that chunk's values exactly.
RGS_HOST_DEVICE void merge_chunk(ChunkPixel& acc, const ChunkPixel& next) {
  if (acc.done) return;
  for (int c = 0; c < 3; ++c) acc.C[c] = fmaf(acc.T, next.C[c], acc.C[c]);
  acc.depth_sum = fmaf(acc.T, next.depth_sum, acc.depth_sum);
  acc.weight_sum = fmaf(acc.T, next.weight_sum, acc.weight_sum);
  acc.T = acc.T * next.T;
  acc.done = next.done;
}

}  // namespace rgs::kernels
