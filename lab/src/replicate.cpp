#include "rgs/lab/replicate.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "rgs/converter/quantize.h"

namespace rgs::lab {
namespace {

/// The value at quantile q ∈ [0, 1] of axis `axis` of the means (nth_element on a copy).
float axis_quantile(const std::vector<float>& means, int axis, double q) {
  const size_t n = means.size() / 3;
  std::vector<float> values(n);
  for (size_t i = 0; i < n; ++i) values[i] = means[i * 3 + size_t(axis)];
  const size_t k = std::min(n - 1, size_t(q * double(n - 1)));
  std::nth_element(values.begin(), values.begin() + std::ptrdiff_t(k), values.end());
  return values[k];
}

template <typename T>
void repeat(const std::vector<T>& in, uint32_t copies, std::vector<T>* out) {
  out->clear();
  out->reserve(in.size() * copies);
  for (uint32_t c = 0; c < copies; ++c) out->insert(out->end(), in.begin(), in.end());
}

}  // namespace

Result<format::EncodedScene> replicate(const format::EncodedScene& scene, uint32_t copies) {
  RGS_RETURN_ERROR_IF(copies == 0, StatusCode::kInvalidArgument, "replicate: the number of copies must be >= 1");
  RGS_RETURN_ERROR_IF(!scene.is_consistent(), StatusCode::kInvalidArgument,
                      "replicate: scene arrays do not match its count and SH degree");
  const uint64_t total = scene.count * uint64_t(copies);
  RGS_RETURN_ERROR_IF(total > uint64_t{0x7fffffff}, StatusCode::kLimitExceeded,
                      "replicate: " + std::to_string(copies) + " copies of " + std::to_string(scene.count) +
                          " Gaussians exceed 2^31 - 1");
  format::EncodedScene out;
  out.metadata = scene.metadata;
  out.provenance = scene.provenance;
  out.provenance.emplace_back("replicated", std::to_string(copies));
  out.count = total;
  repeat(scene.rotations, copies, &out.rotations);
  repeat(scene.scales, copies, &out.scales);
  repeat(scene.opacities, copies, &out.opacities);
  repeat(scene.sh, copies, &out.sh);
  repeat(scene.sh_dc_residual, copies, &out.sh_dc_residual);

  const uint32_t cols = uint32_t(std::ceil(std::sqrt(double(copies))));
  const uint32_t rows = (copies + cols - 1) / cols;
  float spacing[3] = {0, 0, 0};
  if (scene.count > 0) {
    for (int axis : {0, 2}) {
      spacing[axis] = axis_quantile(scene.means, axis, 0.98) - axis_quantile(scene.means, axis, 0.02);
    }
  }
  format::GaussianCloud positions;  // means only, for compute_bounds
  positions.means.reserve(scene.means.size() * copies);
  for (uint32_t c = 0; c < copies; ++c) {
    // Centre the grid on the original: offsets (col − (cols−1)/2)·spacing_x, (row − (rows−1)/2)·spacing_z.
    const float dx = (float(c % cols) - 0.5f * float(cols - 1)) * spacing[0];
    const float dz = (float(c / cols) - 0.5f * float(rows - 1)) * spacing[2];
    for (uint64_t i = 0; i < scene.count; ++i) {
      positions.means.push_back(scene.means[i * 3] + dx);
      positions.means.push_back(scene.means[i * 3 + 1]);
      positions.means.push_back(scene.means[i * 3 + 2] + dz);
    }
  }
  out.metadata.bounds = converter::compute_bounds(positions);
  out.means = std::move(positions.means);
  return out;
}

}  // namespace rgs::lab
