// Exact depth order after the 32-bit pair sort (order_equal_keys_by_depth, RoofGS+, beyond the paper): pairs
// whose keys tie (same tile, same depth bin) come out of the stable sort in emission order, i.e. by Gaussian
// index; this pass puts each such run in (view depth, index) order, which is the order of the baseline's
// 64-bit key. It reads the sorted keys anyway, so it also writes the tile ranges (tile_ranges' job).
#include "launch_util.cuh"
#include "rgs/kernels/roofgs_pipeline.h"
#include "tile_ranges.cuh"

namespace rgs::kernels {
namespace {

/// Thread p moves pair p and records the range boundaries at p. A pair alone in its key goes straight
/// through; a pair in a run [a, b) of equal keys goes to a + its rank in the run under (depth, index). A run that
/// lies within the warp's 32 pairs is ranked with shuffles, each lane holding one pair's depth and index (one
/// gather a pair); a run that crosses the warp's ends is ranked by its own pairs over global memory (O(run
/// length) reads per pair, as the render's own loop over the tile's pairs). Real scenes tie in short runs, yet
/// on taebak at 4K 95 % of the warps hold one and 45 % one that crosses their ends. The pass is bound by its
/// instructions there (Nsight Compute), so Index is uint32_t whenever the positions fit (64-bit positions are
/// slower: docs/lab/TRIED.md#tried-and-not-kept).
template <typename Index>
__global__ void __launch_bounds__(detail::kBlockSize)
    order_equal_keys_kernel(const uint32_t* __restrict__ keys, const uint32_t* __restrict__ values_in,
                            const float* __restrict__ depths, Index count, int tile_shift,
                            uint32_t* __restrict__ values_out, uint64_t* __restrict__ ranges) {
  const Index p = Index(blockIdx.x) * Index(blockDim.x) + Index(threadIdx.x);
  const int lane = int(threadIdx.x % 32);
  // Whole warps stay for the shuffles; lanes past the end take part as untied pairs.
  const bool valid = p < count;
  const uint32_t key = valid ? keys[p] : 0u;
  const uint32_t g = valid ? values_in[p] : 0u;
  const uint32_t previous_key = valid && p > 0 ? keys[p - 1] : 0u;
  // Tile ranges, as tile_ranges_kernel (the shift is done in 64 bits: a single-tile key has 32 depth bits).
  if (valid) {
    detail::record_tile_range(ranges, p, count, uint64_t(key) >> tile_shift, uint64_t(previous_key) >> tile_shift);
  }
  const bool tied_before = valid && p > 0 && previous_key == key;
  const bool tied_after = valid && p + 1 < count && keys[p + 1] == key;
  const bool tied = tied_before || tied_after;
  const uint32_t tied_lanes = __ballot_sync(0xffffffffu, tied);
  if (tied_lanes == 0) {
    if (valid) values_out[p] = g;
    return;
  }
  // Run boundaries inside the warp: lane l starts a run unless it ties with lane l − 1; the run of lane l spans
  // lanes [start, end). A run reaching lane 0 while tied before, or lane 31 while tied after, crosses the warp.
  const uint32_t starts = __ballot_sync(0xffffffffu, !tied_before);
  const uint32_t below_or_self = (2u << lane) - 1u;  // lanes 0..lane
  const int start = 31 - __clz(int(starts & below_or_self));  // lane 0 counts as a start if it is one
  const uint32_t starts_above = starts & ~below_or_self;
  const int end = starts_above != 0 ? __ffs(int(starts_above)) - 1 : 32;
  const bool last_tied_after = __shfl_sync(0xffffffffu, tied_after, 31);
  const bool crosses = ((starts & below_or_self) == 0) || (end == 32 && last_tied_after);
  const float depth = tied ? depths[g] : 0.f;
  // Each lane compares its pair with the pairs of its run, one run position per step, for as many steps as the
  // warp's longest run inside it (every lane takes part in every shuffle).
  const int run_length = tied && !crosses ? end - start : 0;
  const int steps = int(__reduce_max_sync(0xffffffffu, uint32_t(run_length)));
  uint32_t rank = 0;
  for (int d = 0; d < steps; ++d) {
    const int source = (start + d) & 31;
    const float other_depth = __shfl_sync(0xffffffffu, depth, source);
    const uint32_t other = __shfl_sync(0xffffffffu, g, source);
    rank += (d < run_length && (other_depth < depth || (other_depth == depth && other < g))) ? 1u : 0u;
  }
  if (!valid) return;
  if (!tied) {
    values_out[p] = g;
    return;
  }
  const Index warp_first = p - Index(lane);
  if (!crosses) {
    values_out[warp_first + Index(start) + rank] = g;
    return;
  }
  Index a = p, b = p + 1;
  while (a > 0 && keys[a - 1] == key) --a;
  while (b < count && keys[b] == key) ++b;
  Index run_rank = 0;
  for (Index j = a; j < b; ++j) {
    const uint32_t other = values_in[j];
    const float other_depth = depths[other];
    run_rank += (other_depth < depth || (other_depth == depth && other < g)) ? 1u : 0u;
  }
  values_out[a + run_rank] = g;
}

}  // namespace

cudaError_t order_equal_keys_by_depth(const uint32_t* sorted_keys, const uint32_t* sorted_values,
                                      const float* depths, uint64_t count, int tile_shift, uint32_t num_tiles,
                                      uint32_t* values_out, uint64_t* ranges, cudaStream_t stream) {
  const cudaError_t cleared = detail::clear_tile_ranges(ranges, num_tiles, stream);
  if (cleared != cudaSuccess || count == 0) return cleared;
  // 32-bit positions while every p + 1 of the launch fits in them.
  if (count < uint64_t(UINT32_MAX) - detail::kBlockSize) {
    order_equal_keys_kernel<uint32_t><<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
        sorted_keys, sorted_values, depths, uint32_t(count), tile_shift, values_out, ranges);
  } else {
    order_equal_keys_kernel<uint64_t><<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
        sorted_keys, sorted_values, depths, count, tile_shift, values_out, ranges);
  }
  return detail::launch_result();
}

}  // namespace rgs::kernels
