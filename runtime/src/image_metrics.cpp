#include "rgs/runtime/image_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace rgs::runtime {

namespace {

double clamp01(float v) { return std::isnan(v) ? 0.0 : std::clamp(static_cast<double>(v), 0.0, 1.0); }

Status check_pair(const ImageRef& a, const ImageRef& b) {
  RGS_RETURN_ERROR_IF(a.data == nullptr || b.data == nullptr, StatusCode::kInvalidArgument,
                      "image comparison: null image");
  RGS_RETURN_ERROR_IF(a.channels < 3 || b.channels < 3, StatusCode::kInvalidArgument,
                      "image comparison: images need at least 3 channels (got " + std::to_string(a.channels) +
                          " and " + std::to_string(b.channels) + ")");
  RGS_RETURN_ERROR_IF(a.width != b.width || a.height != b.height, StatusCode::kInvalidArgument,
                      "image comparison: sizes differ (" + std::to_string(a.width) + "x" + std::to_string(a.height) +
                          " and " + std::to_string(b.width) + "x" + std::to_string(b.height) + ")");
  RGS_RETURN_ERROR_IF(a.width < uint32_t(kSsimWindow) || a.height < uint32_t(kSsimWindow),
                      StatusCode::kInvalidArgument,
                      "SSIM needs images of at least 11x11 pixels (got " + std::to_string(a.width) + "x" +
                          std::to_string(a.height) + ")");
  return Status::ok_status();
}

Status check_vectors(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height) {
  const size_t n = size_t{width} * height * 3;
  RGS_RETURN_ERROR_IF(n == 0 || a.size() != n || b.size() != n, StatusCode::kInvalidArgument,
                      "images must both hold " + std::to_string(width) + "x" + std::to_string(height) +
                          "x3 values (got " + std::to_string(a.size()) + " and " + std::to_string(b.size()) + ")");
  return Status::ok_status();
}

/// Sum of squared differences of the clamped RGB values, and the maximum difference (with the map).
double squared_error_sum(const ImageRef& a, const ImageRef& b, float* max_abs, std::vector<float>* diff) {
  const size_t pixels = size_t{a.width} * a.height;
  if (diff != nullptr) diff->assign(pixels, 0.f);
  double sum = 0;
  float largest = 0;
  for (size_t p = 0; p < pixels; ++p) {
    float pixel_max = 0;
    for (size_t c = 0; c < 3; ++c) {
      const double d = clamp01(a.data[p * a.channels + c]) - clamp01(b.data[p * b.channels + c]);
      sum += d * d;
      pixel_max = std::max(pixel_max, static_cast<float>(std::fabs(d)));
    }
    if (diff != nullptr) (*diff)[p] = pixel_max;
    largest = std::max(largest, pixel_max);
  }
  *max_abs = largest;
  return sum;
}

double psnr_from_sum(double squared_sum, size_t values) {
  const double mse = squared_sum / static_cast<double>(values);
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(1.0 / mse);
}

/// Separable SSIM; the GPU kernel (kernels/src/image_metrics.cu) evaluates each window with the same
/// operations in the same order, so the per-window values agree bit for bit.
double ssim_of(const ImageRef& a, const ImageRef& b) {
  const std::array<double, kSsimWindow> g = ssim_window_weights();
  const int w = static_cast<int>(a.width), h = static_cast<int>(a.height), win = kSsimWindow;
  const int ow = w - 2 * kSsimRadius, oh = h - 2 * kSsimRadius;  // valid output positions
  // Five maps (x, y, x², y², xy), filtered horizontally into [h, ow], then vertically into [oh, ow].
  std::vector<double> x(size_t(w) * h), y(size_t(w) * h);
  std::vector<double> hz[5];
  for (auto& m : hz) m.assign(size_t(ow) * h, 0.0);
  double total = 0;
  for (int c = 0; c < 3; ++c) {
    for (size_t i = 0; i < x.size(); ++i) {
      x[i] = clamp01(a.data[i * a.channels + c]);
      y[i] = clamp01(b.data[i * b.channels + c]);
    }
    for (int r = 0; r < h; ++r) {
      for (int o = 0; o < ow; ++o) {
        double s[5] = {0, 0, 0, 0, 0};
        for (int k = 0; k < win; ++k) {
          const size_t i = size_t(r) * w + o + k;
          const double xv = x[i], yv = y[i], gk = g[k];
          s[0] += gk * xv;
          s[1] += gk * yv;
          s[2] += gk * xv * xv;
          s[3] += gk * yv * yv;
          s[4] += gk * xv * yv;
        }
        for (int m = 0; m < 5; ++m) hz[m][size_t(r) * ow + o] = s[m];
      }
    }
    double channel_sum = 0;
    for (int r = 0; r < oh; ++r) {
      for (int o = 0; o < ow; ++o) {
        double s[5] = {0, 0, 0, 0, 0};
        for (int k = 0; k < win; ++k) {
          const size_t i = size_t(r + k) * ow + o;
          for (int m = 0; m < 5; ++m) s[m] += g[k] * hz[m][i];
        }
        const double mx = s[0], my = s[1];
        const double vx = s[2] - mx * mx, vy = s[3] - my * my, cxy = s[4] - mx * my;
        channel_sum += ((2 * mx * my + kSsimC1) * (2 * cxy + kSsimC2)) /
                       ((mx * mx + my * my + kSsimC1) * (vx + vy + kSsimC2));
      }
    }
    total += channel_sum / (double(ow) * oh);
  }
  return total / 3.0;
}

}  // namespace

