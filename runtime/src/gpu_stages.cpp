// The GPU pipelines' stages: the projection with its pair counts, pair sort, tile ranges with depth order,
// tile chunk list.
#include "internal_gpu_stages.h"

#include <array>
#include <atomic>
#include <string>

#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/runtime/cuda_device.h"

namespace rgs::runtime {

Status GaussianProjection::create() {
  RGS_RETURN_IF_ERROR(counts_.reserve(3 * sizeof(uint64_t), "GpuRenderer: pair count", cudaHostAllocMapped));
  RGS_RETURN_IF_CUDA_ERROR(cudaEventCreateWithFlags(&publisher_done_, cudaEventDisableTiming),
                           "GpuRenderer: cudaEventCreateWithFlags");
  return Status();
}

GaussianProjection::~GaussianProjection() {
  if (publisher_done_ != nullptr) cudaEventDestroy(publisher_done_);
}

Status GaussianProjection::reserve_common(uint32_t n) {
  RGS_RETURN_IF_ERROR(depths_.reserve_exact(n, "GpuRenderer: depths"));
  RGS_RETURN_IF_ERROR(means2d_.reserve_exact(size_t(n) * 2, "GpuRenderer: 2D means"));
  RGS_RETURN_IF_ERROR(conic_opacity_.reserve_exact(size_t(n) * 4, "GpuRenderer: conics"));
  return radii_.reserve_exact(n, "GpuRenderer: radii");
}

Status GaussianProjection::reserve_scan(uint32_t n) {
  RGS_RETURN_IF_ERROR(tiles_touched_.reserve_exact(n, "GpuRenderer: tiles touched"));
  return offsets_.reserve_exact(n, "GpuRenderer: pair offsets");
}

Status GaussianProjection::reserve_baseline(uint32_t n) {
  RGS_RETURN_IF_ERROR(reserve_common(n));
  RGS_RETURN_IF_ERROR(reserve_scan(n));
  return rgb_.reserve_exact(size_t(n) * 3, "GpuRenderer: colours");
}

Status GaussianProjection::reserve_roofgs(uint32_t n, bool fused) {
  RGS_RETURN_IF_ERROR(reserve_common(n));
  if (fused) {
    RGS_RETURN_IF_ERROR(fused_ticket_.reserve(1, "GpuRenderer: fused ticket"));
    RGS_RETURN_IF_ERROR(fused_status_.reserve(kernels::fused_blocks(n), "GpuRenderer: fused block status"));
  } else {
    RGS_RETURN_IF_ERROR(reserve_scan(n));  // the fused kernel allocates its pairs itself
  }
  RGS_RETURN_IF_ERROR(colour_log_opacity_.reserve_exact(size_t(n) * 4, "GpuRenderer: colours and log opacities"));
  RGS_RETURN_IF_ERROR(large_pairs_.reserve(1, "GpuRenderer: large Gaussian pairs"));
  // The tile walk's inputs (every visible Gaussian with separate stages, the large ones when fused).
  RGS_RETURN_IF_ERROR(cov2d_.reserve_exact(size_t(n) * 3, "GpuRenderer: 2D covariances"));
  RGS_RETURN_IF_ERROR(snug_t_.reserve_exact(n, "GpuRenderer: SnugBox thresholds"));
  RGS_RETURN_IF_ERROR(depth_bins_.reserve_exact(n, "GpuRenderer: depth bins"));
  RGS_RETURN_IF_ERROR(large_count_.reserve(1, "GpuRenderer: large Gaussian count"));
  return fused_total_.reserve(kernels::kFusedTotals, "GpuRenderer: fused pair totals");
}

kernels::ProjectedArrays GaussianProjection::projected() const {
  kernels::ProjectedArrays p;
  p.depths = depths_.data();
  p.means2d = means2d_.data();
  p.conic_opacity = conic_opacity_.data();
  p.rgb = rgb_.data();
  p.radii = radii_.data();
  p.tiles_touched = tiles_touched_.data();
  return p;
}

kernels::RoofgsProjected GaussianProjection::roofgs_projected() const {
  kernels::RoofgsProjected p;
  p.depths = depths_.data();
  p.means2d = means2d_.data();
  p.conic_opacity = conic_opacity_.data();
  p.colour_log_opacity = colour_log_opacity_.data();
  p.cov2d = cov2d_.data();
  p.snug_t = snug_t_.data();
  p.radii = radii_.data();
  p.depth_bins = depth_bins_.data();
  p.tiles_touched = tiles_touched_.data();
  return p;
}

Result<FrameCounts> GaussianProjection::scan_and_count(uint32_t n, const void* second, cudaStream_t stream) {
  size_t scan_bytes = 0;
  RGS_RETURN_IF_CUDA_ERROR(kernels::inclusive_scan(nullptr, &scan_bytes, tiles_touched_.data(), offsets_.data(), n,
                                                   stream),
                           "GpuRenderer: scan size query");
  RGS_RETURN_IF_ERROR(scan_temp_.reserve(scan_bytes, "GpuRenderer: scan scratch"));
  scan_bytes = scan_temp_.bytes();
  RGS_RETURN_IF_CUDA_ERROR(kernels::inclusive_scan(scan_temp_.data(), &scan_bytes, tiles_touched_.data(),
                                                   offsets_.data(), n, stream),
                           "GpuRenderer: offset scan");
  return read_back(offsets_.data() + (n - 1), second, stream);
}

Result<FrameCounts> GaussianProjection::read_back(const void* first, const void* second, cudaStream_t stream) {
  auto* host = static_cast<uint64_t*>(counts_.data());
  host[1] = 0;
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host, first, sizeof(uint64_t), cudaMemcpyDeviceToHost, stream),
                           "GpuRenderer: pair count read-back");
  if (second != nullptr) {
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host + 1, second, sizeof(uint64_t), cudaMemcpyDeviceToHost, stream),
                             "GpuRenderer: pair count read-back");
  }
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "GpuRenderer: preprocess");
  return FrameCounts{host[0], host[1]};
}

