// Image metrics on the GPU (CUDA builds only: rgs/config.h RGS_HAS_CUDA). Same definitions as
// compare_images() in image_metrics.h; per-window SSIM values are the CPU reference's bits, and PSNR and SSIM
// differ from it only by the order of the final float64 sums (relative 1e-12 or less).
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

#include "rgs/runtime/image_metrics.h"
#include "rgs/format/status.h"
#include "rgs/kernels/image_metrics.h"
#include "rgs/runtime/device_buffer.h"

namespace rgs::runtime {

/// Compares images in device memory (kernels::launch_image_metrics). Keeps its scratch buffers between calls
/// and grows them as needed. Not thread-safe; move-only.
class GpuImageComparer {
 public:
  /// Compares `a` and `b` ([H, W, channels] float32 in device memory, R, G, B first) on `stream` and waits
  /// for the three results.
  /// @param d_diff  optional device [H, W] float32 receiving the per-pixel max over R, G, B of |Δ|.
  /// @return kInvalidArgument (null pointer, channels < 3, a side below 11 pixels), kOutOfMemory,
  ///         kCudaError naming the step.
  Result<ImageMetrics> compare(const float* a, const float* b, uint32_t width, uint32_t height, uint32_t channels,
                               float* d_diff = nullptr, cudaStream_t stream = nullptr);

 private:
  runtime::DeviceBuffer<char> scratch_;
  runtime::DeviceBuffer<kernels::ImageMetricsSums> sums_;
  runtime::PinnedBuffer host_sums_;
};

}  // namespace rgs::runtime
