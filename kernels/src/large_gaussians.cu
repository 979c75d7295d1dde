// Pair emission of the Gaussians with many tiles (emit_large_gaussians): a warp per chunk of a tile walk, so
// that a Gaussian covering the screen (32,400 tiles at 4K) is written by many warps instead of one thread
// while the rest of the GPU waits for it, and the chunks of many Gaussians are in flight at once.
#include <algorithm>

#include "launch_util.cuh"
#include "roofgs_gaussian.cuh"

namespace rgs::kernels {
namespace {

/// Threads per block (warps take work items independently; the block only groups them).
constexpr int kLargeBlockSize = 128;
constexpr int kWarpsPerBlock = kLargeBlockSize / 32;
static_assert(kLargeChunkSlices <= 32, "a chunk's slices are measured one per lane");

constexpr unsigned kAllLanes = 0xffffffffu;

/// Writes the pairs of slices [chunk_first, chunk_first + chunk_slices) of one Gaussian's walk with the
/// calling warp (every lane calls it with the same walk). The chunk's first position is the Gaussian's plus
/// the lengths of the slices before the chunk (lanes take every 32nd slice, then a warp sum); lane i measures
/// the chunk's slice i, a warp scan places them, and the warp writes the chunk's pairs 32 at a time, lanes on
/// consecutive positions (coalesced stores) whatever the slices' lengths. Positions and order equal
/// emit_pairs_serial's.
__device__ void emit_chunk_with_warp(const detail::TileWalk& walk, int chunk_first, int chunk_slices,
                                     const detail::PairSource& source, const detail::PairSink& sink,
                                     const FrameParams& frame, const RoofgsFrame& roofgs) {
  const int lane = int(threadIdx.x % 32);
  const auto length_of = [&](int k, int* first) {
    int end = 0;
    walk.span(k, first, &end);
    return end > *first ? uint32_t(end - *first) : 0u;
  };
  // A walk holds at most 2048 × 2048 tiles (validate_camera's largest image), so 32-bit sums suffice.
  uint32_t before = 0;
  for (int k = walk.slice_begin() + lane; k < chunk_first; k += 32) {
    int first = 0;
    before += length_of(k, &first);
  }
  const uint64_t chunk_base = source.offset + __reduce_add_sync(kAllLanes, before);
  const int k = chunk_first + lane;
  int first = 0;
  const uint32_t length = lane < chunk_slices && k < walk.slice_end() ? length_of(k, &first) : 0u;
  const uint32_t inclusive = detail::warp_inclusive_sum(length, lane);
  const uint32_t exclusive = inclusive - length;
  const uint32_t total = __shfl_sync(kAllLanes, inclusive, 31);
  // The chunk's pairs laid end to end, 32 per step: lane i writes pair f = step + i, found in slice s (its
  // cursor only moves forward, since f does), so short slices do not leave lanes idle.
  int s = 0;
  for (uint32_t step = 0; step < total; step += 32) {
    const uint32_t f = step + uint32_t(lane);
    for (;;) {  // advance s while pair f lies past slice s (lanes past `total` stay put)
      const uint32_t next_start = __shfl_sync(kAllLanes, exclusive, min(s + 1, 31));
      const bool advance = f < total && s + 1 < chunk_slices && f >= next_start;
      if (!__any_sync(kAllLanes, advance)) break;
      if (advance) ++s;
    }
    const int slice_first = __shfl_sync(kAllLanes, first, s);
    const uint32_t slice_start = __shfl_sync(kAllLanes, exclusive, s);
    if (f < total) {
      sink.write(chunk_base + f, walk.tile(chunk_first + s, slice_first + int(f - slice_start), frame.tiles_x),
                 source, roofgs);
    }
  }
}

/// HostTotals: the counts, a system-scope fence, then the sequence number, so that a host that reads the new
/// sequence number reads the new counts.
__device__ void publish_totals(const HostTotals& totals) {
  if (totals.host == nullptr) return;
  totals.host[0] = totals.totals[0];
  totals.host[1] = totals.totals[1];
  __threadfence_system();
  totals.host[2] = totals.sequence;
}

__global__ void publish_totals_kernel(HostTotals totals) { publish_totals(totals); }

/// Warp-per-item loop over the list (items marked kNoLargeGaussian are skipped); block 0 publishes the totals
/// first.
__global__ void __launch_bounds__(kLargeBlockSize)
    emit_large_kernel(RoofgsProjected in, LargeGaussianList large, FrameParams frame, RoofgsFrame roofgs,
                      detail::PairSink sink, HostTotals totals) {
  if (blockIdx.x == 0 && threadIdx.x == 0) publish_totals(totals);
  const uint64_t items = min(*large.count, static_cast<unsigned long long>(large.capacity));
  const uint64_t warps = uint64_t(gridDim.x) * kWarpsPerBlock;
  for (uint64_t w = uint64_t(blockIdx.x) * kWarpsPerBlock + threadIdx.x / 32; w < items; w += warps) {
    const LargeGaussian item = large.items[w];
    if (item.g == kNoLargeGaussian) continue;  // uniform over the warp
    // Every lane rebuilds the same walk from the same stored inputs.
    const detail::TileWalk walk = detail::load_tile_walk(in, item.g, frame, roofgs);
    const detail::PairSource source{item.g, in.depth_bins[item.g], in.depths[item.g], item.offset};
    emit_chunk_with_warp(walk, walk.slice_begin() + int(item.first_slice), int(item.slices), source, sink, frame,
                         roofgs);
  }
}

}  // namespace

cudaError_t emit_large_gaussians(const RoofgsProjected& projected, const LargeGaussianList& large,
                                 const FrameParams& frame, const RoofgsFrame& roofgs, uint64_t capacity,
                                 uint64_t* keys64, uint32_t* keys32, uint32_t* values, const HostTotals& totals,
                                 cudaStream_t stream) {
  if (large.capacity == 0) {
    if (totals.host == nullptr) return cudaSuccess;
    publish_totals_kernel<<<1, 1, 0, stream>>>(totals);
    return detail::launch_result();
  }
  // A persistent grid of as many blocks as fit at once: the items are dealt evenly over its warps, so a block
  // that had to wait for a free slot would finish its share last.
  int device = 0, sms = 0, per_sm = 0;
  cudaError_t result = cudaGetDevice(&device);
  if (result == cudaSuccess) result = cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device);
  if (result == cudaSuccess) {
    result = cudaOccupancyMaxActiveBlocksPerMultiprocessor(&per_sm, emit_large_kernel, kLargeBlockSize, 0);
  }
  if (result != cudaSuccess) return result;
  const uint64_t warp_blocks = (large.capacity + kWarpsPerBlock - 1) / kWarpsPerBlock;
  const unsigned blocks = unsigned(std::min<uint64_t>(warp_blocks, uint64_t(sms) * uint64_t(std::max(per_sm, 1))));
  const detail::PairSink sink{capacity, keys64, keys32, values};
  emit_large_kernel<<<blocks, kLargeBlockSize, 0, stream>>>(projected, large, frame, roofgs, sink, totals);
  return detail::launch_result();
}

}  // namespace rgs::kernels
