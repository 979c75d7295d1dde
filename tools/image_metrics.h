// Image quality metrics of rgs-audit: PSNR and SSIM of RGB float images.
#pragma once

#include <cstdint>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::tools {

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

}  // namespace rgs::tools
