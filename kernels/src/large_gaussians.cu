// Pair emission of the Gaussians with many tiles (emit_large_gaussians): thread blocks on chunks of their
// tile walks, so that a Gaussian covering the screen (32,400 tiles at 4K) is written by many blocks instead of
// one thread (or one block) while the rest of the GPU waits for it.
#include <cub/block/block_reduce.cuh>
#include <cub/block/block_scan.cuh>

#include <algorithm>

#include "launch_util.cuh"
#include "roofgs_gaussian.cuh"

namespace rgs::kernels {
namespace {

/// Threads per block.
constexpr int kLargeBlockSize = 128;
/// Resident blocks per multiprocessor the persistent grid asks for.
constexpr int kBlocksPerSm = 16;

/// Writes the pairs of slices [chunk_first, chunk_first + kLargeChunkSlices) of one Gaussian's walk with the whole
/// block (uniform control flow: every thread calls it with the same walk). The chunk's first position is the
/// Gaussian's plus the lengths of the slices before the chunk (a block reduction over them); a block scan
/// places the chunk's slices; each warp then writes whole slices in turn, its lanes on consecutive tiles
/// (coalesced stores). Positions and order equal emit_pairs_serial's.
__device__ void emit_chunk_with_block(const detail::TileWalk& walk, int chunk_first, const detail::PairSource& source,
                                      const detail::PairSink& sink, const FrameParams& frame,
                                      const RoofgsFrame& roofgs) {
  using LengthReduce = cub::BlockReduce<uint64_t, kLargeBlockSize>;
  using SliceScan = cub::BlockScan<uint32_t, kLargeBlockSize>;
  constexpr int kWarps = kLargeBlockSize / 32;
  __shared__ typename LengthReduce::TempStorage reduce;
  __shared__ typename SliceScan::TempStorage scan;
  __shared__ uint64_t chunk_base;
  __shared__ int slice_first[kLargeChunkSlices];
  __shared__ uint32_t slice_length[kLargeChunkSlices];
  __shared__ uint32_t slice_offset[kLargeChunkSlices];

  const int lane = int(threadIdx.x) % 32, warp = int(threadIdx.x) / 32;
  const auto length_of = [&](int k, int* first) {
    int end = 0;
    walk.span(k, first, &end);
    return end > *first ? uint32_t(end - *first) : 0u;
  };
  uint64_t before = 0;  // lengths of this thread's share of the slices before the chunk
  for (int k = walk.slice_begin() + int(threadIdx.x); k < chunk_first; k += kLargeBlockSize) {
    int first = 0;
    before += length_of(k, &first);
  }
  const uint64_t base = LengthReduce(reduce).Sum(before);
  const int k = chunk_first + int(threadIdx.x);
  int first = 0;
  const uint32_t length = threadIdx.x < kLargeChunkSlices && k < walk.slice_end() ? length_of(k, &first) : 0u;
  uint32_t offset = 0;
  SliceScan(scan).ExclusiveSum(length, offset);
  if (threadIdx.x == 0) chunk_base = source.offset + base;
  if (threadIdx.x < kLargeChunkSlices) {
    slice_first[threadIdx.x] = first;
    slice_length[threadIdx.x] = length;
    slice_offset[threadIdx.x] = offset;
  }
  __syncthreads();
  const int slices = min(kLargeChunkSlices, walk.slice_end() - chunk_first);
  for (int s = warp; s < slices; s += kWarps) {
    const uint64_t at = chunk_base + slice_offset[s];
    for (uint32_t i = uint32_t(lane); i < slice_length[s]; i += 32) {
      sink.write(at + i, walk.tile(chunk_first + s, slice_first[s] + int(i), frame.tiles_x), source, roofgs);
    }
  }
  __syncthreads();  // the shared arrays and the collectives' storage are reused by the next chunk
}

/// Block-per-item loop over the list (items marked kNoLargeGaussian are skipped).
__global__ void __launch_bounds__(kLargeBlockSize)
    emit_large_kernel(RoofgsProjected in, LargeGaussianList large, FrameParams frame, RoofgsFrame roofgs,
                      detail::PairSink sink) {
  const uint64_t items = min(*large.count, static_cast<unsigned long long>(large.capacity));
  for (uint64_t w = blockIdx.x; w < items; w += gridDim.x) {
    const LargeGaussian item = large.items[w];
    if (item.g == kNoLargeGaussian) continue;  // uniform over the block
    // Every thread rebuilds the same walk from the same stored inputs.
    const detail::TileWalk walk = detail::load_tile_walk(in, item.g, frame, roofgs);
    const detail::PairSource source{item.g, in.depth_bins[item.g], in.depths[item.g], item.offset};
    emit_chunk_with_block(walk, walk.slice_begin() + int(item.chunk * kLargeChunkSlices), source, sink, frame,
                          roofgs);
  }
}

}  // namespace

cudaError_t emit_large_gaussians(const RoofgsProjected& projected, const LargeGaussianList& large,
                                 const FrameParams& frame, const RoofgsFrame& roofgs, uint64_t capacity,
                                 uint64_t* keys64, uint32_t* keys32, uint32_t* values, cudaStream_t stream) {
  if (large.capacity == 0) return cudaSuccess;
  int device = 0, sms = 0;
  cudaError_t result = cudaGetDevice(&device);
  if (result == cudaSuccess) result = cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device);
  if (result != cudaSuccess) return result;
  const unsigned blocks = unsigned(std::min<uint64_t>(large.capacity, uint64_t(sms) * kBlocksPerSm));
  emit_large_kernel<<<blocks, kLargeBlockSize, 0, stream>>>(projected, large, frame, roofgs,
                                                            detail::PairSink{capacity, keys64, keys32, values});
  return detail::launch_result();
}

}  // namespace rgs::kernels
