// Measured peaks of the current CUDA device, the roofs of rgs-bench's roofline (docs/lab/ROOFLINE.md). Available
// only with RGS_WITH_CUDA.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::lab {

/// What measure_device_peaks() does.
struct DevicePeakOptions {
  /// Size of the device-to-device copy in bytes; halved (down to 64 MiB) while the two buffers cannot be
  /// allocated. Large enough that the copy is not served from L2 (50 MB on an H100).
  uint64_t copy_bytes = uint64_t{1} << 30;
  /// Timed copies and FMA launches after one untimed warm-up of each; the medians are reported.
  uint32_t repeats = 7;
  /// Threads per block of the FMA loop (lab/src/internal_peak_kernels.h).
  uint32_t fma_threads_per_block = 256;
  /// Grid of the FMA loop in full waves: SMs × resident blocks per SM × fma_waves.
  uint32_t fma_waves = 2;
  /// Loop trips per thread of the FMA loop (each kFmaPeakChains FMAs).
  uint32_t fma_iterations = 16384;
};

/// Measured roofs. GB/s and GFLOP/s use 10^9.
struct DevicePeaks {
  // Memory: cudaMemcpyAsync device to device, bytes counted as read + write (2 × copy_bytes per copy).
  uint64_t copy_bytes = 0;             ///< bytes of one copy (after any halving)
  std::vector<float> copy_ms;          ///< each timed copy, CUDA events
  double copy_median_ms = 0;
  double memory_gbps = 0;              ///< 2 · copy_bytes / median time
  // Compute: the FP32 FMA loop (launch_fma_peak), 2 FLOPs per FMA.
  uint32_t fma_blocks = 0, fma_threads_per_block = 0, fma_iterations = 0, fma_blocks_per_sm = 0;
  uint32_t fma_chains_per_thread = 0;  ///< kFmaPeakChains
  double fma_flops = 0;                ///< FLOPs of one launch
  std::vector<float> fma_ms;           ///< each timed launch, CUDA events
  double fma_median_ms = 0;
  double fp32_gflops = 0;              ///< fma_flops / median time
  // binary16: the same loop with __hfma2 on half2 pairs (2 FMAs, 4 FLOPs per instruction), same grid.
  double hfma2_flops = 0;              ///< FLOPs of one launch
  std::vector<float> hfma2_ms;         ///< each timed launch, CUDA events
  double hfma2_median_ms = 0;
  double half_gflops = 0;              ///< hfma2_flops / median time
  /// Ridge point of the roofline, FLOP per byte: fp32_gflops / memory_gbps.
  double ridge_flop_per_byte() const { return memory_gbps > 0 ? fp32_gflops / memory_gbps : 0.0; }
};

/// Measures the memory, FP32 and binary16 compute peaks of the current device on `stream` (waits for it). The
/// source buffer is filled with a non-zero byte pattern first; buffers are freed before returning.
/// Errors: kInvalidArgument (repeats 0, fma_iterations 0, fma_waves 0, copy_bytes < 64 MiB, a block
/// size the kernel refuses), kOutOfMemory (not even 2 × 64 MiB free), kCudaError (a failed call, named).
Result<DevicePeaks> measure_device_peaks(const DevicePeakOptions& options = {}, cudaStream_t stream = nullptr);

}  // namespace rgs::lab
