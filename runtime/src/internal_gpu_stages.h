// The stages of the GPU pipelines, each owning its device buffers and counting their bytes: the projection
// of the Gaussians with their pair counts (emission), the pair sort, the per-tile ranges (with depth order),
// and the list of long tiles' chunks. GpuRenderer composes them with the blend (docs/RENDERER.md#the-frame-plan).
#pragma once

#include <cstdint>

#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/runtime/device_buffer.h"

namespace rgs::runtime {

/// Counts a frame reads back before its sort: its pairs and, for RoofGS, those of the Gaussians with more than
/// kernels::kSubtileLargeTiles tiles (0 for the baseline).
struct FrameCounts {
  uint64_t pairs = 0;
  uint64_t large_pairs = 0;
};

/// The emission stage's buffers: the projected Gaussians (depths, 2D means, conics, radii, colours and the tile
/// walk's inputs, [n, k] per Gaussian, sized by the scene) and the frame's pair counting: the per-Gaussian tile
/// counts and their scan, the large Gaussians' work list, the fused kernel's scratch, and the pinned words
/// through which the counts reach the host.
class GaussianProjection {
 public:
  /// The pinned count words and the event that ends a wait for the fused kernel's totals. Errors: kCudaError,
  /// kOutOfMemory.
  Status create();
  ~GaussianProjection();

  /// Arrays of the baseline pipeline for `n` Gaussians (exactly n entries).
  Status reserve_baseline(uint32_t n);
  /// Arrays of the RoofGS pipeline for `n` Gaussians; `fused`: the fused kernel's block status instead of the
  /// scan's arrays.
  Status reserve_roofgs(uint32_t n, bool fused);

  kernels::ProjectedArrays projected() const;
  kernels::RoofgsProjected roofgs_projected() const;
  const float* depths() const { return depths_.data(); }
  const uint64_t* offsets() const { return offsets_.data(); }
  unsigned long long* large_pairs() const { return large_pairs_.data(); }

  /// Inclusive scan of the tile counts into offsets(), and the pair count read back to the host (one wait),
  /// with the counter at `second` (device uint64, or null) read in the same wait.
  Result<FrameCounts> scan_and_count(uint32_t n, const void* second, cudaStream_t stream);

  /// The large Gaussians' work list of a frame of at most `max_pairs` pairs over `n` Gaussians, never longer
  /// than a pass of `limit` pairs needs (a list grown by earlier frames is given back first); capacity 0
  /// (listing off) unless `balanced`. Counted beside the fused kernel's totals when `fused`.
  Result<kernels::LargeGaussianList> large_list(uint32_t n, uint64_t max_pairs, uint64_t limit, bool balanced,
                                                bool fused);
  uint64_t large_list_bytes() const { return large_items_.bytes(); }
  /// Device counter of the large Gaussians' work items: with the fused kernel beside its totals, which its
  /// launcher zeroes together (kernels::kFusedLargeCount).
  unsigned long long* large_list_count(bool fused) const {
    return fused ? fused_total_.data() + kernels::kFusedLargeCount : large_count_.data();
  }

  /// The fused kernel's scratch, and where it publishes its totals for the host with a new sequence number.
  kernels::FusedScratch fused_scratch() const;
  Result<kernels::HostTotals> next_published_totals();
  /// Records, after the kernel that publishes the totals, the event that ends wait_for_totals() if they never
  /// come (a failed kernel).
  Status record_publisher_done(cudaStream_t stream);
  /// The fused kernel's totals once they are published with the sequence of the last next_published_totals():
  /// the host polls pinned memory while the stream's later work runs.
  Result<FrameCounts> wait_for_totals();

  uint64_t bytes() const;

 private:
  /// Per-Gaussian arrays both pipelines use: depths, 2D means, conics, radii.
  Status reserve_common(uint32_t n);
  /// The tile counts and their scan (the baseline and the separate RoofGS stages).
  Status reserve_scan(uint32_t n);
  /// Reads the uint64 at `first` and, unless null, the one at `second` from the device (waits for the stream).
  Result<FrameCounts> read_back(const void* first, const void* second, cudaStream_t stream);

