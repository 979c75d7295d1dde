// CUB wrappers: the offset scan and the stable radix sort of the (tile, Gaussian) pairs.
//
// The RoofGS sort of 32-bit keys calls CUB's public DeviceRadixSort::SortPairs, except when built against the
// CCCL it was tuned on (CCCL_VERSION 3000001: CCCL 3.0.1, the CCCL of CUDA 13.0): there it launches CUB's
// internal onesweep kernels itself, with larger blocks for large counts and counters zeroed ahead of the sort
// (below). Those kernels, their argument lists and the policy hub are CUB internals that another CCCL may
// rename or change, so any other version takes the public path, which sorts to the same result (a stable
// sort's output is unique). Compiling with -DRGS_PUBLIC_CUB_SORT takes the public path on CCCL 3.0.1 too.
#include <cub/device/device_radix_sort.cuh>
#include <cub/device/device_scan.cuh>
#include <cub/version.cuh>

#include <algorithm>
#include <cstdint>

#include "rgs/kernels/baseline_pipeline.h"

#if defined(CCCL_VERSION) && CCCL_VERSION == 3000001 && !defined(RGS_PUBLIC_CUB_SORT)
#define RGS_TUNED_ONESWEEP 1
#include <cub/device/dispatch/dispatch_radix_sort.cuh>
#else
#define RGS_TUNED_ONESWEEP 0
#endif

