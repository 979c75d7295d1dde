// The device's binary16 exp2 over every pattern (half_exp2.h).
#include "launch_util.cuh"
#include "rgs/kernels/half_exp2.h"
#include "rgs/kernels/shared/half_blend.h"

namespace rgs::kernels {
namespace {

/// Thread i evaluates the patterns 2i (low half) and 2i + 1 (high half) with one half2_exp2.
__global__ void half_exp2_table_kernel(uint32_t* out) {
  const uint32_t i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < kHalfPatterns / 2) out[i] = half2_exp2((2 * i) | ((2 * i + 1) << 16));
}

}  // namespace

cudaError_t device_half_exp2_table(uint16_t* out, cudaStream_t stream) {
  constexpr uint32_t kThreads = 256;
  // Little-endian: the word of thread i holds patterns 2i and 2i + 1 at out[2i] and out[2i + 1].
  half_exp2_table_kernel<<<kHalfPatterns / 2 / kThreads, kThreads, 0, stream>>>(reinterpret_cast<uint32_t*>(out));
  return detail::launch_result();
}

}  // namespace rgs::kernels
