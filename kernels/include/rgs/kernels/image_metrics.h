// Image comparison on the GPU (runtime::GpuImageComparer, for the audit and rate control): PSNR's squared-error
// sum (whole frame and a's foreground), SSIM's per-channel window sums and the per-pixel maximum difference of two
// float images in device memory. The window weights and constants come from the caller (the CPU reference,
// runtime/include/rgs/runtime/image_metrics.h), and every window is evaluated with the CPU reference's float64
// operations in its order (the library is built with --fmad=false), so per-window values agree bit for bit; only
// the order of the final sums differs.
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <cstdint>

namespace rgs::kernels {

/// SSIM window side (11×11, Wang et al. 2004).
constexpr int kMetricsSsimWindow = 11;

/// Sums of one comparison, written by launch_image_metrics into device memory.
struct ImageMetricsSums {
  double squared_error = 0;  ///< Σ over H·W·3 values of (clamp(a) − clamp(b))², clamp to [0, 1], NaN → 0
  double ssim[3] = {0, 0, 0};///< Σ of the SSIM map over the (W − 10)·(H − 10) valid windows, per channel
  float max_abs_diff = 0;    ///< max over pixels of max over R, G, B of |clamp(a) − clamp(b)|
  /// The squared-error sum and the pixel count over a's foreground: pixels whose alpha (channel 3, with 4 or
  /// more channels) is above 0 or whose clamped R, G or B is above 0 (rgs::audit::foreground_psnr's mask).
  double foreground_squared_error = 0;
  double foreground_pixels = 0;
};

/// Inputs and outputs of one comparison. Pointers are device memory.
struct ImageMetricsParams {
  const float* a = nullptr;  ///< [H, W, channels] float32, R, G, B first (channels 3 or 4)
  const float* b = nullptr;  ///< same layout and size as `a`
  uint32_t width = 0, height = 0;
  uint32_t channels = 4;
  double window[kMetricsSsimWindow] = {};  ///< normalized 1D Gaussian weights
  double c1 = 0, c2 = 0;                   ///< SSIM stabilizers
  /// Scratch of image_metrics_scratch_bytes(width, height) bytes, 16-byte aligned (cudaMalloc).
  void* scratch = nullptr;
  ImageMetricsSums* sums = nullptr;  ///< one struct; written, not accumulated
  float* diff = nullptr;  ///< optional [H, W] float32: per-pixel max over R, G, B of |Δ| (clamped values)
};

/// Scratch bytes launch_image_metrics needs for an image of width × height.
size_t image_metrics_scratch_bytes(uint32_t width, uint32_t height);

/// Enqueues the comparison on `stream`: a per-pixel kernel (squared error, maximum, optional diff map), a
/// tiled SSIM kernel (shared-memory separable filter, float64) and one block that reduces the per-block
/// partial sums in a fixed order into *sums (deterministic: same inputs, same bits). Does not synchronize.
/// Sizes must have been validated by the caller (width, height ≥ 11; channels ≥ 3).
/// @return the first launch error (cudaGetLastError after each launch).
cudaError_t launch_image_metrics(const ImageMetricsParams& params, cudaStream_t stream);

}  // namespace rgs::kernels
