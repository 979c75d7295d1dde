// Helpers of the SPZ, .splat and glTF tests: clouds to encode, and per-Gaussian comparisons.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>

#include <doctest/doctest.h>

#include "rgs/format/gaussian_cloud.h"

namespace rgs::test {

/// A deterministic cloud with every attribute varied (SH up to `degree`), unit quaternions (w, x, y, z).
inline format::GaussianCloud make_interop_cloud(size_t n, uint32_t degree, uint32_t seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-20.0f, 20.0f), unit(-1.0f, 1.0f), logs(-7.0f, 1.5f), op(0.0f, 1.0f),
      dc(-1.8f, 1.8f), rest(-0.9f, 0.9f);
  format::GaussianCloud c;
  c.sh_degree = degree;
  c.resize(n);
  const uint32_t k = c.sh_coefficients();
  for (size_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) {
      c.means[i * 3 + a] = pos(rng);
      c.scales[i * 3 + a] = std::exp(logs(rng));
    }
    double q[4], n2 = 0;
    for (double& v : q) {
      v = unit(rng);
      n2 += v * v;
    }
    for (int a = 0; a < 4; ++a) c.rotations[i * 4 + a] = static_cast<float>(q[a] / std::sqrt(n2));
    c.opacities[i] = op(rng);
    for (uint32_t j = 0; j < k; ++j) {
      for (int ch = 0; ch < 3; ++ch) c.sh[(i * k + j) * 3 + ch] = j == 0 ? dc(rng) : rest(rng);
    }
  }
  return c;
}

/// Angle in degrees between the rotations of unit quaternions a and b (q and −q are the same rotation).
inline double rotation_angle_deg(const float* a, const float* b) {
  double dot = 0, na = 0, nb = 0;
  for (int i = 0; i < 4; ++i) {
    dot += double{a[i]} * b[i];
    na += double{a[i]} * a[i];
    nb += double{b[i]} * b[i];
  }
  const double c = std::min(1.0, std::fabs(dot) / std::sqrt(na * nb));
  return 2.0 * std::acos(c) * 180.0 / 3.14159265358979323846;
}

/// Largest per-attribute differences between two clouds of equal size and degree.
struct CloudDiff {
  double position = 0, log_scale = 0, rotation_deg = 0, opacity = 0, dc = 0, rest = 0;
};

inline CloudDiff diff_clouds(const format::GaussianCloud& a, const format::GaussianCloud& b) {
  REQUIRE(a.size() == b.size());
  REQUIRE(a.sh_degree == b.sh_degree);
  CloudDiff d;
  const uint32_t k = a.sh_coefficients();
  for (size_t i = 0; i < a.size(); ++i) {
    for (int x = 0; x < 3; ++x) {
      d.position = std::max(d.position, std::fabs(double{a.means[i * 3 + x]} - b.means[i * 3 + x]));
      d.log_scale = std::max(d.log_scale,
                             std::fabs(std::log(double{a.scales[i * 3 + x]}) - std::log(double{b.scales[i * 3 + x]})));
    }
    d.rotation_deg = std::max(d.rotation_deg, rotation_angle_deg(&a.rotations[i * 4], &b.rotations[i * 4]));
    d.opacity = std::max(d.opacity, std::fabs(double{a.opacities[i]} - b.opacities[i]));
    for (uint32_t j = 0; j < k; ++j) {
      for (int c = 0; c < 3; ++c) {
        const double e = std::fabs(double{a.sh[(i * k + j) * 3 + c]} - b.sh[(i * k + j) * 3 + c]);
        (j == 0 ? d.dc : d.rest) = std::max(j == 0 ? d.dc : d.rest, e);
      }
    }
  }
  return d;
}

/// Largest |Σa − Σb| over all Gaussians, relative to the largest squared scale of the Gaussian, with
/// Σ = R·S²·Rᵀ (the quantity renderers use; different quaternions can give the same Σ).
inline double max_covariance_error(const format::GaussianCloud& a, const format::GaussianCloud& b) {
  auto cov = [](const format::GaussianCloud& c, size_t i, double out[9]) {
    const float* q = &c.rotations[i * 4];
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                         2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                         2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)};
    for (int m = 0; m < 3; ++m) {
      for (int n = 0; n < 3; ++n) {
        double s = 0;
        for (int k = 0; k < 3; ++k)
          s += r[m * 3 + k] * r[n * 3 + k] * double{c.scales[i * 3 + k]} * c.scales[i * 3 + k];
        out[m * 3 + n] = s;
      }
    }
  };
  double worst = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    double ca[9], cb[9];
    cov(a, i, ca);
    cov(b, i, cb);
    double s2 = 0;
    for (int k = 0; k < 3; ++k) s2 = std::max(s2, double{a.scales[i * 3 + k]} * a.scales[i * 3 + k]);
    for (int m = 0; m < 9; ++m) worst = std::max(worst, std::fabs(ca[m] - cb[m]) / s2);
  }
  return worst;
}

inline std::string describe(const CloudDiff& d) {
  return "position " + std::to_string(d.position) + ", ln scale " + std::to_string(d.log_scale) + ", rotation " +
         std::to_string(d.rotation_deg) + " deg, opacity " + std::to_string(d.opacity) + ", f_dc " +
         std::to_string(d.dc) + ", SH rest " + std::to_string(d.rest);
}

}  // namespace rgs::test
