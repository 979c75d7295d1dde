// Exact depth order after the 32-bit pair sort (order_equal_keys_by_depth): pairs whose keys tie (same tile,
// same depth bin) come out of the stable sort in emission order, i.e. by Gaussian index; this pass puts each
// such run in (view depth, index) order, which is the order of the baseline's 64-bit key.
#include "launch_util.cuh"
#include "rgs/kernels/roofgs_pipeline.h"

namespace rgs::kernels {
namespace {

/// Thread p moves pair p. A pair alone in its key goes straight through; a pair in a run [a, b) of equal
/// keys goes to a + its rank in the run under (depth, index), counted over the run (O(run length) per pair,
/// as the render's own loop over the tile's pairs).
__global__ void order_equal_keys_kernel(const uint32_t* __restrict__ keys, const uint32_t* __restrict__ values_in,
                                        const float* __restrict__ depths, uint64_t count,
                                        uint32_t* __restrict__ values_out) {
  const uint64_t p = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (p >= count) return;
  const uint32_t key = keys[p];
  const uint32_t g = values_in[p];
  const bool tied_before = p > 0 && keys[p - 1] == key;
  const bool tied_after = p + 1 < count && keys[p + 1] == key;
  if (!tied_before && !tied_after) {
    values_out[p] = g;
    return;
  }
  uint64_t a = p, b = p + 1;
  while (a > 0 && keys[a - 1] == key) --a;
  while (b < count && keys[b] == key) ++b;
  const float depth = depths[g];
  uint64_t rank = 0;
  for (uint64_t j = a; j < b; ++j) {
    const uint32_t other = values_in[j];
    const float other_depth = depths[other];
    rank += (other_depth < depth || (other_depth == depth && other < g)) ? 1u : 0u;
  }
  values_out[a + rank] = g;
}

}  // namespace

cudaError_t order_equal_keys_by_depth(const uint32_t* sorted_keys, const uint32_t* sorted_values,
                                      const float* depths, uint64_t count, uint32_t* values_out,
                                      cudaStream_t stream) {
  if (count == 0) return cudaSuccess;
  const uint64_t blocks = (count + detail::kBlockSize - 1) / detail::kBlockSize;
  order_equal_keys_kernel<<<unsigned(blocks), detail::kBlockSize, 0, stream>>>(sorted_keys, sorted_values, depths,
                                                                               count, values_out);
  return detail::launch_result();
}

}  // namespace rgs::kernels
