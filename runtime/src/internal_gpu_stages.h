// The stages after pair emission that the GPU pipelines share, each owning its device buffers and counting
// their bytes: the pair sort, the per-tile ranges (with depth order), and the list of long tiles' chunks.
// GpuRenderer composes them with its preprocess and blend (docs/RENDERER.md#the-frame-plan).
#pragma once

#include <cstdint>

#include "rgs/kernels/roofgs_pipeline.h"
#include "rgs/kernels/shared/tile_chunks.h"
#include "rgs/runtime/device_buffer.h"

namespace rgs::runtime {

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
