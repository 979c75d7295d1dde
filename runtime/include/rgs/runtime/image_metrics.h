// Image quality metrics of two renders (the audit's and rate control's): PSNR, SSIM and the per-pixel maximum difference of two float RGB images
// (CPU reference). The GPU version (gpu_image_metrics.h) uses the same window and constants and gives the same
// per-window values; only the order of the final sums differs.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::runtime {

/// SSIM window radius: an 11×11 window (Wang et al. 2004).
inline constexpr int kSsimRadius = 5;
/// SSIM window side, 2·kSsimRadius + 1.
inline constexpr int kSsimWindow = 2 * kSsimRadius + 1;
/// Standard deviation of the SSIM's Gaussian window, pixels.
inline constexpr double kSsimSigma = 1.5;
/// SSIM stabilizers for a dynamic range of 1: C1 = (0.01·1)², C2 = (0.03·1)².
inline constexpr double kSsimC1 = 0.01 * 0.01;
inline constexpr double kSsimC2 = 0.03 * 0.03;

/// The 1D SSIM window: exp(−i² / (2σ²)) for i in [−5, 5], normalized to sum 1, in float64. The 2D window is
/// its outer product, applied separably (rows first, then columns) by both the CPU and the GPU version.
std::array<double, kSsimWindow> ssim_window_weights();

/// A float image in caller-owned memory, row-major, top row first: [H, W, channels] with R, G, B in the first
/// three channels of each pixel (channels 3 for RGB, 4 for RGBA renders; the rest is ignored).
struct ImageRef {
  const float* data = nullptr;
  uint32_t width = 0, height = 0;
  uint32_t channels = 3;
};

/// PSNR over the foreground of a reference render (the audit's renders have a black background).
struct ForegroundPsnr {
  /// PSNR in dB over the 3·`pixels` clamped R, G, B values of the foreground pixels (peak 1, MSE in float64);
  /// +inf when they are equal there; NaN when the reference has no foreground pixel.
  double psnr_db = 0;
  /// Foreground pixels: those of the reference whose alpha (channel 3, when it has 4 or more channels) is above
  /// 0 or whose clamped R, G or B is above 0. The rest is black background, equal in both renders of a
  /// faithful candidate, and would only add zeros to the whole-frame MSE (raising its PSNR by
  /// 10·log10(total / foreground pixels) dB for the same error).
  uint64_t pixels = 0;
  uint64_t total_pixels = 0;  ///< W·H
};

/// PSNR over the foreground pixels (ForegroundPsnr::pixels) from their squared-error sum: NaN for no pixel.
ForegroundPsnr foreground_from_sum(double squared_sum, uint64_t pixels, uint64_t total_pixels);

/// The metrics of one image pair.
struct ImageMetrics {
  /// PSNR in dB over the H·W·3 clamped RGB values (peak 1, MSE in float64); +inf when they are equal.
  double psnr_db = 0;
  /// Mean SSIM over the valid windows, per channel, averaged over R, G, B (see ssim_rgb).
  double ssim = 0;
  /// Largest per-pixel max over R, G, B of |a − b| of the clamped values.
  float max_abs_diff = 0;
  /// PSNR over a's foreground (foreground_psnr, with a as the reference).
  ForegroundPsnr foreground;
};

/// Compares two images of the same size: clamps every R, G, B value to [0, 1] first (NaN counts as 0), then
/// PSNR (psnr_rgb's definition), SSIM (ssim_rgb's), the maximum difference and the PSNR over a's foreground.
/// @param diff  optional; receives [H, W] float32, the per-pixel max over R, G, B of |a − b| (clamped values).
/// @return kInvalidArgument when sizes differ, a pointer is null, channels < 3 or a side is below 11 pixels.
/// Deterministic; single-threaded; float64 accumulation. Memory: about 7 float64 planes of H·W.
Result<ImageMetrics> compare_images(const ImageRef& a, const ImageRef& b, std::vector<float>* diff = nullptr);


/// PSNR of `candidate` against `reference` over the reference's foreground pixels (ForegroundPsnr::pixels).
/// The mask is the reference's alone, so every candidate of one source is measured over the same pixels; a
/// candidate's stray colour on the reference's background counts only in the whole-frame PSNR.
/// @return kInvalidArgument when sizes differ, a pointer is null, channels < 3 or a side is below 11 pixels
///         (compare_images' checks). Deterministic; single-threaded; float64 accumulation.
Result<ForegroundPsnr> foreground_psnr(const ImageRef& reference, const ImageRef& candidate);

/// PSNR in dB of two [H, W, 3] float RGB images, each value clamped to [0, 1] first (peak 1), over all
/// H·W·3 values, MSE accumulated in float64: 10·log10(1 / MSE). +inf when the clamped images are equal.
/// @return kInvalidArgument when the sizes differ from width·height·3 or are 0.
Result<double> psnr_rgb(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height);

/// Mean SSIM (Wang et al. 2004) of two [H, W, 3] float RGB images clamped to [0, 1] (dynamic range 1):
/// 11×11 Gaussian window with σ = 1.5 (normalized to sum 1), C1 = 0.01², C2 = 0.03², population
/// (biased) statistics; the SSIM map is taken over the "valid" windows only (every window fully inside the
/// image: (W − 10)·(H − 10) positions), averaged, per channel, then the three channels are averaged. This is
/// the reference MATLAB ssim_index and skimage's structural_similarity(gaussian_weights=True, sigma=1.5,
/// use_sample_covariance=False, data_range=1). Computed in float64 with separable filtering.
/// @return kInvalidArgument when the sizes mismatch or a side is below 11 pixels.
Result<double> ssim_rgb(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height);

}  // namespace rgs::runtime