  // rgb: the baseline's colours; colour_log_opacity: RoofGS's colours with ln o, [N, 4].
  DeviceBuffer<float> depths_, means2d_, conic_opacity_, rgb_, colour_log_opacity_, cov2d_, snug_t_;
  DeviceBuffer<int32_t> radii_;
  DeviceBuffer<uint32_t> depth_bins_;
  DeviceBuffer<uint64_t> tiles_touched_, offsets_;
  DeviceBuffer<uint8_t> scan_temp_;
  // Gaussians with many tiles, emitted a warp per chunk of their walks: the work list and its count.
  DeviceBuffer<kernels::LargeGaussian> large_items_;
  DeviceBuffer<unsigned long long> large_count_;
  // Pairs of the large Gaussians (separate stages; the fused kernel counts them in fused_total_[1]).
  DeviceBuffer<unsigned long long> large_pairs_;
  // Fused kernel scratch: ticket, one status word per block, pair totals (all pairs, large Gaussians' pairs).
  DeviceBuffer<uint32_t> fused_ticket_;
  DeviceBuffer<unsigned long long> fused_status_, fused_total_;
  // Counts read back from the device: the pair count, the large Gaussians' pairs, the published sequence.
  PinnedBuffer counts_;
  unsigned long long sequence_ = 0;
  cudaEvent_t publisher_done_ = nullptr;
};

/// The (key, value) pairs of a frame and their stable radix sort. Keys are 64-bit (tile << 32 | depth, the
/// baseline and key32 off) or 32-bit (runtime/depth_key.h); values are Gaussian indices. The emission writes
/// keys*() and values(); after sort() the sorted pairs are in sorted_keys*() / sorted_values(), and values()
/// is free scratch (the depth order writes its reordered values there).
class PairSort {
 public:
  /// Buffers for `pairs` pairs with `key32` keys and CUB's scratch for a `key_bits` sort of them, with
  /// headroom up to `at_most` pairs (buffers holding more are given back first). On failure every pair buffer
  /// is dropped, so the renderer stays usable for smaller frames.
  Status reserve(uint64_t pairs, bool key32, int key_bits, uint64_t at_most, cudaStream_t stream);
  /// Device bytes a pair takes in reserve()'s buffers and CUB's scratch (rounded up), for sorts of many pairs.
  static Result<uint64_t> bytes_per_pair(bool key32, int key_bits);
  /// Pairs the buffers hold now.
  uint64_t capacity() const { return values_.size(); }

  /// Zeroes the 32-bit sort's counters for up to `capacity` pairs ahead of the count (sort()'s `counters`).
  Status clear_counters(uint64_t capacity, int key_bits, cudaStream_t stream);

  /// Sorts the first `pairs` pairs by their low `key_bits` key bits, stable. `counters`: the capacity the
  /// counters were cleared for by clear_counters(), or 0 to let the sort zero them.
  Status sort(uint64_t pairs, bool key32, int key_bits, uint64_t counters, cudaStream_t stream);

  uint64_t* keys64() const { return keys64_.data(); }
  uint32_t* keys32() const { return keys32_.data(); }
  uint32_t* values() const { return values_.data(); }
  const uint64_t* sorted_keys64() const { return keys64_sorted_.data(); }
  const uint32_t* sorted_keys32() const { return keys32_sorted_.data(); }
  const uint32_t* sorted_values() const { return values_sorted_.data(); }

  uint64_t bytes() const;

 private:
  void release();
  DeviceBuffer<uint64_t> keys64_, keys64_sorted_;
  DeviceBuffer<uint32_t> keys32_, keys32_sorted_;
  DeviceBuffer<uint32_t> values_, values_sorted_;
  DeviceBuffer<uint8_t> temp_;
};

/// Per-tile [begin, end) ranges of the sorted pairs, [tiles, 2] uint64. With depth order (32-bit keys) the
/// same pass puts each run of tied keys in exact depth order.
class TileRanges {
 public:
  /// Ranges of `pairs` sorted pairs over `num_tiles` tiles; `depth_bits`: the depth field of a 32-bit key.
  /// With `depths` (per Gaussian, 32-bit keys only) the runs of tied keys are reordered by depth into
  /// sort->values(). @return the sorted values the blend reads.
  Result<const uint32_t*> build(const PairSort& sort, uint64_t pairs, bool key32, int depth_bits, uint32_t num_tiles,
                                const float* depths, cudaStream_t stream);
  /// Holds the ranges of `num_tiles` tiles (build() does too).
  Status reserve(uint32_t num_tiles);
  const uint64_t* ranges() const { return ranges_.data(); }
  uint64_t bytes() const { return ranges_.bytes(); }

 private:
  DeviceBuffer<uint64_t> ranges_;
};

/// The chunks of the long tiles, each blended by a block of its own and merged front to back
/// (kernels/shared/tile_chunks.h).
class TileChunkList {
 public:
  /// Lists the chunks of `chunk_pairs` pairs of the tiles longer than that, for a frame of `pairs` pairs.
  /// @return kLimitExceeded when the chunks exceed the render grid; kCudaError.
  Result<kernels::TileChunks> list(uint32_t chunk_pairs, uint64_t pairs, const kernels::FrameParams& frame,
                                   const uint64_t* ranges, bool with_depth, cudaStream_t stream);
  /// Device counter of the chunks the last list() found.
  const uint32_t* last_count() const { return counts_.data() + (1 - parity_); }
  uint64_t bytes() const;
  /// Gives every buffer back (the next list() allocates again).
  void release();
  /// Most bytes list() holds for frames of `num_tiles` tiles whose chunks hold at least 1/kTileChunksPerFrame
  /// of the frame's pairs (kernels::frame_chunk_pairs), headroom included.
  static uint64_t max_bytes(uint32_t num_tiles, bool with_depth);

 private:
  DeviceBuffer<uint2> items_;
  DeviceBuffer<uint32_t> first_, arrivals_, records_;
  /// Two item counts, used by alternate listings: each listing zeroes the other's (zeroed once when allocated).
  DeviceBuffer<uint32_t> counts_;
  int parity_ = 0;
};

}  // namespace rgs::runtime
