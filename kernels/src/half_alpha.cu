// half2_alpha on the device for given powers (half_alpha.h).
#include "launch_util.cuh"
#include "rgs/kernels/half_alpha.h"
#include "rgs/kernels/shared/half_blend.h"

namespace rgs::kernels {
namespace {

__global__ void half_alpha_kernel(const float2* powers, uint32_t* out, uint64_t pairs) {
  const uint64_t i = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < pairs) out[i] = half2_alpha(powers[i].x, powers[i].y);
}

}  // namespace

cudaError_t device_half_alpha(const float* powers, uint32_t* out, uint64_t pairs, cudaStream_t stream) {
  if (pairs == 0) return cudaSuccess;
  half_alpha_kernel<<<detail::blocks_for(pairs), detail::kBlockSize, 0, stream>>>(
      reinterpret_cast<const float2*>(powers), out, pairs);
  return detail::launch_result();
}

}  // namespace rgs::kernels
