#include "rgs/runtime/gpu_image_metrics.h"

#include <cmath>
#include <limits>
#include <string>

#include "rgs/runtime/cuda_device.h"

namespace rgs::runtime {

Result<ImageMetrics> GpuImageComparer::compare(const float* a, const float* b, uint32_t width, uint32_t height,
                                               uint32_t channels, float* d_diff, cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(a == nullptr || b == nullptr, StatusCode::kInvalidArgument, "GPU image comparison: null image");
  RGS_RETURN_ERROR_IF(channels < 3, StatusCode::kInvalidArgument,
                      "GPU image comparison: images need at least 3 channels (got " + std::to_string(channels) + ")");
  RGS_RETURN_ERROR_IF(width < uint32_t(kSsimWindow) || height < uint32_t(kSsimWindow), StatusCode::kInvalidArgument,
                      "SSIM needs images of at least 11x11 pixels (got " + std::to_string(width) + "x" +
                          std::to_string(height) + ")");
  kernels::ImageMetricsParams p;
  p.a = a;
  p.b = b;
  p.width = width;
  p.height = height;
  p.channels = channels;
  const auto window = ssim_window_weights();
  static_assert(kSsimWindow == kernels::kMetricsSsimWindow, "one SSIM window on both sides");
  for (int k = 0; k < kSsimWindow; ++k) p.window[k] = window[size_t(k)];
  p.c1 = kSsimC1;
  p.c2 = kSsimC2;
  RGS_RETURN_IF_ERROR(scratch_.reserve(kernels::image_metrics_scratch_bytes(width, height), "image metrics scratch"));
  RGS_RETURN_IF_ERROR(sums_.reserve(1, "image metrics sums"));
  RGS_RETURN_IF_ERROR(host_sums_.reserve(sizeof(kernels::ImageMetricsSums), "image metrics sums"));
  p.scratch = scratch_.data();
  p.sums = sums_.data();
  p.diff = d_diff;
  RGS_RETURN_IF_CUDA_ERROR(kernels::launch_image_metrics(p, stream), "launch_image_metrics");
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host_sums_.data(), sums_.data(), sizeof(kernels::ImageMetricsSums),
                                           cudaMemcpyDeviceToHost, stream),
                           "image metrics: copying the sums to the host");
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "image metrics: waiting for the comparison");
  const auto* sums = static_cast<const kernels::ImageMetricsSums*>(host_sums_.data());
  ImageMetrics m;
  const double mse = sums->squared_error / (double(width) * height * 3);
  m.psnr_db = mse == 0.0 ? std::numeric_limits<double>::infinity() : 10.0 * std::log10(1.0 / mse);
  const double windows = double(width - 2 * kSsimRadius) * double(height - 2 * kSsimRadius);
  double total = 0;
  for (int c = 0; c < 3; ++c) total += sums->ssim[c] / windows;
  m.ssim = total / 3.0;
  m.max_abs_diff = sums->max_abs_diff;
  m.foreground = foreground_from_sum(sums->foreground_squared_error, uint64_t(sums->foreground_pixels),
                                     uint64_t(width) * height);
  return m;
}

}  // namespace rgs::runtime
