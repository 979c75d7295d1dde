// The GPU pipelines' shared stages: pair sort, tile ranges with depth order, tile chunk list.
#include "internal_gpu_stages.h"

#include <array>
#include <string>

#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/runtime/cuda_device.h"

namespace rgs::runtime {

Status PairSort::reserve(uint64_t pairs, bool key32, int key_bits, uint64_t at_most, cudaStream_t stream) {
  if (capacity() > at_most) release();
  const std::string count = std::to_string(pairs) + " pairs";
  Status grown = key32 ? keys32_.reserve(pairs, "GpuRenderer: keys of " + count, at_most)
                       : keys64_.reserve(pairs, "GpuRenderer: keys of " + count, at_most);
  if (grown.ok()) {
    grown = key32 ? keys32_sorted_.reserve(pairs, "GpuRenderer: sorted keys of " + count, at_most)
                  : keys64_sorted_.reserve(pairs, "GpuRenderer: sorted keys of " + count, at_most);
  }
  if (grown.ok()) grown = values_.reserve(pairs, "GpuRenderer: values of " + count, at_most);
  if (grown.ok()) grown = values_sorted_.reserve(pairs, "GpuRenderer: sorted values of " + count, at_most);
  size_t temp_bytes = 0;
  if (grown.ok()) {
    int unused = 0;
    std::array<uint32_t*, 2> keys{keys32_.data(), keys32_sorted_.data()};
    std::array<uint32_t*, 2> values{values_.data(), values_sorted_.data()};
    const cudaError_t query =
        key32 ? kernels::sort_pairs_ping_pong(nullptr, &temp_bytes, keys.data(), values.data(), values_.size(),
                                              values_.size(), 0, key_bits, false, &unused, stream)
              : kernels::sort_pairs(nullptr, &temp_bytes, keys64_.data(), keys64_sorted_.data(), values_.data(),
                                    values_sorted_.data(), values_.size(), 0, key_bits, stream);
    grown = cuda_status(query, "GpuRenderer: sort size query");
  }
  // For the pairs the buffers hold, headroom included: no more.
  if (grown.ok()) grown = temp_.reserve_exact(temp_bytes, "GpuRenderer: sort scratch");
  if (!grown.ok()) release();
  return grown;
}

Result<uint64_t> PairSort::bytes_per_pair(bool key32, int key_bits) {
  constexpr uint64_t kPairs = uint64_t{1} << 24;
  size_t temp_bytes = 0;
  int unused = 0;
  std::array<uint32_t*, 2> none{nullptr, nullptr};
  const cudaError_t query =
      key32 ? kernels::sort_pairs_ping_pong(nullptr, &temp_bytes, none.data(), none.data(), kPairs, kPairs, 0, key_bits,
                                            false, &unused, nullptr)
            : kernels::sort_pairs(nullptr, &temp_bytes, nullptr, nullptr, nullptr, nullptr, kPairs, 0, key_bits, nullptr);
  RGS_RETURN_IF_ERROR(cuda_status(query, "GpuRenderer: sort size query"));
  const uint64_t buffers = 2 * ((key32 ? sizeof(uint32_t) : sizeof(uint64_t)) + sizeof(uint32_t));
  return buffers + (temp_bytes + kPairs - 1) / kPairs;
}

void PairSort::release() {
  keys64_.release();
  keys64_sorted_.release();
  keys32_.release();
  keys32_sorted_.release();
  values_.release();
  values_sorted_.release();
  temp_.release();
}

Status PairSort::clear_counters(uint64_t capacity, int key_bits, cudaStream_t stream) {
  RGS_RETURN_IF_CUDA_ERROR(kernels::clear_sort_counters(temp_.data(), temp_.bytes(), capacity, 0, key_bits, stream),
                           "GpuRenderer: sort counters");
  return Status();
}

Status PairSort::sort(uint64_t pairs, bool key32, int key_bits, uint64_t counters, cudaStream_t stream) {
  if (pairs == 0) return Status();
  size_t temp_bytes = temp_.bytes();
  if (!key32) {
    RGS_RETURN_IF_CUDA_ERROR(kernels::sort_pairs(temp_.data(), &temp_bytes, keys64_.data(), keys64_sorted_.data(),
                                                 values_.data(), values_sorted_.data(), pairs, 0, key_bits, stream),
                             "GpuRenderer: radix sort");
    return Status();
  }
  // The ping-pong sort leaves the sorted pairs in either buffer of each pair; they are named *_sorted after.
  int sorted = 0;
  std::array<uint32_t*, 2> keys{keys32_.data(), keys32_sorted_.data()};
  std::array<uint32_t*, 2> values{values_.data(), values_sorted_.data()};
  RGS_RETURN_IF_CUDA_ERROR(kernels::sort_pairs_ping_pong(temp_.data(), &temp_bytes, keys.data(), values.data(), pairs,
                                                         counters, 0, key_bits, counters != 0, &sorted, stream),
                           "GpuRenderer: radix sort");
  if (sorted == 0) {
    std::swap(keys32_, keys32_sorted_);
    std::swap(values_, values_sorted_);
  }
  return Status();
}

uint64_t PairSort::bytes() const {
  return keys64_.bytes() + keys64_sorted_.bytes() + keys32_.bytes() + keys32_sorted_.bytes() + values_.bytes() +
         values_sorted_.bytes() + temp_.bytes();
}

Status TileRanges::reserve(uint32_t num_tiles) {
  return ranges_.reserve(size_t(num_tiles) * 2, "GpuRenderer: tile ranges");
}

Result<const uint32_t*> TileRanges::build(const PairSort& sort, uint64_t pairs, bool key32, int depth_bits,
                                          uint32_t num_tiles, const float* depths, cudaStream_t stream) {
  RGS_RETURN_IF_ERROR(reserve(num_tiles));
  if (depths != nullptr) {
    RGS_RETURN_IF_CUDA_ERROR(kernels::order_equal_keys_by_depth(sort.sorted_keys32(), sort.sorted_values(), depths,
                                                                pairs, depth_bits, num_tiles, sort.values(),
                                                                ranges_.data(), stream),
                             "GpuRenderer: depth order kernel");
    return static_cast<const uint32_t*>(sort.values());
  }
  const cudaError_t ranged =
      key32 ? kernels::tile_ranges(sort.sorted_keys32(), pairs, depth_bits, num_tiles, ranges_.data(), stream)
            : kernels::tile_ranges(sort.sorted_keys64(), pairs, 32, num_tiles, ranges_.data(), stream);
  RGS_RETURN_IF_CUDA_ERROR(ranged, "GpuRenderer: tile ranges kernel");
  return sort.sorted_values();
}

Result<kernels::TileChunks> TileChunkList::list(uint32_t chunk_pairs, uint64_t pairs,
                                                const kernels::FrameParams& frame, const uint64_t* ranges,
                                                bool with_depth, cudaStream_t stream) {
  const uint32_t num_tiles = frame.tiles_x * frame.tiles_y;
  // At most 2·2048 items (chunks hold at least 1/2048 of the pairs), in rows of tiles_x blocks.
  const uint64_t capacity = kernels::tile_chunk_capacity(pairs, chunk_pairs);
  const uint64_t item_rows = (capacity + frame.tiles_x - 1) / frame.tiles_x;
  RGS_RETURN_ERROR_IF(item_rows + frame.tiles_y > 65535, StatusCode::kLimitExceeded,
                      "GpuRenderer: " + std::to_string(capacity) + " tile chunks exceed the render grid");
  const size_t record_words = size_t(capacity) * kernels::tile_chunk_record_words(with_depth) * 128;
  RGS_RETURN_IF_ERROR(items_.reserve(capacity, "GpuRenderer: tile chunk list"));
  if (counts_.size() < 2) {
    RGS_RETURN_IF_ERROR(counts_.reserve_exact(2, "GpuRenderer: tile chunk counts"));
    RGS_RETURN_IF_CUDA_ERROR(cudaMemsetAsync(counts_.data(), 0, 2 * sizeof(uint32_t), stream),
                             "GpuRenderer: tile chunk counts");
  }
  RGS_RETURN_IF_ERROR(first_.reserve(num_tiles, "GpuRenderer: first chunk of each tile"));
  RGS_RETURN_IF_ERROR(arrivals_.reserve(num_tiles, "GpuRenderer: tile chunk arrivals"));
  RGS_RETURN_IF_ERROR(records_.reserve(record_words, "GpuRenderer: tile chunk records"));
  kernels::TileChunks chunks;
  chunks.chunk_pairs = chunk_pairs;
  chunks.capacity = uint32_t(capacity);
  chunks.item_rows = uint32_t(item_rows);
  chunks.items = items_.data();
  chunks.item_count = counts_.data() + parity_;
  chunks.next_item_count = counts_.data() + (1 - parity_);
  parity_ = 1 - parity_;
  chunks.first_item = first_.data();
  chunks.arrivals = arrivals_.data();
  chunks.records = records_.data();
  RGS_RETURN_IF_CUDA_ERROR(kernels::list_tile_chunks(ranges, num_tiles, chunks, stream),
                           "GpuRenderer: tile chunk list kernel");
  return chunks;
}

void TileChunkList::release() {
  items_.release();
  first_.release();
  arrivals_.release();
  records_.release();
  counts_.release();
  parity_ = 0;
}

uint64_t TileChunkList::max_bytes(uint32_t num_tiles, bool with_depth) {
  const uint64_t items = 2 * kernels::kTileChunksPerFrame;
  const uint64_t bytes = items * (sizeof(uint2) + uint64_t(kernels::tile_chunk_record_words(with_depth)) * 128 * 4) +
                         uint64_t(num_tiles) * 2 * sizeof(uint32_t) + 2 * sizeof(uint32_t);
  return bytes + bytes / 4;
}

uint64_t TileChunkList::bytes() const {
  return items_.bytes() + counts_.bytes() + first_.bytes() + arrivals_.bytes() + records_.bytes();
}

}  // namespace rgs::runtime
