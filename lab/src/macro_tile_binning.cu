// Macro-tile binning (kernels::PairBinning): the tiles' depth-ordered lists built without the global pair sort,
// after the macro-tile batches of gsplat's inference renderer (HiGS); measured and not kept (docs/lab/TRIED.md).
//
// A macro-tile is 8×4 tiles. Each visible Gaussian makes one entry per macro-tile its AccuTile walk reaches:
// (view depth, id, mask of the macro-tile's tiles it reaches). Entries are counted into buckets of
// (macro-tile, depth slab) — the slab is the top bits of the 32-bit key's depth bin, so slabs follow depth
// — placed by a counting sort, and each bucket is sorted by (depth, id) in a thread block. A bucket's entries
// then write their pairs: tile t of macro-tile m takes its slabs in order, each slab's pairs in (depth, id)
// order, which is the order the pair sort and the depth order pass give every tile.
#include <cub/block/block_radix_sort.cuh>
#include <cub/device/device_scan.cuh>

#include <algorithm>
#include <climits>
#include <cstdio>
#include <cstdlib>

#include "launch_util.cuh"
#include "rgs/lab/macro_tile_binning.h"
#include "rgs/runtime/device_buffer.h"
#include "roofgs_gaussian.cuh"

namespace rgs::lab {
namespace {

using kernels::FrameParams;
using kernels::RoofgsFrame;
using kernels::RoofgsProjected;
namespace detail = kernels::detail;
namespace cg = cooperative_groups;

constexpr int kMacroWidth = 8;   // tiles
constexpr int kMacroHeight = 4;  // tiles; a mask bit per tile: ly · 8 + lx
constexpr int kBucketBits = 18;  // macro-tile bits + slab bits
constexpr int kSortThreads = 256;
constexpr uint32_t kSegmentCapacity = kSortThreads * 16;
constexpr uint32_t kSegmentTarget = kSegmentCapacity / 2;
constexpr int kMaxSlabBits = 10;  // segments_kernel searches a macro-tile's buckets

/// Where a frame's entries and pairs go.
struct BinLayout {
  uint32_t macros_x = 0;
  int slab_bits = 0;    // bucket = macro << slab_bits | slab
  int slab_shift = 0;   // slab = depth bin >> slab_shift
  int bucket_bits = 0;  // macro-tile bits + slab_bits
  __host__ __device__ uint32_t buckets() const { return 1u << bucket_bits; }
  /// Index of (macro-tile, tile of it, slab) in the pair counts: tile-major, so a tile's slabs are adjacent.
  __device__ uint32_t count_index(uint32_t bucket, uint32_t tile) const {
    const uint32_t macro = bucket >> slab_bits;
    return ((macro * 32u + tile) << slab_bits) | (bucket & ((1u << slab_bits) - 1u));
  }
};

/// Calls visit(macro, mask) for every macro-tile that the walk reaches, with the mask of its tiles reached.
/// Slices are taken a macro-tile band at a time (4 tile rows, or 8 tile columns); a band's spans give each
/// macro-tile across it its mask.
template <typename Visit>
__device__ void for_each_macro_tile(const detail::TileWalk& walk, uint32_t macros_x, Visit&& visit) {
  const bool rows = !walk.accutile || walk.walk.walk_rows;  // slice k is tile row k, else tile column k
  const int band = rows ? kMacroHeight : kMacroWidth;
  const int across = rows ? kMacroWidth : kMacroHeight;
  const int k_begin = walk.slice_begin(), k_end = walk.slice_end();
  for (int band_first = (k_begin / band) * band; band_first < k_end; band_first += band) {
    int first[kMacroWidth], end[kMacroWidth];
    int v_min = INT_MAX, v_max = INT_MIN;
#pragma unroll
    for (int i = 0; i < kMacroWidth; ++i) {
      const int k = band_first + i;
      first[i] = end[i] = 0;
      if (i < band && k >= k_begin && k < k_end) {
        walk.span(k, &first[i], &end[i]);
        if (end[i] > first[i]) v_min = min(v_min, first[i]), v_max = max(v_max, end[i]);
      }
    }
    for (int v0 = v_max > v_min ? (v_min / across) * across : v_max; v0 < v_max; v0 += across) {
      uint32_t mask = 0;
#pragma unroll
      for (int i = 0; i < kMacroWidth; ++i) {
        const int lo = max(first[i], v0), hi = min(end[i], v0 + across);
        if (i >= band || hi <= lo) continue;
        if (rows) {
          mask |= ((1u << (hi - lo)) - 1u) << (i * kMacroWidth + (lo - v0));
        } else {
          for (int v = lo; v < hi; ++v) mask |= 1u << ((v - v0) * kMacroWidth + i);
        }
      }
      if (mask == 0) continue;
      const uint32_t mx = uint32_t(rows ? v0 / kMacroWidth : band_first / kMacroWidth);
      const uint32_t my = uint32_t(rows ? band_first / kMacroHeight : v0 / kMacroHeight);
      visit(my * macros_x + mx, mask);
    }
  }
}

/// Counts (kFill false) or places (kFill true) the entries of Gaussian g: counters are the bucket counts, or
/// the buckets' next free positions.
template <bool kFill>
__global__ void __launch_bounds__(detail::kBlockSize)
    entries_kernel(RoofgsProjected in, uint32_t count, FrameParams frame, RoofgsFrame roofgs, BinLayout layout,
                   uint32_t* counters, uint32_t* keys, uint64_t* values) {
  const uint32_t g = blockIdx.x * blockDim.x + threadIdx.x;
  if (g >= count || in.tiles_touched[g] == 0) return;
  const detail::TileWalk walk = detail::load_tile_walk(in, g, frame, roofgs);
  const uint32_t slab = in.depth_bins[g] >> layout.slab_shift;
  const uint32_t depth_key = __float_as_uint(in.depths[g]);  // depth > 0: its bits order as the floats
  for_each_macro_tile(walk, layout.macros_x, [&](uint32_t macro, uint32_t mask) {
    // One atomic per bucket among the converged lanes (neighbouring Gaussians often share one).
    const uint32_t bucket = (macro << layout.slab_bits) | slab;
    const cg::coalesced_group active = cg::coalesced_threads();
    const auto peers = cg::labeled_partition(active, bucket);
    uint32_t base = 0;
    if (peers.thread_rank() == 0) base = atomicAdd(&counters[bucket], peers.num_threads());
    const uint32_t slot = peers.shfl(base, 0) + peers.thread_rank();
    if (kFill) {
      keys[slot] = depth_key;
      values[slot] = (uint64_t(g) << 32) | mask;
    }
  });
}

/// Segments: the unit a block sorts. Macro-tile m's buckets are cut where its running entry count crosses a
/// multiple of kSegmentTarget (at the start of the bucket holding that entry), so a segment holds fewer than
/// kSegmentTarget entries plus those of its first bucket. segment_end[b] is the end of the segment that bucket b
/// starts (an entry index ≥ 1), 0 for a bucket that starts none.
__global__ void __launch_bounds__(detail::kBlockSize)
    segments_kernel(const uint32_t* bucket_offsets, BinLayout layout, uint32_t* segment_end) {
  const uint32_t bucket = blockIdx.x * blockDim.x + threadIdx.x;
  if (bucket >= layout.buckets()) return;
  const uint32_t slabs = 1u << layout.slab_bits;
  const uint32_t first = bucket & ~(slabs - 1u);
  const uint32_t base = bucket_offsets[first], macro_end = bucket_offsets[first + slabs];
  const uint32_t p = bucket_offsets[bucket] - base, n = bucket_offsets[bucket + 1] - bucket_offsets[bucket];
  const auto next_cut = [](uint32_t position) {
    return (position + kSegmentTarget - 1) / kSegmentTarget * kSegmentTarget;
  };
  if (n == 0 || next_cut(p) >= p + n) {
    segment_end[bucket] = 0;
    return;
  }
  // The bucket holding the next cut after this one's entries starts the next segment.
  const uint32_t cut = base + next_cut(p + n);
  if (cut >= macro_end) {
    segment_end[bucket] = macro_end;
    return;
  }
  uint32_t lo = bucket + 1, hi = first + slabs;  // the last j in [lo, hi) with bucket_offsets[j] <= cut
  while (hi - lo > 1) {
    const uint32_t mid = (lo + hi) / 2;
    if (bucket_offsets[mid] <= cut) lo = mid; else hi = mid;
  }
  segment_end[bucket] = bucket_offsets[lo];
}

template <int kItems>
using SegmentSort = cub::BlockRadixSort<uint32_t, kSortThreads, kItems, uint64_t>;

/// Dynamic shared memory of sort_segments_kernel: CUB's sort, then the sorted segment.
struct SortStorage {
  union {
    typename SegmentSort<1>::TempStorage sort1;
    typename SegmentSort<2>::TempStorage sort2;
    typename SegmentSort<4>::TempStorage sort4;
    typename SegmentSort<8>::TempStorage sort8;
    typename SegmentSort<16>::TempStorage sort16;
    struct {
      uint32_t keys[kSegmentCapacity];
      uint64_t values[kSegmentCapacity];
    } sorted;
  };
  uint32_t tile_counts[32];
  uint32_t key_min, key_max;
};

/// Sorts the n ≤ kItems · kSortThreads entries at `keys` / `values` by depth key into s.sorted (rank r at
/// index r), over the bits where the segment's keys differ only.
template <int kItems, typename TempStorage>
__device__ void sort_segment(TempStorage& temp, SortStorage& s, const uint32_t* keys, const uint64_t* values,
                             uint32_t n) {
  const uint32_t t = threadIdx.x;
  // Blocked input: entries past n are last, so the stable sort keeps them after the equal keys of the segment.
  uint32_t k[kItems];
  uint64_t v[kItems];
  uint32_t lo = 0xffffffffu, hi = 0;
#pragma unroll
  for (int i = 0; i < kItems; ++i) {
    const uint32_t r = t * kItems + uint32_t(i);
    k[i] = r < n ? keys[r] : 0;
    v[i] = r < n ? values[r] : 0;
    if (r < n) lo = min(lo, k[i]), hi = max(hi, k[i]);
  }
  lo = __reduce_min_sync(0xffffffffu, lo);
  hi = __reduce_max_sync(0xffffffffu, hi);
  if (t % 32 == 0) atomicMin(&s.key_min, lo), atomicMax(&s.key_max, hi);
  __syncthreads();
  const uint32_t differ = s.key_min ^ s.key_max;
  const int end_bit = differ == 0 ? 1 : 32 - __clz(int(differ));
  const uint32_t low = end_bit == 32 ? 0xffffffffu : (1u << end_bit) - 1u;
  const uint32_t pad = s.key_max | low;  // not below any key of the segment in bits [0, end_bit)
#pragma unroll
  for (int i = 0; i < kItems; ++i) {
    if (t * kItems + uint32_t(i) >= n) k[i] = pad;
  }
  __syncthreads();  // key_min and key_max read before the sort's storage reuses nothing of them; s.sorted after
  SegmentSort<kItems>(temp).SortBlockedToStriped(k, v, 0, end_bit);
  __syncthreads();
#pragma unroll
  for (int i = 0; i < kItems; ++i) {
    s.sorted.keys[i * kSortThreads + t] = k[i];
    s.sorted.values[i * kSortThreads + t] = v[i];
  }
}

/// A block per segment (persistent): sorts the segment's entries by (depth, id) in place and writes its pair
/// count per tile. A segment over kSegmentCapacity entries counts in *overflow and is left as it is.
__global__ void __launch_bounds__(kSortThreads, 2)
    sort_segments_kernel(const uint32_t* bucket_offsets, const uint32_t* segment_end, BinLayout layout,
                         const uint32_t* keys, uint64_t* values, uint32_t* pair_counts, uint32_t* overflow) {
  extern __shared__ __align__(16) unsigned char shared_bytes[];
  SortStorage& s = *reinterpret_cast<SortStorage*>(shared_bytes);
  const uint32_t t = threadIdx.x;
  for (uint32_t bucket = blockIdx.x; bucket < layout.buckets(); bucket += gridDim.x) {
    const uint32_t end = segment_end[bucket];
    if (end == 0) continue;
    const uint32_t begin = bucket_offsets[bucket];
    const uint32_t n = end - begin;
    if (n > kSegmentCapacity) {
      if (t == 0) atomicAdd(overflow, 1u);
      continue;
    }
    __syncthreads();  // the previous segment's last reads of s
    if (t < 32) s.tile_counts[t] = 0;
    if (t == 0) s.key_min = 0xffffffffu, s.key_max = 0;
    __syncthreads();
    if (n <= kSortThreads) {
      sort_segment<1>(s.sort1, s, keys + begin, values + begin, n);
    } else if (n <= 2 * kSortThreads) {
      sort_segment<2>(s.sort2, s, keys + begin, values + begin, n);
    } else if (n <= 4 * kSortThreads) {
      sort_segment<4>(s.sort4, s, keys + begin, values + begin, n);
    } else if (n <= 8 * kSortThreads) {
      sort_segment<8>(s.sort8, s, keys + begin, values + begin, n);
    } else {
      sort_segment<16>(s.sort16, s, keys + begin, values + begin, n);
    }
    __syncthreads();
    // Equal depths (distinct Gaussians at the same float depth) are put in id order: the thread at the start of
    // a run sorts it by insertion. Runs are short.
    for (uint32_t r = t; r + 1 < n; r += kSortThreads) {
      const uint32_t key = s.sorted.keys[r];
      if (s.sorted.keys[r + 1] != key || (r > 0 && s.sorted.keys[r - 1] == key)) continue;
      uint32_t e = r + 2;
      while (e < n && s.sorted.keys[e] == key) ++e;
      for (uint32_t a = r + 1; a < e; ++a) {
        const uint64_t x = s.sorted.values[a];
        uint32_t b = a;
        for (; b > r && s.sorted.values[b - 1] > x; --b) s.sorted.values[b] = s.sorted.values[b - 1];
        s.sorted.values[b] = x;
      }
    }
    __syncthreads();
    for (uint32_t r = t; r < n; r += kSortThreads) {
      const uint64_t x = s.sorted.values[r];
      values[begin + r] = x;
      for (uint32_t mask = uint32_t(x); mask != 0; mask &= mask - 1) atomicAdd(&s.tile_counts[__ffs(int(mask)) - 1], 1u);
    }
    __syncthreads();
    if (t < 32) pair_counts[layout.count_index(bucket, t)] = s.tile_counts[t];
  }
}

/// A block per bucket (persistent): writes the pairs of the bucket's sorted entries, 256 at a time. Tile t's
/// pairs of this bucket start at pair_offsets[count_index(bucket, t)] and follow the entries' order.
__global__ void __launch_bounds__(detail::kBlockSize)
    place_pairs_kernel(const uint32_t* bucket_offsets, const uint32_t* segment_end, BinLayout layout,
                       const uint64_t* values,
                       const uint32_t* pair_offsets, uint32_t* sorted_values) {
  constexpr int kWarps = detail::kBlockSize / 32;
  __shared__ uint32_t next[32];              // tile t's next position
  __shared__ uint32_t warp_first[kWarps][32];  // counts, then each warp's first position, per tile
  const uint32_t t = threadIdx.x, lane = t % 32, warp = t / 32;
  const uint32_t lanes_below = (1u << lane) - 1u;
  for (uint32_t bucket = blockIdx.x; bucket < layout.buckets(); bucket += gridDim.x) {
    const uint32_t end = segment_end[bucket];
    if (end == 0) continue;
    const uint32_t begin = bucket_offsets[bucket];
    const uint32_t n = end - begin;
    if (n > kSegmentCapacity) continue;
    __syncthreads();  // the previous segment's last reads of next
    if (t < 32) next[t] = pair_offsets[layout.count_index(bucket, t)];
    for (uint32_t chunk = 0; chunk < n; chunk += detail::kBlockSize) {
      const uint32_t r = chunk + t;
      const uint64_t x = r < n ? values[begin + r] : 0;
      const uint32_t mask = uint32_t(x), g = uint32_t(x >> 32);
      const uint32_t tiles = __reduce_or_sync(0xffffffffu, mask);
      warp_first[warp][lane] = 0;
      __syncwarp();
      for (uint32_t rest = tiles; rest != 0; rest &= rest - 1) {
        const int tile = __ffs(int(rest)) - 1;
        const uint32_t hits = __ballot_sync(0xffffffffu, (mask >> tile) & 1u);
        if (lane == 0) warp_first[warp][tile] = __popc(hits);
      }
      __syncthreads();
      if (t < 32) {
        uint32_t position = next[t];
        for (int w = 0; w < kWarps; ++w) {
          const uint32_t c = warp_first[w][t];
          warp_first[w][t] = position;
          position += c;
        }
        next[t] = position;
      }
      __syncthreads();
      for (uint32_t rest = tiles; rest != 0; rest &= rest - 1) {
        const int tile = __ffs(int(rest)) - 1;
        const uint32_t hits = __ballot_sync(0xffffffffu, (mask >> tile) & 1u);
        if ((mask >> tile) & 1u) sorted_values[warp_first[warp][tile] + __popc(hits & lanes_below)] = g;
      }
      __syncthreads();  // warp_first is rewritten by the next chunk
    }
  }
}

/// Tile ranges from the scanned pair counts: tile t of macro-tile m spans its slabs' pairs.
__global__ void __launch_bounds__(detail::kBlockSize)
    ranges_kernel(const uint32_t* pair_offsets, BinLayout layout, uint32_t tiles_x, uint32_t tiles, uint64_t* ranges) {
  const uint32_t tile = blockIdx.x * blockDim.x + threadIdx.x;
  if (tile >= tiles) return;
  const uint32_t tx = tile % tiles_x, ty = tile / tiles_x;
  const uint32_t macro = (ty / kMacroHeight) * layout.macros_x + tx / kMacroWidth;
  const uint32_t bit = (ty % kMacroHeight) * kMacroWidth + tx % kMacroWidth;
  const uint32_t first = (macro * 32u + bit) << layout.slab_bits;
  ranges[2 * uint64_t(tile)] = pair_offsets[first];
  ranges[2 * uint64_t(tile) + 1] = pair_offsets[first + (1u << layout.slab_bits)];
}

int bits_for(uint32_t count) {
  int bits = 0;
  while ((uint64_t{1} << bits) < count) ++bits;
  return bits;
}

#define RGS_TRY_CUDA(call)                       \
  do {                                           \
    const cudaError_t result_ = (call);          \
    if (result_ != cudaSuccess) return result_;  \
  } while (0)

class MacroTileBinning final : public kernels::PairBinning {
 public:
  cudaError_t bin(const RoofgsProjected& projected, uint32_t count, uint64_t pairs, const FrameParams& frame,
                  const RoofgsFrame& roofgs, uint64_t* ranges, const uint32_t** sorted_values,
                  cudaStream_t stream) override {
    const uint32_t macros_x = (frame.tiles_x + kMacroWidth - 1) / kMacroWidth;
    const uint32_t macros = macros_x * ((frame.tiles_y + kMacroHeight - 1) / kMacroHeight);
    const int macro_bits = bits_for(macros);
    if (macro_bits > kBucketBits - 1 || pairs >= UINT32_MAX) return cudaSuccess;  // beyond it: not exact
    BinLayout layout;
    layout.macros_x = macros_x;
    layout.slab_bits = std::min(kMaxSlabBits, kBucketBits - macro_bits);
    layout.bucket_bits = macro_bits + layout.slab_bits;
    layout.slab_shift = std::max(0, roofgs.key_depth_bits - layout.slab_bits);
    const uint32_t buckets = layout.buckets();
    const uint64_t counts = (uint64_t(buckets) << 5) + 1;  // 32 tiles a macro-tile, and the total
    // Entries: at most one a pair.
    if (!reserve(pairs, counts)) return cudaErrorMemoryAllocation;
    RGS_TRY_CUDA(cudaMemsetAsync(bucket_counts_.data(), 0, sizeof(uint32_t) * (buckets + 1), stream));
    RGS_TRY_CUDA(cudaMemsetAsync(pair_counts_.data(), 0, sizeof(uint32_t) * counts, stream));
    RGS_TRY_CUDA(cudaMemsetAsync(flags_.data(), 0, sizeof(uint32_t), stream));
    mark(0, stream);
    entries_kernel<false><<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
        projected, count, frame, roofgs, layout, bucket_counts_.data(), nullptr, nullptr);
    mark(1, stream);
    RGS_TRY_CUDA(scan(bucket_counts_.data(), bucket_offsets_.data(), buckets + 1, stream));
    RGS_TRY_CUDA(cudaMemcpyAsync(cursors_.data(), bucket_offsets_.data(), sizeof(uint32_t) * buckets,
                                 cudaMemcpyDeviceToDevice, stream));
    mark(2, stream);
    entries_kernel<true><<<detail::blocks_for(count), detail::kBlockSize, 0, stream>>>(
        projected, count, frame, roofgs, layout, cursors_.data(), keys_.data(), values_.data());
    mark(3, stream);
    segments_kernel<<<detail::blocks_for(buckets), detail::kBlockSize, 0, stream>>>(bucket_offsets_.data(), layout,
                                                                                     segment_end_.data());
    mark(4, stream);
    sort_segments_kernel<<<persistent_blocks_, kSortThreads, sizeof(SortStorage), stream>>>(
        bucket_offsets_.data(), segment_end_.data(), layout, keys_.data(), values_.data(), pair_counts_.data(),
        flags_.data());
    mark(5, stream);
    RGS_TRY_CUDA(scan(pair_counts_.data(), pair_offsets_.data(), counts, stream));
    mark(6, stream);
    place_pairs_kernel<<<persistent_blocks_ * 4, detail::kBlockSize, 0, stream>>>(
        bucket_offsets_.data(), segment_end_.data(), layout, values_.data(), pair_offsets_.data(), sorted_.data());
    const uint32_t tiles = frame.tiles_x * frame.tiles_y;
    ranges_kernel<<<detail::blocks_for(tiles), detail::kBlockSize, 0, stream>>>(pair_offsets_.data(), layout,
                                                                                 frame.tiles_x, tiles, ranges);
    mark(7, stream);
    // The check: no bucket over capacity, and every pair placed.
    RGS_TRY_CUDA(cudaMemcpyAsync(host_.data(), flags_.data(), sizeof(uint32_t), cudaMemcpyDeviceToHost, stream));
    RGS_TRY_CUDA(cudaMemcpyAsync(static_cast<uint32_t*>(host_.data()) + 1, pair_offsets_.data() + (counts - 1),
                                 sizeof(uint32_t), cudaMemcpyDeviceToHost, stream));
    expected_pairs_ = pairs;
    checked_ = true;
    *sorted_values = sorted_.data();
    return detail::launch_result();
  }

