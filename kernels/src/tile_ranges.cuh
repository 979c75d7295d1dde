// The per-tile ranges of the sorted pairs (3DGS identifyTileRanges), shared by tile_ranges and the depth order
// pass that writes them too (order_equal_keys_by_depth).
#pragma once

#include <cuda_runtime.h>

#include <cstdint>

namespace rgs::kernels::detail {

/// Zeroes the [num_tiles, 2] ranges, so that tiles without pairs get [0, 0).
inline cudaError_t clear_tile_ranges(uint64_t* ranges, uint32_t num_tiles, cudaStream_t stream) {
  return cudaMemsetAsync(ranges, 0, sizeof(uint64_t) * 2 * size_t(num_tiles), stream);
}

/// The range boundaries at sorted pair p of `count`, whose tile is `tile` and whose predecessor's is
/// `previous_tile` (ignored for p = 0): tile t's pairs are [ranges[2t], ranges[2t + 1]).
__device__ inline void record_tile_range(uint64_t* ranges, uint64_t p, uint64_t count, uint64_t tile,
                                         uint64_t previous_tile) {
  if (p == 0) {
    ranges[2 * tile] = 0;
  } else if (tile != previous_tile) {
    ranges[2 * previous_tile + 1] = p;
    ranges[2 * tile] = p;
  }
  if (p == count - 1) ranges[2 * tile + 1] = count;
}

}  // namespace rgs::kernels::detail