std::array<double, kSsimWindow> ssim_window_weights() {
  std::array<double, kSsimWindow> g{};
  double sum = 0;
  for (int i = -kSsimRadius; i <= kSsimRadius; ++i) {
    sum += g[size_t(i + kSsimRadius)] = std::exp(-(i * i) / (2 * kSsimSigma * kSsimSigma));
  }
  for (double& v : g) v /= sum;
  return g;
}

namespace {

/// foreground_psnr without the checks (the caller has made them).
ForegroundPsnr foreground_of(const ImageRef& reference, const ImageRef& candidate) {
  const uint64_t total = uint64_t{reference.width} * reference.height;
  uint64_t pixels = 0;
  double sum = 0;
  for (size_t p = 0; p < total; ++p) {
    const float* r = reference.data + p * reference.channels;
    const float* c = candidate.data + p * candidate.channels;
    const bool covered = reference.channels >= 4 && r[3] > 0.f;  // NaN alpha: not covered
    if (!covered && clamp01(r[0]) == 0.0 && clamp01(r[1]) == 0.0 && clamp01(r[2]) == 0.0) continue;
    ++pixels;
    for (size_t ch = 0; ch < 3; ++ch) {
      const double d = clamp01(r[ch]) - clamp01(c[ch]);
      sum += d * d;
    }
  }
  return foreground_from_sum(sum, pixels, total);
}

}  // namespace

Result<ImageMetrics> compare_images(const ImageRef& a, const ImageRef& b, std::vector<float>* diff) {
  RGS_RETURN_IF_ERROR(check_pair(a, b));
  ImageMetrics m;
  const double sum = squared_error_sum(a, b, &m.max_abs_diff, diff);
  m.psnr_db = psnr_from_sum(sum, size_t{a.width} * a.height * 3);
  m.ssim = ssim_of(a, b);
  m.foreground = foreground_of(a, b);
  return m;
}

ForegroundPsnr foreground_from_sum(double squared_sum, uint64_t pixels, uint64_t total_pixels) {
  ForegroundPsnr f;
  f.pixels = pixels;
  f.total_pixels = total_pixels;
  f.psnr_db = pixels == 0 ? std::numeric_limits<double>::quiet_NaN() : psnr_from_sum(squared_sum, pixels * 3);
  return f;
}

Result<ForegroundPsnr> foreground_psnr(const ImageRef& reference, const ImageRef& candidate) {
  RGS_RETURN_IF_ERROR(check_pair(reference, candidate));
  return foreground_of(reference, candidate);
}

Result<double> psnr_rgb(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height) {
  RGS_RETURN_IF_ERROR(check_vectors(a, b, width, height));
  float max_abs = 0;
  const ImageRef ra{a.data(), width, height, 3}, rb{b.data(), width, height, 3};
  return psnr_from_sum(squared_error_sum(ra, rb, &max_abs, nullptr), a.size());
}

Result<double> ssim_rgb(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height) {
  RGS_RETURN_IF_ERROR(check_vectors(a, b, width, height));
  const ImageRef ra{a.data(), width, height, 3}, rb{b.data(), width, height, 3};
  RGS_RETURN_IF_ERROR(check_pair(ra, rb));
  return ssim_of(ra, rb);
}

}  // namespace rgs::runtime
