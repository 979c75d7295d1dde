// Stages 2 and 4 of the 3DGS baseline: one (key, value) pair per touched tile (duplicateWithKeys), and the
// per-tile ranges of the sorted pairs (identifyTileRanges).
#include "launch_util.cuh"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/sort_key.h"

namespace rgs::kernels {
namespace {

__global__ void __launch_bounds__(detail::kBlockSize)
    duplicate_baseline_kernel(const float* depths, const float* means2d, const int32_t* radii,
                              const uint64_t* offsets, uint32_t count, uint32_t tiles_x, uint32_t tiles_y,
                              uint64_t* keys, uint32_t* values) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count || radii[i] <= 0) return;
  uint64_t off = i == 0 ? 0 : offsets[i - 1];
  // The rectangle preprocess counted, recomputed from the same inputs (as 3DGS does).
  const TileRect rect = tile_rect(means2d[2 * i], means2d[2 * i + 1], radii[i], int(tiles_x), int(tiles_y));
  const float depth = depths[i];
  for (int ty = rect.y_min; ty < rect.y_max; ++ty) {
    for (int tx = rect.x_min; tx < rect.x_max; ++tx) {
      keys[off] = make_key64(uint32_t(ty) * tiles_x + uint32_t(tx), depth);
      values[off] = i;
      ++off;
    }
  }
}

template <typename Key>
__global__ void __launch_bounds__(detail::kBlockSize)
    tile_ranges_kernel(const Key* keys, uint64_t count, int tile_shift, uint64_t* ranges) {
  const uint64_t p = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p >= count) return;
  const uint64_t tile = uint64_t(keys[p]) >> tile_shift;
  if (p == 0) {
    ranges[2 * tile] = 0;
  } else {
    const uint64_t previous = uint64_t(keys[p - 1]) >> tile_shift;
    if (tile != previous) {
      ranges[2 * previous + 1] = p;
      ranges[2 * tile] = p;
    }
  }
  if (p == count - 1) ranges[2 * tile + 1] = count;
}

template <typename Key>
cudaError_t launch_tile_ranges(const Key* sorted_keys, uint64_t count, int tile_shift, uint32_t num_tiles,
                               uint64_t* ranges, cudaStream_t stream) {
  const cudaError_t cleared = cudaMemsetAsync(ranges, 0, sizeof(uint64_t) * 2 * size_t(num_tiles), stream);
  if (cleared != cudaSuccess || count == 0) return cleared;
  tile_ranges_kernel<Key><<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(sorted_keys, count,
                                                                                        tile_shift, ranges);
  return detail::launch_result();
}

}  // namespace

cudaError_t duplicate_baseline(const ProjectedArrays& projected, const uint64_t* offsets, uint32_t count,
                               const FrameParams& frame, uint64_t* keys, uint32_t* values, cudaStream_t stream) {
  if (count == 0) return cudaSuccess;
  duplicate_baseline_kernel<<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
      projected.depths, projected.means2d, projected.radii, offsets, count, frame.tiles_x, frame.tiles_y, keys,
      values);
  return detail::launch_result();
}

cudaError_t tile_ranges(const uint64_t* sorted_keys, uint64_t count, int tile_shift, uint32_t num_tiles,
                        uint64_t* ranges, cudaStream_t stream) {
  return launch_tile_ranges(sorted_keys, count, tile_shift, num_tiles, ranges, stream);
}

cudaError_t tile_ranges(const uint32_t* sorted_keys, uint64_t count, int tile_shift, uint32_t num_tiles,
                        uint64_t* ranges, cudaStream_t stream) {
  return launch_tile_ranges(sorted_keys, count, tile_shift, num_tiles, ranges, stream);
}

}  // namespace rgs::kernels
