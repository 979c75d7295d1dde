#include "rgs/format/encoded_scene.h"

#include <algorithm>
#include <cmath>
#include <functional>
#include <new>
#include <string>
#include <vector>

#include "internal_sections.h"
#include "rgs/format/half.h"

namespace rgs::format {

bool EncodedScene::is_consistent() const {
  if (metadata.sh_degree > 3) return false;
  const uint64_t n = count;
  const uint64_t k = sh_coefficient_count(metadata.sh_degree);
  return means.size() == n * 3 && rotations.size() == n * 4 && scales.size() == n * 3 &&
         opacities.size() == n && sh.size() == n * k * 3 && (sh_dc_residual.empty() || sh_dc_residual.size() == n * 3);
}

namespace {

Status check_range(const EncodedScene& scene, uint64_t first, uint64_t count) {
  RGS_RETURN_ERROR_IF(!scene.is_consistent(), StatusCode::kCorruptData,
                      "encoded scene arrays do not match count " + std::to_string(scene.count) +
                          " and SH degree " + std::to_string(scene.metadata.sh_degree));
  RGS_RETURN_ERROR_IF(first > scene.count || count > scene.count - first, StatusCode::kInvalidArgument,
                      "range [" + std::to_string(first) + ", +" + std::to_string(count) +
                          ") outside a scene of " + std::to_string(scene.count) + " Gaussians");
  return Status();
}

Status resize_cloud(uint64_t count, uint32_t sh_degree, GaussianCloud* out) {
  out->sh_degree = sh_degree;
  try {
    out->resize(count);
  } catch (const std::bad_alloc&) {
    *out = GaussianCloud{};
    return Status(StatusCode::kOutOfMemory, "out of memory dequantizing " + std::to_string(count) +
                                                " Gaussians at SH degree " + std::to_string(sh_degree));
  }
  return Status();
}

/// Gaussians [first, first + count) of `scene` into Gaussians [at, at + count) of `out` (sized, checked).
void dequantize_into(const EncodedScene& scene, uint64_t first, uint64_t count, uint64_t at, GaussianCloud* out) {
  const uint32_t k_count = out->sh_coefficients();
  const bool log_scale = scene.metadata.scale_encoding == ScaleEncoding::kLog;
  const auto& s = scene.metadata.sh_quantization.scales;
  for (uint64_t j = at; j < at + count; ++j) {
    const uint64_t i = first + (j - at);
    for (int a = 0; a < 3; ++a) out->means[j * 3 + a] = scene.means[i * 3 + a];
    for (int a = 0; a < 4; ++a) out->rotations[j * 4 + a] = half_bits_to_float(scene.rotations[i * 4 + a]);
    for (int a = 0; a < 3; ++a) {
      const float v = half_bits_to_float(scene.scales[i * 3 + a]);
      out->scales[j * 3 + a] = log_scale ? std::exp(v) : v;
    }
    out->opacities[j] = half_bits_to_float(scene.opacities[i]);
    for (uint32_t k = 0; k < k_count; ++k) {
      const uint32_t d = sh_degree_of_coefficient(k);
      for (uint32_t c = 0; c < 3; ++c) {
        out->sh[(j * k_count + k) * 3 + c] = s[d][c] * static_cast<float>(scene.sh[(i * k_count + k) * 3 + c]);
      }
    }
    if (!scene.sh_dc_residual.empty()) {
      for (uint32_t c = 0; c < 3; ++c) {
        out->sh[j * k_count * 3 + c] =
            sh_dc_value(s[0][c], scene.sh[i * k_count * 3 + c], scene.sh_dc_residual[i * 3 + c]);
      }
    }
  }
}

/// Gaussians dequantize() hands each of its threads at a time.
constexpr uint64_t kDequantizeChunk = uint64_t{1} << 16;

}  // namespace

Status dequantize_range(const EncodedScene& scene, uint64_t first, uint64_t count, GaussianCloud* out) {
  RGS_RETURN_IF_ERROR(check_range(scene, first, count));
  RGS_RETURN_IF_ERROR(resize_cloud(count, scene.metadata.sh_degree, out));
  out->antialiased = scene.metadata.antialiased;
  dequantize_into(scene, first, count, 0, out);
  return Status();
}

Result<GaussianCloud> dequantize(const EncodedScene& scene, uint32_t threads) {
  RGS_RETURN_IF_ERROR(check_range(scene, 0, scene.count));
  GaussianCloud cloud;
  RGS_RETURN_IF_ERROR(resize_cloud(scene.count, scene.metadata.sh_degree, &cloud));
  cloud.antialiased = scene.metadata.antialiased;
  std::vector<std::function<Status()>> jobs;
  for (uint64_t first = 0; first < scene.count; first += kDequantizeChunk) {
    jobs.push_back([&scene, &cloud, first] {
      const uint64_t count = std::min(kDequantizeChunk, scene.count - first);
      dequantize_into(scene, first, count, first, &cloud);
      return Status();
    });
  }
  RGS_RETURN_IF_ERROR(detail::run_jobs(jobs, threads, "dequantizing"));
  return cloud;
}

}  // namespace rgs::format