namespace rgs::kernels {
namespace {

/// CUB's public sort of the pairs in `keys` / `values` (DoubleBuffer, overwrite allowed: the sorted pairs end
/// in the buffers the selectors name), with 32-bit offsets up to 2^32 − 1 pairs.
cudaError_t sort_public(void* temp, size_t* temp_bytes, cub::DoubleBuffer<uint32_t>& keys,
                        cub::DoubleBuffer<uint32_t>& values, uint64_t count, int begin_bit, int end_bit,
                        cudaStream_t stream) {
  if (count <= UINT32_MAX) {
    return cub::DeviceRadixSort::SortPairs(temp, *temp_bytes, keys, values, uint32_t(count), begin_bit, end_bit,
                                           stream);
  }
  return cub::DeviceRadixSort::SortPairs(temp, *temp_bytes, keys, values, count, begin_bit, end_bit, stream);
}

/// Scratch of sort_public for every count up to `count` (counts up to 2^32 − 1 take 32-bit offsets, larger
/// ones 64-bit offsets, so a larger count's size need not cover a smaller count's).
cudaError_t public_bytes(uint64_t count, int begin_bit, int end_bit, size_t* bytes) {
  cub::DoubleBuffer<uint32_t> none;
  *bytes = 0;
  size_t narrow = 0;
  cudaError_t result = sort_public(nullptr, &narrow, none, none, std::min<uint64_t>(count, UINT32_MAX), begin_bit,
                                   end_bit, nullptr);
  size_t wide = 0;
  if (result == cudaSuccess && count > UINT32_MAX) {
    result = sort_public(nullptr, &wide, none, none, count, begin_bit, end_bit, nullptr);
  }
  if (result == cudaSuccess) *bytes = std::max(narrow, wide);
  return result;
}

#if RGS_TUNED_ONESWEEP
/// CUB's policies for the RoofGS sort of 32-bit keys and values with 32-bit offsets (the onesweep radix sort
/// CUB runs on sm_89 and sm_90, 8 bits a pass), changed where H100 runs of a standalone program measured a
/// difference (docs/lab/TRIED.md#tried-and-not-kept; tile-ordered keys), for counts whose 384-thread
/// onesweep tiles (CUB's choice for sm_90, 23 keys a thread) are more than one per SM:
/// - the digit histograms are built by 1,024-thread blocks instead of 128: the kernel runs as many blocks as
///   fit and each adds its 4 × 256 counts into the same global bins with atomics, so 8× fewer blocks make
///   8× fewer of those serialized atomics;
/// - a onesweep pass takes 512-thread tiles when those fit one per SM (1.36M pairs on 132 SMs: 154 tiles of
///   384 threads, 116 of 512), else 384.
/// Smaller counts keep CUB's own sm_90 policies. The kernels (cub::detail::radix_sort), their argument lists
/// and the policy hub are those of CCCL 3.0.1, the only version this path is compiled for (top of the file).
template <typename Onesweep, typename Histogram>
struct PairSortPolicies {
  /// The policies CUB's histogram, exclusive-sum and onesweep kernels read (the same for every architecture).
  struct Policy : cub::ChainedPolicy<600, Policy, Policy> {
    static constexpr int ONESWEEP_RADIX_BITS = 8;
    using HistogramPolicy = Histogram;
    using ExclusiveSumPolicy = cub::AgentRadixSortExclusiveSumPolicy<256, ONESWEEP_RADIX_BITS>;
    using OnesweepPolicy = Onesweep;
  };
  using MaxPolicy = Policy;
};

constexpr int kRadixBits = 8;
constexpr int kDigits = 1 << kRadixBits;
using Cub900 = cub::detail::radix::policy_hub<uint32_t, uint32_t, uint32_t>::Policy900;
template <int kThreads>
using TunedOnesweep =
    cub::AgentRadixSortOnesweepPolicy<kThreads, 23, uint32_t, 1, cub::RADIX_RANK_MATCH_EARLY_COUNTS_ANY,
                                      cub::BLOCK_SCAN_RAKING_MEMOIZE, cub::RADIX_SORT_STORE_DIRECT, kRadixBits>;
using TunedHistogram = cub::AgentRadixSortHistogramPolicy<1024, 8, 1, uint32_t, kRadixBits>;
using Tuned384 = PairSortPolicies<TunedOnesweep<384>, TunedHistogram>;
using Tuned512 = PairSortPolicies<TunedOnesweep<512>, TunedHistogram>;
using Stock = PairSortPolicies<Cub900::OnesweepPolicy, Cub900::HistogramPolicy>;
static_assert(Cub900::ONESWEEP_RADIX_BITS == kRadixBits, "CUB's sm_90 onesweep takes 8 bits a pass");

template <typename Policies>
constexpr int onesweep_tile_items() {
  using P = typename Policies::Policy::OnesweepPolicy;
  return P::BLOCK_THREADS * P::ITEMS_PER_THREAD;
}
/// The smallest onesweep tile of the three policies: the most tiles, hence lookback rows, a count can need.
constexpr int kMinTileItems =
    std::min({onesweep_tile_items<Stock>(), onesweep_tile_items<Tuned384>(), onesweep_tile_items<Tuned512>()});
/// CUB sorts more items than its PORTION_SIZE, 2^28 − 1 rounded down to whole tiles, in portions; up to this
/// many, one portion does, which is what sort_onesweep launches.
constexpr uint64_t kMaxOnePortion = (uint64_t{1} << 28) - 16384;

/// The zero-initialised counters of the onesweep passes at the start of the scratch, as CUB's InvokeOnesweep
/// lays out its own: digit counts [passes][256] (turned into digit offsets by the exclusive-sum kernel), a
/// tile ticket per pass, and, unlike CUB, which zeroes one lookback array before each pass, a lookback
/// array [tiles][256] per pass, so that one memset ahead of the sort serves every pass.
struct CounterLayout {
  int passes = 0;
  uint64_t max_tiles = 0;
  uint32_t* bins(void* temp) const { return static_cast<uint32_t*>(temp); }
  int* tickets(void* temp) const { return reinterpret_cast<int*>(bins(temp) + size_t(passes) * kDigits); }
  int* lookback(void* temp, int pass) const {
    return tickets(temp) + passes + size_t(pass) * max_tiles * kDigits;
  }
  size_t bytes() const { return sizeof(int) * size_t(passes) * (kDigits + 1 + max_tiles * kDigits); }
};

int passes_for(int begin_bit, int end_bit) {
  return end_bit > begin_bit ? (end_bit - begin_bit + kRadixBits - 1) / kRadixBits : 0;
}

/// The layout for sorts of up to `count` pairs (a sort of fewer pairs on it uses the first lookback rows of
/// each pass). Only sorts of one portion take the tuned path, so a larger count needs no more than one portion's.
CounterLayout layout_for_count(uint64_t count, int begin_bit, int end_bit) {
  const uint64_t tuned = std::min(count, kMaxOnePortion);
  return CounterLayout{passes_for(begin_bit, end_bit), (tuned + kMinTileItems - 1) / kMinTileItems};
}

/// DispatchRadixSort::InvokeOnesweep for one portion with overwrite allowed, on counters already zeroed: the
/// histogram kernel, the exclusive sum, then one onesweep kernel per pass, CUB's own kernels with `Policies`.
/// No memset and no occupancy query between the launches (the histogram kernel's occupancy is asked once).
template <typename Policies>
cudaError_t sort_onesweep(void* temp, const CounterLayout& layout, cub::DoubleBuffer<uint32_t>& keys,
                          cub::DoubleBuffer<uint32_t>& values, uint32_t count, int begin_bit, int end_bit, int sms,
                          cudaStream_t stream) {
  using MaxPolicy = typename Policies::MaxPolicy;
  using Active = typename Policies::Policy;
  constexpr auto kOrder = cub::SortOrder::Ascending;
  namespace radix = cub::detail::radix_sort;
  const auto histogram = radix::DeviceRadixSortHistogramKernel<MaxPolicy, kOrder, uint32_t, uint32_t>;
  const auto exclusive_sum = radix::DeviceRadixSortExclusiveSumKernel<MaxPolicy, uint32_t>;
  const auto onesweep = radix::DeviceRadixSortOnesweepKernel<MaxPolicy, kOrder, uint32_t, uint32_t, uint32_t, int, int>;
  constexpr int kHistogramThreads = Active::HistogramPolicy::BLOCK_THREADS;
  constexpr int kTileItems = onesweep_tile_items<Policies>();
  static const int histogram_blocks_per_sm = [&] {
    int blocks = 1;
    return cudaOccupancyMaxActiveBlocksPerMultiprocessor(&blocks, histogram, kHistogramThreads, 0) == cudaSuccess
               ? blocks
               : 1;
  }();
  const int tiles = int((uint64_t(count) + kTileItems - 1) / kTileItems);
  uint32_t* bins = layout.bins(temp);
  histogram<<<histogram_blocks_per_sm * sms, kHistogramThreads, 0, stream>>>(bins, keys.Current(), count, begin_bit,
                                                                               end_bit, {});
  exclusive_sum<<<layout.passes, Active::ExclusiveSumPolicy::BLOCK_THREADS, 0, stream>>>(bins);
  for (int pass = 0, bit = begin_bit; bit < end_bit; ++pass, bit += kRadixBits) {
    onesweep<<<tiles, Active::OnesweepPolicy::BLOCK_THREADS, 0, stream>>>(
        layout.lookback(temp, pass), layout.tickets(temp) + pass, nullptr, bins + size_t(pass) * kDigits,
        keys.Alternate(), keys.Current(), values.Alternate(), values.Current(), int(count), bit,
        std::min(end_bit - bit, kRadixBits), {});
    keys.selector ^= 1;
    values.selector ^= 1;
  }
  return cudaGetLastError();
}

/// The current device's SM count.
cudaError_t multiprocessors(int* sms) {
  int device = 0;
  const cudaError_t result = cudaGetDevice(&device);
  return result == cudaSuccess ? cudaDeviceGetAttribute(sms, cudaDevAttrMultiProcessorCount, device) : result;
}

/// The onesweep block size for `count` pairs on `sms` SMs (0: CUB's own sm_90 policy, Stock).
int policy_for(uint32_t count, int sms) {
  const auto fits_one_per_sm = [&](uint64_t block_threads) { return count <= uint64_t(sms) * block_threads * 23u; };
  return fits_one_per_sm(384) ? 0 : fits_one_per_sm(512) ? 512 : 384;
}
#endif  // RGS_TUNED_ONESWEEP

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

bool sort_pairs_ping_pong_tuned() { return RGS_TUNED_ONESWEEP != 0; }

cudaError_t sort_pairs_ping_pong(void* temp, size_t* temp_bytes, uint32_t* const keys[2], uint32_t* const values[2],
                                 uint64_t count, uint64_t counters_capacity, int begin_bit, int end_bit,
                                 bool counters_zeroed, int* sorted, cudaStream_t stream) {
  cub::DoubleBuffer<uint32_t> key_buffers(keys[0], keys[1]);
  cub::DoubleBuffer<uint32_t> value_buffers(values[0], values[1]);
  cudaError_t result = cudaSuccess;
  if (temp == nullptr) {  // enough for the public sort and, on the tuned path, for sort_onesweep's counters
    result = public_bytes(count, begin_bit, end_bit, temp_bytes);
#if RGS_TUNED_ONESWEEP
    if (result == cudaSuccess) *temp_bytes = std::max(*temp_bytes, layout_for_count(count, begin_bit, end_bit).bytes());
#endif
    return result;
  }
  *sorted = 0;
  if (count <= 1 || end_bit <= begin_bit) return cudaSuccess;
  if (counters_zeroed && counters_capacity < count) return cudaErrorInvalidValue;
#if RGS_TUNED_ONESWEEP
  if (count <= kMaxOnePortion) {
    const CounterLayout layout = layout_for_count(std::max(count, counters_capacity), begin_bit, end_bit);
    if (layout.bytes() > *temp_bytes) return cudaErrorInvalidValue;
    if (!counters_zeroed) result = cudaMemsetAsync(temp, 0, layout.bytes(), stream);
    int sms = 0;
    if (result == cudaSuccess) result = multiprocessors(&sms);
    if (result != cudaSuccess) return result;
    const int threads = policy_for(uint32_t(count), sms);
    const auto n = uint32_t(count);
    const auto sort = [&](auto policies) {
      return sort_onesweep<decltype(policies)>(temp, layout, key_buffers, value_buffers, n, begin_bit, end_bit, sms,
                                                stream);
    };
    result = threads == 0 ? sort(Stock{}) : threads == 512 ? sort(Tuned512{}) : sort(Tuned384{});
    *sorted = key_buffers.selector;
    return result;
  }
#endif
  // CUB's own dispatch, memsets included (cudaErrorInvalidValue when *temp_bytes is too small).
  result = sort_public(temp, temp_bytes, key_buffers, value_buffers, count, begin_bit, end_bit, stream);
  *sorted = key_buffers.selector;
  return result;
}

cudaError_t clear_sort_counters(void* temp, size_t temp_bytes, uint64_t capacity, int begin_bit, int end_bit,
                                cudaStream_t stream) {
#if RGS_TUNED_ONESWEEP
  // Every sort of up to `capacity` pairs that takes the tuned path reads these counters (laid out for capacity).
  const CounterLayout layout = layout_for_count(capacity, begin_bit, end_bit);
  if (layout.bytes() > temp_bytes) return cudaErrorInvalidValue;
  return layout.bytes() == 0 ? cudaSuccess : cudaMemsetAsync(temp, 0, layout.bytes(), stream);
#else
  // The public sort zeroes its own counters: only the size is checked.
  (void)temp;
  (void)stream;
  size_t needed = 0;
  const cudaError_t result = public_bytes(capacity, begin_bit, end_bit, &needed);
  return result != cudaSuccess ? result : needed > temp_bytes ? cudaErrorInvalidValue : cudaSuccess;
#endif
}

}  // namespace rgs::kernels
