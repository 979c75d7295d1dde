// CUB wrappers: the offset scan and the stable radix sort of the (tile, Gaussian) pairs.
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>

#include "rgs/kernels/baseline_pipeline.h"

namespace rgs::kernels {
namespace {

template <typename Key>
cudaError_t sort_pairs_impl(void* temp, size_t* temp_bytes, const Key* keys_in, Key* keys_out,
                            const uint32_t* values_in, uint32_t* values_out, uint64_t count, int begin_bit,
                            int end_bit, cudaStream_t stream) {
  // CUB takes the item count as a template type: uint64_t keeps pair counts beyond 2^31 correct.
  return cub::DeviceRadixSort::SortPairs(temp, *temp_bytes, keys_in, keys_out, values_in, values_out, count,
                                         begin_bit, end_bit, stream);
}

}  // namespace

cudaError_t inclusive_scan(void* temp, size_t* temp_bytes, const uint64_t* in, uint64_t* out, uint32_t count,
                           cudaStream_t stream) {
  return cub::DeviceScan::InclusiveSum(temp, *temp_bytes, in, out, count, stream);
}

cudaError_t sort_pairs(void* temp, size_t* temp_bytes, const uint64_t* keys_in, uint64_t* keys_out,
                       const uint32_t* values_in, uint32_t* values_out, uint64_t count, int begin_bit,
                       int end_bit, cudaStream_t stream) {
  return sort_pairs_impl(temp, temp_bytes, keys_in, keys_out, values_in, values_out, count, begin_bit, end_bit,
                         stream);
}

cudaError_t sort_pairs(void* temp, size_t* temp_bytes, const uint32_t* keys_in, uint32_t* keys_out,
                       const uint32_t* values_in, uint32_t* values_out, uint64_t count, int begin_bit,
                       int end_bit, cudaStream_t stream) {
  return sort_pairs_impl(temp, temp_bytes, keys_in, keys_out, values_in, values_out, count, begin_bit, end_bit,
                         stream);
}

}  // namespace rgs::kernels