  cudaError_t last_frame_exact(bool* exact, cudaStream_t stream) override {
    *exact = false;
    if (!checked_) return cudaSuccess;
    RGS_TRY_CUDA(cudaStreamSynchronize(stream));
    const auto* host = static_cast<const uint32_t*>(host_.data());
    *exact = host[0] == 0 && host[1] == expected_pairs_;
    checked_ = false;
    if (timing_) {
      for (int i = 0; i + 1 < kMarks; ++i) {
        float ms = 0.f;
        RGS_TRY_CUDA(cudaEventElapsedTime(&ms, events_[i], events_[i + 1]));
        sums_[i] += ms;
      }
      ++frames_;
    }
    return cudaSuccess;
  }

  MacroTileBinning() : timing_(std::getenv("RGS_BINNING_TIMES") != nullptr) {
    for (cudaEvent_t& e : events_) {
      if (timing_ && cudaEventCreate(&e) != cudaSuccess) timing_ = false;
    }
  }

  /// With RGS_BINNING_TIMES set (a lab diagnostic): the mean time of each launch group over the frames.
  ~MacroTileBinning() override {
    if (!timing_) return;
    const char* names[kMarks - 1] = {"count entries", "bucket scan", "place entries", "segments", "segment sort",
                                     "pair scan", "place pairs + ranges"};
    for (int i = 0; i + 1 < kMarks; ++i) {
      std::fprintf(stderr, "binning %-22s %.4f ms (mean of %u frames)\n", names[i],
                   frames_ > 0 ? sums_[i] / frames_ : 0.0, frames_);
    }
  }

