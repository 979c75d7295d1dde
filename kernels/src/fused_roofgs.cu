// The fused RoofGS kernel: preprocess + tile count + allocation + key/value generation in one pass. Pair
// space is allocated per thread block in block order by a decoupled look-back (Merrill & Garland, "Single-pass
// Parallel Prefix Scan with Decoupled Look-back", 2016): block b publishes its pair count, then its first
// warp adds its predecessors' counts, 32 at a time, until it meets one that published an inclusive prefix.
// Pairs therefore land exactly where the separate stages (scan + duplicate) put them, in emission order,
// and every frame is deterministic (an atomicAdd per block, as the public RoofGS code uses, orders blocks by
// arrival instead: PairAllocation::kArrivalOrder, for frames whose depth order pass makes the order moot).
#include <cub/block/block_scan.cuh>
#include <cuda/atomic>

#include <algorithm>

#include "launch_util.cuh"
#include "roofgs_gaussian.cuh"

namespace rgs::kernels {
namespace {

// Status word of a block: flag in the top 2 bits, pair count in the low 62.
constexpr unsigned long long kFlagAggregate = 1ull << 62;
constexpr unsigned long long kFlagInclusive = 2ull << 62;
constexpr unsigned long long kValueMask = (1ull << 62) - 1;

/// Threads per block: half the other kernels' 256, so that a small scene (flowers: 38k Gaussians, one wave)
/// spreads over twice as many blocks and a block waits at its barriers for 4 warps instead of 8.
constexpr uint32_t kFusedBlockSize = 128;

__device__ inline void publish(unsigned long long* word, unsigned long long value) {
  __threadfence();
  atomicExch(word, value);
}

/// Publishes block `block`'s pair count for its successors' look-back: as its inclusive prefix for block 0,
/// else as an aggregate. Called by one thread, as soon as the count is known.
__device__ void publish_aggregate(unsigned long long* status, uint32_t block, unsigned long long aggregate) {
  publish(&status[block], (block == 0 ? kFlagInclusive : kFlagAggregate) | aggregate);
}

/// Exclusive prefix of block `block` (sum of the pair counts of blocks < block), after publish_aggregate;
/// publishes its inclusive prefix last. Called by the 32 lanes of the block's first warp, which read 32
/// predecessors' status words at once (lane i reads block − 1 − i, spinning until it has published: it
/// started before us, so it will), add those up to the nearest inclusive prefix, and move the window back by
/// 32 until they meet one. Returns the prefix in every lane.
__device__ unsigned long long look_back(unsigned long long* status, uint32_t block, unsigned long long aggregate) {
  const int lane = int(threadIdx.x);
  if (block == 0) return 0;
  unsigned long long exclusive = 0;
  for (int64_t window = int64_t(block) - 1;; window -= 32) {
    const int64_t j = window - lane;
    unsigned long long word = kFlagInclusive;  // before block 0: an empty inclusive prefix
    if (j >= 0) {
      // Relaxed loads at device scope (L2, not the SM's L1): the word carries its value, no other data hangs
      // on it. A predecessor still counting costs a short sleep per poll instead of a stream of L2 requests.
      const cuda::atomic_ref<unsigned long long, cuda::thread_scope_device> ref(status[j]);
      while ((word = ref.load(cuda::std::memory_order_relaxed)) == 0) __nanosleep(64);
    }
    const unsigned inclusive = __ballot_sync(0xffffffffu, (word & ~kValueMask) == kFlagInclusive);
    const int last = inclusive != 0 ? __ffs(int(inclusive)) - 1 : 31;  // lanes 0..last count
    unsigned long long value = lane <= last ? (word & kValueMask) : 0ull;
    for (int offset = 16; offset > 0; offset /= 2) value += __shfl_xor_sync(0xffffffffu, value, offset);
    exclusive += value;
    if (inclusive != 0) break;
  }
  if (lane == 0) publish(&status[block], kFlagInclusive | (exclusive + aggregate));
  return exclusive;
}

/// Eight blocks an SM (64 registers, 4–22 bytes of spills by variant) instead of the seven that 68 registers
/// allow: the kernel waits on its loads (long-scoreboard stalls lead its Nsight Compute samples on taebak), and
/// the extra warps hide more of them (measured with the ticket's removal below:
/// docs/lab/TRIED.md#tried-and-not-kept).
template <bool kCompact, int kDegree>
__global__ void __launch_bounds__(kFusedBlockSize, 8)
    fused_kernel(GaussianSource src, FrameParams frame, RoofgsFrame roofgs, RoofgsProjected out,
                 FusedScratch scratch, LargeGaussianList large, detail::PairSink sink, bool arrival_order) {
  using BlockScan = cub::BlockScan<uint32_t, kFusedBlockSize>;
  __shared__ typename BlockScan::TempStorage scan_storage;
  __shared__ uint32_t block_id;
  __shared__ unsigned long long block_base;
  __shared__ detail::LongWalks<kFusedBlockSize> long_walks;

  // In block order, blocks take ids in the order they start, so every predecessor a block waits for is already
  // running; in arrival order no block waits for another, and the launch order serves (no atomic and barrier
  // before the first loads: 3 % of the kernel's stall samples on taebak at 4K).
  if (!arrival_order) {  // uniform over the launch
    if (threadIdx.x == 0) block_id = atomicAdd(scratch.block_ticket, 1u);
    __syncthreads();
  }
  const uint32_t block = arrival_order ? blockIdx.x : block_id;
  const uint32_t g = block * kFusedBlockSize + threadIdx.x;

  detail::ProjectedRegs p;  // every field read is written first (preprocess_gaussian sets tiles)
  detail::TileWalk walk;  // read only for visible Gaussians
  const bool visible = detail::preprocess_gaussian<kCompact>(src, g, frame, roofgs, long_walks, &p, &walk);
  if (visible) {
    detail::store_projected(p, g, out);
  } else if (g < src.count) {
    out.radii[g] = 0;
  }

  // 32-bit block sums: one Gaussian touches at most the whole grid, ≤ 2^22 tiles for the largest image
  // validate_camera accepts (32768², 2048² tiles), so 128 Gaussians stay below 2^29.
  uint32_t local_offset = 0, block_total = 0;
  BlockScan(scan_storage).ExclusiveSum(p.tiles, local_offset, block_total);
  // The count goes out before the colours are computed: the successors' look-backs wait for it, and the
  // SH work of every warp overlaps this block's own wait (before this order, 37 % of the kernel's stall
  // samples on flowers at 4K were warps at the barrier below and 8 % the look-back's polls).
  if (arrival_order) {  // uniform over the launch
    if (threadIdx.x == 0) block_base = atomicAdd(&scratch.totals[0], static_cast<unsigned long long>(block_total));
  } else if (threadIdx.x == 0) {
    publish_aggregate(scratch.block_status, block, block_total);
  }
  if (visible) detail::shade_gaussian<kCompact, kDegree>(src, g, frame, p.log_opacity, out);
  if (!arrival_order && threadIdx.x < 32) {
    const unsigned long long exclusive = look_back(scratch.block_status, block, block_total);
    if (threadIdx.x == 0) {
      block_base = exclusive;
      if (block == gridDim.x - 1) scratch.totals[0] = exclusive + block_total;
    }
  }
  detail::count_large_pairs(p.tiles, &scratch.totals[1]);
  __syncthreads();
  if (p.tiles == 0) return;
  if (p.tiles > kSerialTileLimit && large.capacity > 0) {  // emit_large_gaussians rebuilds the walk from these
    out.cov2d[3 * uint64_t(g)] = p.cov.xx;
    out.cov2d[3 * uint64_t(g) + 1] = p.cov.xy;
    out.cov2d[3 * uint64_t(g) + 2] = p.cov.yy;
    out.snug_t[g] = p.snug_t;
    out.depth_bins[g] = p.depth_bin;
  }
  const detail::PairSource source{g, p.depth_bin, p.depth, block_base + local_offset};
  detail::emit_or_defer(walk, source, p.tiles, sink, large, frame, roofgs);
}

}  // namespace

uint32_t fused_blocks(uint32_t count) { return std::max(1u, (count + kFusedBlockSize - 1) / kFusedBlockSize); }

cudaError_t fused_preprocess_roofgs(const GaussianSource& source, const FrameParams& frame,
                                    const RoofgsFrame& roofgs, const RoofgsProjected& out,
                                    const FusedScratch& scratch, const LargeGaussianList& large, uint64_t capacity,
                                    PairAllocation allocation, uint64_t* keys64, uint32_t* keys32, uint32_t* values,
                                    cudaStream_t stream) {
  const uint32_t blocks = fused_blocks(source.count);
  const bool arrival = allocation == PairAllocation::kArrivalOrder;
  cudaError_t result = cudaSuccess;
  if (!arrival) {  // the block tickets and the look-back's status words (arrival order uses neither)
    result = cudaMemsetAsync(scratch.block_ticket, 0, sizeof(uint32_t), stream);
    if (result == cudaSuccess) {
      result = cudaMemsetAsync(scratch.block_status, 0, sizeof(unsigned long long) * blocks, stream);
    }
  }
  if (result == cudaSuccess) {
    result = cudaMemsetAsync(scratch.totals, 0, kFusedTotals * sizeof(unsigned long long), stream);
  }
  if (result == cudaSuccess && large.count != scratch.totals + kFusedLargeCount) {
    result = cudaMemsetAsync(large.count, 0, sizeof(*large.count), stream);
  }
  if (result != cudaSuccess || source.count == 0) return result;
  const detail::PairSink sink{capacity, keys64, keys32, values};
  const uint32_t degree = roofgs.compact ? source.compact.sh_degree : source.fp32.sh_degree;
  const cudaError_t launched = detail::with_sh_degree(degree, [&](auto d) {
    if (roofgs.compact) {
      fused_kernel<true, decltype(d)::value><<<blocks, kFusedBlockSize, 0, stream>>>(source, frame, roofgs, out, scratch, large,
                                                                         sink, arrival);
    } else {
      fused_kernel<false, decltype(d)::value><<<blocks, kFusedBlockSize, 0, stream>>>(source, frame, roofgs, out, scratch,
                                                                          large, sink, arrival);
    }
  });
  return launched != cudaSuccess ? launched : detail::launch_result();
}

}  // namespace rgs::kernels
