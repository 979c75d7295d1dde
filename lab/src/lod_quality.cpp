// The level-of-detail quality measures (rgs/lab/lod_quality.h).
#include "rgs/lab/lod_quality.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace rgs::lab {
namespace {

/// A colour value clamped to [0, 1], NaN as 0.
double clamp01(float v) { return std::isnan(v) ? 0.0 : std::clamp(static_cast<double>(v), 0.0, 1.0); }

}  // namespace

Result<std::vector<float>> area_downsample_2x(const runtime::ImageRef& image) {
  RGS_RETURN_ERROR_IF(image.data == nullptr || image.channels == 0, StatusCode::kInvalidArgument,
                      "area downsample: null image or no channel");
  RGS_RETURN_ERROR_IF(image.width == 0 || image.height == 0 || image.width % 2 != 0 || image.height % 2 != 0,
                      StatusCode::kInvalidArgument,
                      "area downsample: the sides must be even and non-zero (got " + std::to_string(image.width) +
                          "x" + std::to_string(image.height) + ")");
  const size_t w = image.width / 2, h = image.height / 2, c = image.channels, row = size_t{image.width} * c;
  std::vector<float> out(w * h * c);
  for (size_t y = 0; y < h; ++y) {
    for (size_t x = 0; x < w; ++x) {
      const float* top = image.data + (2 * y) * row + 2 * x * c;
      for (size_t k = 0; k < c; ++k) {
        const double sum = double(top[k]) + double(top[c + k]) + double(top[row + k]) + double(top[row + c + k]);
        out[(y * w + x) * c + k] = static_cast<float>(0.25 * sum);
      }
    }
  }
  return out;
}

Result<double> mean_abs_difference(const runtime::ImageRef& a, const runtime::ImageRef& b) {
  RGS_RETURN_ERROR_IF(a.data == nullptr || b.data == nullptr || a.channels < 3 || b.channels < 3,
                      StatusCode::kInvalidArgument, "mean absolute difference: null image or fewer than 3 channels");
  RGS_RETURN_ERROR_IF(a.width != b.width || a.height != b.height || a.width == 0 || a.height == 0,
                      StatusCode::kInvalidArgument,
                      "mean absolute difference: sizes differ or are empty (" + std::to_string(a.width) + "x" +
                          std::to_string(a.height) + " and " + std::to_string(b.width) + "x" +
                          std::to_string(b.height) + ")");
  const size_t pixels = size_t{a.width} * a.height;
  double sum = 0;
  for (size_t p = 0; p < pixels; ++p) {
    for (size_t c = 0; c < 3; ++c) {
      sum += std::fabs(clamp01(a.data[p * a.channels + c]) - clamp01(b.data[p * b.channels + c]));
    }
  }
  return sum / static_cast<double>(3 * pixels);
}

}  // namespace rgs::lab