 private:
  bool reserve(uint64_t pairs, uint64_t counts) {
    const uint32_t buckets = 1u << kBucketBits;
    const bool ok = keys_.reserve(pairs, "binning keys").ok() && values_.reserve(pairs, "binning entries").ok() &&
                    sorted_.reserve(pairs, "binning pairs").ok() &&
                    bucket_counts_.reserve(buckets + 1, "bucket counts").ok() &&
                    bucket_offsets_.reserve(buckets + 1, "bucket offsets").ok() &&
                    cursors_.reserve(buckets, "bucket cursors").ok() &&
                    segment_end_.reserve(buckets, "segment ends").ok() &&
                    pair_counts_.reserve(counts, "pair counts").ok() &&
                    pair_offsets_.reserve(counts, "pair offsets").ok() && flags_.reserve(1, "binning flags").ok() &&
                    host_.reserve(2 * sizeof(uint32_t), "binning check").ok();
    if (!ok) return false;
    if (persistent_blocks_ == 0) {
      int device = 0, sms = 0;
      if (cudaGetDevice(&device) != cudaSuccess ||
          cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device) != cudaSuccess ||
          cudaFuncSetAttribute(sort_segments_kernel, cudaFuncAttributeMaxDynamicSharedMemorySize,
                               int(sizeof(SortStorage))) != cudaSuccess) {
        return false;
      }
      persistent_blocks_ = uint32_t(sms) * 2;  // sort_segments_kernel's occupancy (its launch bounds)
    }
    return true;
  }

