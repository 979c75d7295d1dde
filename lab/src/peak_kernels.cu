// The FP32 and half2 FMA loops of the device-peak measurement (internal_peak_kernels.h).
#include <cuda_fp16.h>

#include "launch_util.cuh"
#include "internal_peak_kernels.h"

namespace rgs::lab {
namespace {

constexpr uint32_t kMaxThreadsPerBlock = 1024;

/// kFmaPeakChains independent chains per thread, so consecutive FMAs of one warp never depend on each other
/// and the FP32 pipes stay busy. The launch bound lets the compiler keep every chain in registers at the
/// largest block size; __fmaf_rn because --fmad=false would otherwise leave a*b + c as a mul and an add.
__global__ void __launch_bounds__(kMaxThreadsPerBlock)
    fma_peak_kernel(float* __restrict__ out, uint32_t iterations, float mul, float add) {
  const uint32_t thread = blockIdx.x * blockDim.x + threadIdx.x;
  float a[kFmaPeakChains];
#pragma unroll
  for (uint32_t k = 0; k < kFmaPeakChains; ++k) a[k] = float(thread & 0xffu) * 1e-3f + float(k);
#pragma unroll 4
  for (uint32_t i = 0; i < iterations; ++i) {
#pragma unroll
    for (uint32_t k = 0; k < kFmaPeakChains; ++k) a[k] = __fmaf_rn(a[k], mul, add);
  }
  float sum = 0.f;
#pragma unroll
  for (uint32_t k = 0; k < kFmaPeakChains; ++k) sum += a[k];
  out[thread] = sum;
}

/// The same loop in binary16 pairs: each __hfma2 is two FMAs (the half2 rate of the blend in binary16).
__global__ void __launch_bounds__(kMaxThreadsPerBlock)
    hfma2_peak_kernel(float* __restrict__ out, uint32_t iterations, float mul, float add) {
  const uint32_t thread = blockIdx.x * blockDim.x + threadIdx.x;
  const __half2 m = __float2half2_rn(mul), c = __float2half2_rn(add);
  __half2 a[kFmaPeakChains];
#pragma unroll
  for (uint32_t k = 0; k < kFmaPeakChains; ++k) a[k] = __float2half2_rn(float(thread & 0xfu) * 1e-2f + float(k));
#pragma unroll 4
  for (uint32_t i = 0; i < iterations; ++i) {
#pragma unroll
    for (uint32_t k = 0; k < kFmaPeakChains; ++k) a[k] = __hfma2(a[k], m, c);
  }
  float sum = 0.f;
#pragma unroll
  for (uint32_t k = 0; k < kFmaPeakChains; ++k) sum += __low2float(a[k]) + __high2float(a[k]);
  out[thread] = sum;
}

bool valid_block_size(uint32_t threads) { return threads >= 32 && threads <= kMaxThreadsPerBlock && threads % 32 == 0; }

}  // namespace

cudaError_t fma_peak_blocks_per_sm(uint32_t threads_per_block, int* blocks_per_sm) {
  if (blocks_per_sm == nullptr || !valid_block_size(threads_per_block)) return cudaErrorInvalidValue;
  return cudaOccupancyMaxActiveBlocksPerMultiprocessor(blocks_per_sm, fma_peak_kernel, int(threads_per_block), 0);
}

cudaError_t launch_fma_peak(const FmaPeakParams& params, cudaStream_t stream) {
  if (params.out == nullptr || params.blocks == 0 || !valid_block_size(params.threads_per_block)) {
    return cudaErrorInvalidValue;
  }
  const auto kernel = params.half2 ? hfma2_peak_kernel : fma_peak_kernel;
  kernel<<<params.blocks, params.threads_per_block, 0, stream>>>(params.out, params.iterations, params.mul,
                                                                 params.add);
  return kernels::detail::launch_result();
}

}  // namespace rgs::lab
