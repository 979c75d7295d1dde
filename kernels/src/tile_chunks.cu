// The chunks of the long tiles (beyond the paper; kernels/shared/tile_chunks.h): one work item per chunk of
// every tile with more than K pairs, for the chunk blocks of render_roofgs.
#include "launch_util.cuh"
#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/tile_chunks.h"

namespace rgs::kernels {
namespace {

__global__ void list_tile_chunks_kernel(const uint64_t* __restrict__ ranges, uint32_t tiles, TileChunks chunks) {
  const uint32_t tile = blockIdx.x * blockDim.x + threadIdx.x;
  if (tile == 0) *chunks.next_item_count = 0;
  if (tile >= tiles) return;
  chunks.arrivals[tile] = 0;
  const uint32_t count = tile_chunk_count(ranges[2 * uint64_t(tile) + 1] - ranges[2 * uint64_t(tile)],
                                          chunks.chunk_pairs);
  if (count == 1) return;
  const uint32_t first = atomicAdd(chunks.item_count, count);
  if (uint64_t(first) + count > chunks.capacity) return;  // cannot happen when capacity was sized for the frame
  chunks.first_item[tile] = first;
  for (uint32_t c = 0; c < count; ++c) chunks.items[first + c] = make_uint2(tile, c);
}

}  // namespace

cudaError_t list_tile_chunks(const uint64_t* ranges, uint32_t tiles, const TileChunks& chunks, cudaStream_t stream) {
  if (tiles == 0) return cudaSuccess;
  constexpr uint32_t kThreads = 256;
  list_tile_chunks_kernel<<<(tiles + kThreads - 1) / kThreads, kThreads, 0, stream>>>(ranges, tiles, chunks);
  return detail::launch_result();
}

}  // namespace rgs::kernels
