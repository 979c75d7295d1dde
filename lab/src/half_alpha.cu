// half2_alpha on the device for given powers (rgs/lab/half_alpha.h).
#include "launch_util.cuh"
#include "rgs/kernels/shared/half_blend.h"
#include "rgs/lab/half_alpha.h"

namespace rgs::lab {
namespace {

__global__ void half_alpha_kernel(const float2* powers, uint32_t* out, uint64_t pairs) {
  const uint64_t i = uint64_t(blockIdx.x) * blockDim.x + threadIdx.x;
  if (i < pairs) out[i] = kernels::half2_alpha(powers[i].x, powers[i].y);
}

}  // namespace

cudaError_t device_half_alpha(const float* powers, uint32_t* out, uint64_t pairs, cudaStream_t stream) {
  if (pairs == 0) return cudaSuccess;
  half_alpha_kernel<<<kernels::detail::blocks_for(pairs), kernels::detail::kBlockSize, 0, stream>>>(
      reinterpret_cast<const float2*>(powers), out, pairs);
  return kernels::detail::launch_result();
}

}  // namespace rgs::lab