Result<kernels::LargeGaussianList> GaussianProjection::large_list(uint32_t n, uint64_t max_pairs, uint64_t limit,
                                                                  bool balanced, bool fused) {
  unsigned long long* const count = large_list_count(fused);
  if (!balanced) return kernels::LargeGaussianList{nullptr, count, 0};
  const uint64_t capacity = kernels::large_list_capacity(n, max_pairs);
  const uint64_t most = kernels::large_list_capacity(n, limit);
  if (large_items_.size() > most) large_items_.release();
  RGS_RETURN_IF_ERROR(large_items_.reserve(capacity, "GpuRenderer: large Gaussian list", most));
  return kernels::LargeGaussianList{large_items_.data(), count, capacity};
}

kernels::FusedScratch GaussianProjection::fused_scratch() const {
  return kernels::FusedScratch{fused_ticket_.data(), fused_status_.data(), fused_total_.data()};
}

Result<kernels::HostTotals> GaussianProjection::next_published_totals() {
  RGS_ASSIGN_OR_RETURN(void* const host, counts_.device_pointer());
  return kernels::HostTotals{fused_total_.data(), static_cast<volatile unsigned long long*>(host), ++sequence_};
}

Status GaussianProjection::record_publisher_done(cudaStream_t stream) {
  RGS_RETURN_IF_CUDA_ERROR(cudaEventRecord(publisher_done_, stream), "GpuRenderer: cudaEventRecord");
  return Status();
}

Result<FrameCounts> GaussianProjection::wait_for_totals() {
  const auto* host = static_cast<volatile unsigned long long*>(counts_.data());
  while (host[2] != sequence_) {
    const cudaError_t ended = cudaEventQuery(publisher_done_);
    if (ended == cudaErrorNotReady) continue;
    RGS_RETURN_IF_CUDA_ERROR(ended, "GpuRenderer: preprocess");
    RGS_RETURN_ERROR_IF(host[2] != sequence_, StatusCode::kCudaError,
                        "GpuRenderer: the fused kernel ended without publishing its pair count");
  }
  std::atomic_thread_fence(std::memory_order_acquire);
  return FrameCounts{host[0], host[1]};
}

uint64_t GaussianProjection::bytes() const {
  return depths_.bytes() + means2d_.bytes() + conic_opacity_.bytes() + rgb_.bytes() + colour_log_opacity_.bytes() +
         cov2d_.bytes() + snug_t_.bytes() + radii_.bytes() + depth_bins_.bytes() + tiles_touched_.bytes() +
         offsets_.bytes() + scan_temp_.bytes() + large_items_.bytes() + large_count_.bytes() + large_pairs_.bytes() +
         fused_ticket_.bytes() + fused_status_.bytes() + fused_total_.bytes();
}

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
