// Micro-kernels that measure a device's FP32 and binary16 (half2) compute peaks for the roofline of rgs-bench (docs/lab/ROOFLINE.md:
// achieved GB/s and GFLOP/s per stage against the device's measured peaks). The memory peak needs no kernel
// (a cudaMemcpyAsync device-to-device copy, rgs/lab/device_peaks.h).
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

namespace rgs::lab {

/// Independent FMA chains per thread of the FMA loop: enough that, with a full SM, the FP32 pipes never wait on
/// an FMA's latency.
constexpr uint32_t kFmaPeakChains = 8;

/// One launch of the FP32 FMA loop (launch_fma_peak).
struct FmaPeakParams {
  /// [blocks · threads_per_block] float32, device memory: each thread stores the sum of its chains there so
  /// the compiler cannot drop the loop. Values are meaningless (bounded, finite).
  float* out = nullptr;
  uint32_t blocks = 0;             ///< thread blocks (e.g. SMs × fma_peak_blocks_per_sm × waves)
  uint32_t threads_per_block = 256;///< 32..1024, a multiple of 32
  uint32_t iterations = 0;         ///< loop trips; each does kFmaPeakChains dependent-free FMAs per thread
  /// Runtime operands of a = fma(a, mul, add), passed by value so nothing folds at compile time; |mul| < 1
  /// keeps the chains bounded.
  float mul = 0.9999f;
  float add = 1e-4f;
  /// Run the chains as binary16 pairs (__hfma2: two FMAs per instruction) instead of float32.
  bool half2 = false;
};

/// FLOPs of one launch_fma_peak: blocks · threads · iterations · kFmaPeakChains · 2 (an FMA counts 2), twice
/// that with half2 (an __hfma2 is two FMAs).
inline double fma_peak_flops(const FmaPeakParams& p) {
  return double(p.blocks) * double(p.threads_per_block) * double(p.iterations) * double(kFmaPeakChains) *
         (p.half2 ? 4.0 : 2.0);
}

/// Resident blocks of the FMA loop kernel per SM at `threads_per_block` (cudaOccupancyMaxActiveBlocksPerMultiprocessor
/// on the current device).
cudaError_t fma_peak_blocks_per_sm(uint32_t threads_per_block, int* blocks_per_sm);

/// Enqueues the FMA loop on `stream`: every thread runs kFmaPeakChains independent chains
/// a_k = __fmaf_rn(a_k, mul, add) for `iterations` trips (explicit FMAs: rgs_kernels is compiled with
/// --fmad=false), or with `half2` the binary16 pairs a_k = __hfma2(a_k, mul, add), then writes the chains'
/// sum to out[thread]. Returns cudaErrorInvalidValue for a null
/// `out`, zero blocks or a block size that is not a multiple of 32 in [32, 1024]; else the launch's error.
cudaError_t launch_fma_peak(const FmaPeakParams& params, cudaStream_t stream);

}  // namespace rgs::lab
