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
/// a block scan turns the lengths into positions, then each warp writes whole slices in turn, its lanes on
/// consecutive tiles (coalesced stores, no search for a pair's slice). Positions and order equal
/// emit_pairs_serial's.
__device__ void emit_walk_with_block(const detail::TileWalk& walk, const detail::PairSource& source,
                                     const detail::PairSink& sink, const FrameParams& frame,
                                     const RoofgsFrame& roofgs) {
  using SliceScan = cub::BlockScan<uint32_t, kLargeBlockSize>;
  constexpr int kWarps = kLargeBlockSize / 32;
  __shared__ typename SliceScan::TempStorage scan;
  __shared__ int slice_first[kLargeBlockSize];
  __shared__ uint32_t slice_length[kLargeBlockSize];
  __shared__ uint32_t slice_offset[kLargeBlockSize];

  const int lane = int(threadIdx.x) % 32, warp = int(threadIdx.x) / 32;
  uint64_t base = source.offset;
  for (int round = walk.slice_begin(); round < walk.slice_end(); round += kLargeBlockSize) {
    const int k = round + int(threadIdx.x);
    int first = 0, end = 0;
    if (k < walk.slice_end()) walk.span(k, &first, &end);
    const uint32_t length = end > first ? uint32_t(end - first) : 0u;
    uint32_t offset = 0, total = 0;
    SliceScan(scan).ExclusiveSum(length, offset, total);
    slice_first[threadIdx.x] = first;
    slice_length[threadIdx.x] = length;
    slice_offset[threadIdx.x] = offset;
    __syncthreads();
    const int slices = min(kLargeBlockSize, walk.slice_end() - round);
    for (int s = warp; s < slices; s += kWarps) {
      const uint64_t at = base + slice_offset[s];
      for (uint32_t i = uint32_t(lane); i < slice_length[s]; i += 32) {
        sink.write(at + i, walk.tile(round + s, slice_first[s] + int(i), frame.tiles_x), source, roofgs);
      }
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