  /// Exclusive sum of `n` counts (the last one 0, so that the last offset is the total).
  cudaError_t scan(const uint32_t* in, uint32_t* out, uint64_t n, cudaStream_t stream) {
    size_t bytes = 0;
    RGS_TRY_CUDA(cub::DeviceScan::ExclusiveSum(nullptr, bytes, in, out, n, stream));
    if (!scan_temp_.reserve(bytes, "binning scan").ok()) return cudaErrorMemoryAllocation;
    bytes = scan_temp_.bytes();
    return cub::DeviceScan::ExclusiveSum(scan_temp_.data(), bytes, in, out, n, stream);
  }

  runtime::DeviceBuffer<uint32_t> keys_, sorted_, bucket_counts_, bucket_offsets_, cursors_, segment_end_, pair_counts_,
      pair_offsets_, flags_;
  runtime::DeviceBuffer<uint64_t> values_;
  runtime::DeviceBuffer<unsigned char> scan_temp_;
  runtime::PinnedBuffer host_;
  void mark(int i, cudaStream_t stream) {
    if (timing_) cudaEventRecord(events_[i], stream);
  }

  static constexpr int kMarks = 8;
  bool timing_ = false;
  cudaEvent_t events_[kMarks] = {};
  double sums_[kMarks - 1] = {};
  uint32_t frames_ = 0;
  uint32_t persistent_blocks_ = 0;
  uint64_t expected_pairs_ = 0;
  bool checked_ = false;
};

}  // namespace

kernels::PairBinning* macro_tile_binning() {
  static MacroTileBinning binning;
  return &binning;
}

}  // namespace rgs::lab
