// Pair emission of the Gaussians with many tiles (emit_large_gaussians): one thread block per Gaussian, so
// that a Gaussian covering the screen (32,400 tiles at 4K) no longer keeps a single thread writing while the
// rest of the GPU waits for it.
#include <cub/block/block_scan.cuh>

#include <algorithm>

#include "launch_util.cuh"
#include "roofgs_gaussian.cuh"

namespace rgs::kernels {
namespace {

/// Threads per block: one slice of the tile walk each per round (a 4K frame has at most 135 slices, since
/// the walk runs along the shorter side).
constexpr int kLargeBlockSize = 128;
/// Resident blocks per multiprocessor the persistent grid asks for.
constexpr int kBlocksPerSm = 16;

/// Writes the pairs of one Gaussian with the whole block (uniform control flow: every thread calls it with
/// the same walk). Round r takes slices [begin + 128r, begin + 128r + 128): each thread measures one slice,
/// a block scan turns the lengths into positions, then the round's pairs are dealt round-robin; a pair's
/// slice is the last one whose prefix is ≤ its rank (empty slices share their successor's prefix).
/// Positions and order equal emit_pairs_serial's.
__device__ void emit_walk_with_block(const detail::TileWalk& walk, const detail::PairSource& source,
                                     const detail::PairSink& sink, const FrameParams& frame,
                                     const RoofgsFrame& roofgs) {
  using SliceScan = cub::BlockScan<uint32_t, kLargeBlockSize>;
  __shared__ typename SliceScan::TempStorage scan;
  __shared__ int slice_first[kLargeBlockSize];
  __shared__ uint32_t slice_offset[kLargeBlockSize];

  uint64_t base = source.offset;
  for (int round = walk.slice_begin(); round < walk.slice_end(); round += kLargeBlockSize) {
    const int k = round + int(threadIdx.x);
    int first = 0, end = 0;
    if (k < walk.slice_end()) walk.span(k, &first, &end);
    const uint32_t length = end > first ? uint32_t(end - first) : 0u;
    uint32_t offset = 0, total = 0;
    SliceScan(scan).ExclusiveSum(length, offset, total);
    slice_first[threadIdx.x] = first;
    slice_offset[threadIdx.x] = offset;
    __syncthreads();
    const int slices = min(kLargeBlockSize, walk.slice_end() - round);
    for (uint32_t j = threadIdx.x; j < total; j += kLargeBlockSize) {
      int lo = 0, hi = slices - 1;
      while (lo < hi) {
        const int mid = (lo + hi + 1) / 2;
        if (slice_offset[mid] <= j) {
          lo = mid;
        } else {
          hi = mid - 1;
        }
      }
      const int v = slice_first[lo] + int(j - slice_offset[lo]);
      sink.write(base + j, walk.tile(round + lo, v, frame.tiles_x), source, roofgs);
    }
    base += total;
    __syncthreads();  // the slice arrays and the scan storage are reused by the next round
  }
}

__global__ void __launch_bounds__(kLargeBlockSize)
    emit_large_kernel(RoofgsProjected in, LargeGaussianList large, FrameParams frame, RoofgsFrame roofgs,
                      detail::PairSink sink) {
  const uint32_t listed = min(*large.count, large.capacity);
  for (uint32_t i = blockIdx.x; i < listed; i += gridDim.x) {
    const LargeGaussian entry = large.items[i];
    const uint32_t g = entry.g;
    // Every thread rebuilds the same walk from the same stored inputs.
    const detail::TileWalk walk = detail::load_tile_walk(in, g, frame, roofgs);
    const detail::PairSource source{g, in.depth_bins[g], in.depths[g], entry.offset};
    emit_walk_with_block(walk, source, sink, frame, roofgs);
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
