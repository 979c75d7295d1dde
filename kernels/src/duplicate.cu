// Stages 2 and 4 of the 3DGS baseline: one (key, value) pair per touched tile (duplicateWithKeys), and the
// per-tile ranges of the sorted pairs (identifyTileRanges).
#include "launch_util.cuh"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/kernels/shared/projection.h"
#include "rgs/kernels/shared/sort_key.h"
#include "tile_ranges.cuh"

namespace rgs::kernels {
namespace {

__global__ void __launch_bounds__(detail::kBlockSize)
    duplicate_baseline_kernel(const float* depths, const float* means2d, const int32_t* radii,
                              const uint64_t* offsets, uint32_t count, FrameParams frame, uint64_t* keys,
                              uint32_t* values) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count || radii[i] <= 0) return;
  uint64_t off = i == 0 ? 0 : offsets[i - 1];
  // The rectangle preprocess counted, recomputed from the same inputs (as 3DGS does).
  const uint32_t tiles_x = frame.tiles_x;
  const TileRect rect = rows_of_pass(
      tile_rect(means2d[2 * i], means2d[2 * i + 1], radii[i], int(tiles_x), int(frame.tiles_y)), frame);
  const float depth = depths[i];
  for (int ty = rect.y_min; ty < rect.y_max; ++ty) {
    for (int tx = rect.x_min; tx < rect.x_max; ++tx) {
      keys[off] = make_key64(uint32_t(ty) * tiles_x + uint32_t(tx), depth);
      values[off] = i;
      ++off;
    }
  }
}

/// Thread t reads keys [16t / sizeof(Key), …) with one 16-byte load (plus the key before them) and writes the
/// range boundaries that fall among them: one key compared with its predecessor per pair, as 3DGS's
/// identifyTileRanges, with fewer, wider loads.
template <typename Key>
__global__ void __launch_bounds__(detail::kBlockSize)
    tile_ranges_kernel(const Key* keys, uint64_t count, int tile_shift, uint64_t* ranges) {
  constexpr int kItems = 16 / int(sizeof(Key));
  struct alignas(16) Group {
    Key k[kItems];
  };
  const uint64_t first = (uint64_t(blockIdx.x) * blockDim.x + threadIdx.x) * kItems;
  if (first >= count) return;
  Key k[kItems];
  if (first + kItems <= count) {
    const Group group = reinterpret_cast<const Group*>(keys)[first / kItems];
    for (int i = 0; i < kItems; ++i) k[i] = group.k[i];
  } else {
    for (int i = 0; i < kItems; ++i) k[i] = first + i < count ? keys[first + i] : Key(0);
  }
  uint64_t previous = first > 0 ? uint64_t(keys[first - 1]) >> tile_shift : 0;
  for (int i = 0; i < kItems && first + i < count; ++i) {
    const uint64_t tile = uint64_t(k[i]) >> tile_shift;
    detail::record_tile_range(ranges, first + uint64_t(i), count, tile, previous);
    previous = tile;
  }
}

template <typename Key>
cudaError_t launch_tile_ranges(const Key* sorted_keys, uint64_t count, int tile_shift, uint32_t num_tiles,
                               uint64_t* ranges, cudaStream_t stream) {
  if (reinterpret_cast<uintptr_t>(sorted_keys) % 16 != 0) return cudaErrorMisalignedAddress;
  const cudaError_t cleared = detail::clear_tile_ranges(ranges, num_tiles, stream);
  if (cleared != cudaSuccess || count == 0) return cleared;
  constexpr uint64_t kItems = 16 / sizeof(Key);
  tile_ranges_kernel<Key><<<detail::blocks_for((count + kItems - 1) / kItems), detail::kBlockSize, 0, stream>>>(
      sorted_keys, count, tile_shift, ranges);
  return detail::launch_result();
}

}  // namespace

cudaError_t duplicate_baseline(const ProjectedArrays& projected, const uint64_t* offsets, uint32_t count,
                               const FrameParams& frame, uint64_t* keys, uint32_t* values, cudaStream_t stream) {
  if (count == 0) return cudaSuccess;
  duplicate_baseline_kernel<<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
      projected.depths, projected.means2d, projected.radii, offsets, count, frame, keys, values);
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
