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
/// through; a pair in a run [a, b) of equal keys goes to a + its rank in the run under (depth, index), counted
/// over the run (O(run length) per pair, as the render's own loop over the tile's pairs).
__global__ void __launch_bounds__(detail::kBlockSize)
    order_equal_keys_kernel(const uint32_t* __restrict__ keys, const uint32_t* __restrict__ values_in,
                            const float* __restrict__ depths, uint64_t count, int tile_shift,
                            uint32_t* __restrict__ values_out, uint64_t* __restrict__ ranges) {
  const uint64_t p = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p >= count) return;
  const uint32_t key = keys[p];
  const uint32_t g = values_in[p];
  const uint32_t previous_key = p > 0 ? keys[p - 1] : 0u;
  // Tile ranges, as tile_ranges_kernel (the shift is done in 64 bits: a single-tile key has 32 depth bits).
  detail::record_tile_range(ranges, p, count, uint64_t(key) >> tile_shift, uint64_t(previous_key) >> tile_shift);

  const bool tied_before = p > 0 && previous_key == key;
  const bool tied_after = p + 1 < count && keys[p + 1] == key;
  if (!tied_before && !tied_after) {
    values_out[p] = g;
    return;
  }
  uint64_t a = p, b = p + 1;
  while (a > 0 && keys[a - 1] == key) --a;
  while (b < count && keys[b] == key) ++b;
  const float depth = depths[g];
  uint64_t rank = 0;
  for (uint64_t j = a; j < b; ++j) {
    const uint32_t other = values_in[j];
    const float other_depth = depths[other];
    rank += (other_depth < depth || (other_depth == depth && other < g)) ? 1u : 0u;
  }
  values_out[a + rank] = g;
}

}  // namespace

cudaError_t order_equal_keys_by_depth(const uint32_t* sorted_keys, const uint32_t* sorted_values,
                                      const float* depths, uint64_t count, int tile_shift, uint32_t num_tiles,
                                      uint32_t* values_out, uint64_t* ranges, cudaStream_t stream) {
  const cudaError_t cleared = detail::clear_tile_ranges(ranges, num_tiles, stream);
  if (cleared != cudaSuccess || count == 0) return cleared;
  order_equal_keys_kernel<<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
      sorted_keys, sorted_values, depths, count, tile_shift, values_out, ranges);
  return detail::launch_result();
}

}  // namespace rgs::kernels
