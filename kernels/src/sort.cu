// CUB wrappers: the offset scan and the stable radix sort of the (tile, Gaussian) pairs.
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/device/dispatch/dispatch_radix_sort.cuh>

#include <algorithm>

#include "rgs/kernels/baseline_pipeline.h"

namespace rgs::kernels {
namespace {

/// CUB's policies for the RoofGS sort of 32-bit keys and values with 32-bit offsets (the onesweep radix sort
/// CUB runs on sm_89 and sm_90, 8 bits a pass), changed where H100 runs of a standalone program measured a
/// difference (docs/BENCHMARKS.md; tile-ordered keys, medians of 50), for counts whose 384-thread
/// onesweep tiles (CUB's choice for sm_90, 23 keys a thread) are more than one per SM:
/// - the digit histograms are built by 1,024-thread blocks instead of 128: the kernel runs as many blocks as
///   fit and each adds its 4 × 256 counts into the same global bins with atomics, so 8× fewer blocks make
///   8× fewer of those serialized atomics (4.17M pairs: 0.219 → 0.205 ms for the whole sort);
/// - a onesweep pass takes 512-thread tiles when those fit one per SM (1.36M pairs on 132 SMs: 154 tiles of
///   384 threads, 116 of 512; 0.107 → 0.099 ms), else 384 (2.0M: 0.122 against 0.139 ms with 512).
/// Smaller counts keep CUB's own policies (405k pairs: 0.083 ms, against 0.084 with the histogram change and
/// 0.086 with 512 threads). The other policies are CUB's; the onesweep path never runs them, but the
/// dispatch instantiates them. DispatchRadixSort and cub::detail's policy hub are those of the CCCL in CUDA
/// 13.0 (the toolkit of the build hosts); a CCCL that renames them fails to compile here, not at run time.
template <int kOnesweepThreads>
struct PairSortPolicies {
  using Cub = cub::detail::radix::policy_hub<uint32_t, uint32_t, uint32_t>::Policy900;
  struct Policy : cub::ChainedPolicy<600, Policy, Policy> {
    static constexpr bool ONESWEEP = true;
    static constexpr int ONESWEEP_RADIX_BITS = 8;
    using HistogramPolicy = cub::AgentRadixSortHistogramPolicy<1024, 8, 1, uint32_t, ONESWEEP_RADIX_BITS>;
    using ExclusiveSumPolicy = cub::AgentRadixSortExclusiveSumPolicy<256, ONESWEEP_RADIX_BITS>;
    using OnesweepPolicy =
        cub::AgentRadixSortOnesweepPolicy<kOnesweepThreads, 23, uint32_t, 1, cub::RADIX_RANK_MATCH_EARLY_COUNTS_ANY,
                                          cub::BLOCK_SCAN_RAKING_MEMOIZE, cub::RADIX_SORT_STORE_DIRECT,
                                          ONESWEEP_RADIX_BITS>;
    using ScanPolicy = Cub::ScanPolicy;
    using DownsweepPolicy = Cub::DownsweepPolicy;
    using AltDownsweepPolicy = Cub::AltDownsweepPolicy;
    using UpsweepPolicy = Cub::UpsweepPolicy;
    using AltUpsweepPolicy = Cub::AltUpsweepPolicy;
    using SingleTilePolicy = Cub::SingleTilePolicy;
    using SegmentedPolicy = Cub::SegmentedPolicy;
    using AltSegmentedPolicy = Cub::AltSegmentedPolicy;
  };
  using MaxPolicy = Policy;
};

template <int kOnesweepThreads>
cudaError_t sort_pairs32_with(void* temp, size_t* temp_bytes, cub::DoubleBuffer<uint32_t>& keys,
                              cub::DoubleBuffer<uint32_t>& values, uint32_t count, int begin_bit, int end_bit,
                              cudaStream_t stream) {
  // SortPairs' own dispatch with is_overwrite_okay: the passes alternate between the two buffers.
  using Dispatch = cub::DispatchRadixSort<cub::SortOrder::Ascending, uint32_t, uint32_t, uint32_t,
                                          cub::detail::identity_decomposer_t, PairSortPolicies<kOnesweepThreads>>;
  return Dispatch::Dispatch(temp, *temp_bytes, keys, values, count, begin_bit, end_bit, true, stream);
}

/// The policies for `count` keys: 0 (CUB's own), or the onesweep block size of PairSortPolicies.
cudaError_t policy_for(uint32_t count, int* onesweep_threads) {
  int device = 0, sms = 0;
  cudaError_t result = cudaGetDevice(&device);
  if (result == cudaSuccess) result = cudaDeviceGetAttribute(&sms, cudaDevAttrMultiProcessorCount, device);
  const auto fits_one_per_sm = [&](uint64_t block_threads) { return count <= uint64_t(sms) * block_threads * 23u; };
  *onesweep_threads = fits_one_per_sm(384) ? 0 : fits_one_per_sm(512) ? 512 : 384;
  return result;
}

}  // namespace

cudaError_t inclusive_scan(void* temp, size_t* temp_bytes, const uint64_t* in, uint64_t* out, uint32_t count,
                           cudaStream_t stream) {
  return cub::DeviceScan::InclusiveSum(temp, *temp_bytes, in, out, count, stream);
}

cudaError_t sort_pairs(void* temp, size_t* temp_bytes, const uint64_t* keys_in, uint64_t* keys_out,
                       const uint32_t* values_in, uint32_t* values_out, uint64_t count, int begin_bit,
                       int end_bit, cudaStream_t stream) {
  // The baseline's sort, as 3DGS calls it: CUB's own policies. CUB takes the item count's type as its offset
  // type; uint64_t keeps pair counts beyond 2^32 correct.
  return cub::DeviceRadixSort::SortPairs(temp, *temp_bytes, keys_in, keys_out, values_in, values_out, count,
                                         begin_bit, end_bit, stream);
}

cudaError_t sort_pairs_ping_pong(void* temp, size_t* temp_bytes, uint32_t* const keys[2], uint32_t* const values[2],
                                 uint64_t count, int begin_bit, int end_bit, int* sorted, cudaStream_t stream) {
  cub::DoubleBuffer<uint32_t> key_buffers(keys[0], keys[1]);
  cub::DoubleBuffer<uint32_t> value_buffers(values[0], values[1]);
  cudaError_t result = cudaSuccess;
  if (count > UINT32_MAX) {  // beyond 32-bit offsets: CUB's policies for 64-bit offsets
    result = cub::DeviceRadixSort::SortPairs(temp, *temp_bytes, key_buffers, value_buffers, count, begin_bit, end_bit,
                                             stream);
  } else {
    const auto n = static_cast<uint32_t>(count);
    const auto stock = [&](void* t, size_t* bytes) {
      return cub::DeviceRadixSort::SortPairs(t, *bytes, key_buffers, value_buffers, n, begin_bit, end_bit, stream);
    };
    if (temp == nullptr) {  // enough scratch for every policy, so a smaller count later may pick another
      size_t bytes[3] = {0, 0, 0};
      result = stock(nullptr, &bytes[0]);
      if (result == cudaSuccess) {
        result = sort_pairs32_with<384>(nullptr, &bytes[1], key_buffers, value_buffers, n, begin_bit, end_bit, stream);
      }
      if (result == cudaSuccess) {
        result = sort_pairs32_with<512>(nullptr, &bytes[2], key_buffers, value_buffers, n, begin_bit, end_bit, stream);
      }
      *temp_bytes = std::max({bytes[0], bytes[1], bytes[2]});
    } else {
      int threads = 0;
      result = policy_for(n, &threads);
      if (result == cudaSuccess) {
        result = threads == 0   ? stock(temp, temp_bytes)
                 : threads == 512 ? sort_pairs32_with<512>(temp, temp_bytes, key_buffers, value_buffers, n, begin_bit,
                                                           end_bit, stream)
                                  : sort_pairs32_with<384>(temp, temp_bytes, key_buffers, value_buffers, n, begin_bit,
                                                           end_bit, stream);
      }
    }
  }
  *sorted = key_buffers.selector;
  return result;
}

}  // namespace rgs::kernels
