#include "image_metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace rgs::tools {

namespace {

constexpr int kRadius = 5;  // 11×11 window
constexpr double kSigma = 1.5;
constexpr double kC1 = 0.01 * 0.01;
constexpr double kC2 = 0.03 * 0.03;

double clamp01(float v) { return std::isnan(v) ? 0.0 : std::clamp(static_cast<double>(v), 0.0, 1.0); }

Status check_sizes(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height) {
  const size_t n = size_t{width} * height * 3;
  RGS_RETURN_ERROR_IF(n == 0 || a.size() != n || b.size() != n, StatusCode::kInvalidArgument,
                      "images must both hold " + std::to_string(width) + "x" + std::to_string(height) +
                          "x3 values (got " + std::to_string(a.size()) + " and " + std::to_string(b.size()) + ")");
  return Status::ok_status();
}

}  // namespace

Result<double> psnr_rgb(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height) {
  RGS_RETURN_IF_ERROR(check_sizes(a, b, width, height));
  double sum = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const double d = clamp01(a[i]) - clamp01(b[i]);
    sum += d * d;
  }
  const double mse = sum / static_cast<double>(a.size());
  if (mse == 0.0) return std::numeric_limits<double>::infinity();
  return 10.0 * std::log10(1.0 / mse);
}

Result<double> ssim_rgb(const std::vector<float>& a, const std::vector<float>& b, uint32_t width, uint32_t height) {
  RGS_RETURN_IF_ERROR(check_sizes(a, b, width, height));
  const int w = static_cast<int>(width), h = static_cast<int>(height), win = 2 * kRadius + 1;
  RGS_RETURN_ERROR_IF(w < win || h < win, StatusCode::kInvalidArgument,
                      "SSIM needs images of at least 11x11 pixels (got " + std::to_string(w) + "x" +
                          std::to_string(h) + ")");
  double g[2 * kRadius + 1];
  double gsum = 0;
  for (int i = -kRadius; i <= kRadius; ++i) gsum += g[i + kRadius] = std::exp(-(i * i) / (2 * kSigma * kSigma));
  for (double& v : g) v /= gsum;

  const int ow = w - 2 * kRadius, oh = h - 2 * kRadius;  // valid output positions
  // Five maps (x, y, x², y², xy), filtered horizontally into [h, ow], then vertically into [oh, ow].
  std::vector<double> x(size_t(w) * h), y(size_t(w) * h);
  std::vector<double> hz[5];
  for (auto& m : hz) m.assign(size_t(ow) * h, 0.0);
  double total = 0;
  for (int c = 0; c < 3; ++c) {
    for (size_t i = 0; i < x.size(); ++i) {
      x[i] = clamp01(a[i * 3 + c]);
      y[i] = clamp01(b[i * 3 + c]);
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
        channel_sum += ((2 * mx * my + kC1) * (2 * cxy + kC2)) / ((mx * mx + my * my + kC1) * (vx + vy + kC2));
      }
    }
    total += channel_sum / (double(ow) * oh);
  }
  return total / 3.0;
}

}  // namespace rgs::tools
