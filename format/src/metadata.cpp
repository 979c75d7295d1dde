#include "rgs/format/metadata.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace rgs::format {

void set_sphere_center(SceneBounds* bounds, double center[3]) {
  for (int a = 0; a < 3; ++a) {
    bounds->sphere_center[a] = static_cast<float>(
        0.5 * (static_cast<double>(bounds->aabb_min[a]) + static_cast<double>(bounds->aabb_max[a])));
    // Read back through a volatile: GCC 12 at -O3 otherwise forwards the unrounded double, and the radius
    // would be measured from a centre that is not the stored one (off by up to half a float ulp).
    const volatile float stored = bounds->sphere_center[a];
    center[a] = stored;
  }
}

float sphere_radius_for(double max_squared_distance) {
  return round_up_float(std::sqrt(max_squared_distance) * (1.0 + 1e-6));
}

float round_up_float(double v) {
  const volatile float rounded = static_cast<float>(v);  // volatile: see set_sphere_center()
  float f = rounded;
  if (static_cast<double>(f) < v) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

void box_of_means(const float* means, uint64_t n, float lo[3], float hi[3]) {
  for (int a = 0; a < 3; ++a) lo[a] = hi[a] = means[a];
  for (uint64_t i = 1; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], means[i * 3 + a]);
      hi[a] = std::max(hi[a], means[i * 3 + a]);
    }
  }
}

double max_squared_distance(const float* means, uint64_t n, const double center[3]) {
  double r2 = 0;
  for (uint64_t i = 0; i < n; ++i) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) d2 += (means[i * 3 + a] - center[a]) * (means[i * 3 + a] - center[a]);
    r2 = std::max(r2, d2);
  }
  return r2;
}

bool is_valid_quantization(const ShQuantization& q, uint32_t sh_degree, std::string* why) {
  auto fail = [why](std::string reason) {
    if (why) *why = std::move(reason);
    return false;
  };
  if (sh_degree > 3) return fail("SH degree " + std::to_string(sh_degree) + " > 3");
  if (q.bits != 8) return fail("SH quantization bits " + std::to_string(q.bits) + " (only 8 is defined)");
  if (!(q.clip_percentile > 0.0f && q.clip_percentile <= 100.0f)) {
    return fail("SH clip percentile " + std::to_string(q.clip_percentile) + " outside (0, 100]");
  }
  for (uint32_t d = 0; d < 4; ++d) {
    for (uint32_t c = 0; c < 3; ++c) {
      const float s = q.scales[d][c];
      const std::string name = "SH scale s[" + std::to_string(d) + "][" + std::to_string(c) + "]";
      if (!std::isfinite(s) || s < 0.0f) return fail(name + " = " + std::to_string(s) + " is not finite and >= 0");
      // s·q must be finite for every stored q in [-127, 127] (SPEC §3.4 sh_scales).
      if (!std::isfinite(s * 127.0f)) return fail(name + " = " + std::to_string(s) + " makes s*127 overflow float32");
      if (d > sh_degree && s != 0.0f) return fail(name + " is non-zero above SH degree " + std::to_string(sh_degree));
    }
  }
  return true;
}

const char* to_string(CoordinateFrame v) { return v == CoordinateFrame::kColmap ? "colmap" : "unknown"; }
const char* to_string(QuaternionOrder v) { return v == QuaternionOrder::kWxyz ? "wxyz" : "unknown"; }
const char* to_string(ScaleEncoding v) {
  return v == ScaleEncoding::kLinear ? "linear" : v == ScaleEncoding::kLog ? "log" : "unknown";
}
const char* to_string(OpacityEncoding v) { return v == OpacityEncoding::kSigmoid ? "sigmoid" : "unknown"; }
const char* to_string(ShLayout v) { return v == ShLayout::kCoefficientMajor ? "coefficient-major" : "unknown"; }

}  // namespace rgs::format
