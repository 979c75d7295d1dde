// Error accumulation shared by attribute_errors.cpp and the fused measurement in quantize.cpp
// (private to rgs_converter).
//
// Both accumulate per fixed chunk of kErrorChunkGaussians Gaussians (each chunk sequential in Gaussian order,
// double sums, through accumulate_gaussian()) and merge the chunks in chunk order, so every entry point gives
// the same bits whatever the thread count.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>

#include "rgs/converter/attribute_errors.h"
#include "rgs/format/encoded_scene.h"

namespace rgs::converter::detail {

/// kInvalidArgument "<what> arrays are inconsistent with N Gaussians at SH degree D" unless `cloud` is
/// consistent (GaussianCloud::is_consistent).
inline Status check_consistent(const format::GaussianCloud& cloud, const std::string& what) {
  if (cloud.is_consistent()) return Status();
  return Status(StatusCode::kInvalidArgument, what + " arrays are inconsistent with " + std::to_string(cloud.size()) +
                                                  " Gaussians at SH degree " + std::to_string(cloud.sh_degree));
}

/// Gaussians per error chunk. Changing it changes the rounding of the sums (not their meaning).
constexpr uint64_t kErrorChunkGaussians = 65536;
constexpr double kRadToDeg = 57.29577951308232;

/// Running max and sum of squares of one measure.
struct Accumulator {
  double max = 0;
  double sum_sq = 0;
  uint64_t samples = 0;

  void add(double e) {
    // NaN propagates into max (a NaN error must not look like a perfect match).
    if (!(e <= max)) max = e;
    sum_sq += e * e;
    ++samples;
  }
  void merge(const Accumulator& other) {
    if (!(other.max <= max)) max = other.max;
    sum_sq += other.sum_sq;
    samples += other.samples;
  }
  ErrorStats stats() const {
    ErrorStats s;
    s.max = max;
    s.samples = samples;
    s.rms = samples ? std::sqrt(sum_sq / static_cast<double>(samples)) : 0.0;
    return s;
  }
};

struct Accumulators {
  Accumulator position, rotation, scale, scale_of_largest, opacity;
  Accumulator sh[4];
  Accumulator sh_channel[4][3];

  void merge(const Accumulators& o) {
    position.merge(o.position);
    rotation.merge(o.rotation);
    scale.merge(o.scale);
    scale_of_largest.merge(o.scale_of_largest);
    opacity.merge(o.opacity);
    for (int d = 0; d < 4; ++d) {
      sh[d].merge(o.sh[d]);
      for (int c = 0; c < 3; ++c) sh_channel[d][c].merge(o.sh_channel[d][c]);
    }
  }

  AttributeErrors result() const {
    AttributeErrors r;
    r.position = position.stats();
    r.rotation_deg = rotation.stats();
    r.scale_relative = scale.stats();
    r.scale_of_largest_axis = scale_of_largest.stats();
    r.opacity = opacity.stats();
    for (int d = 0; d < 4; ++d) {
      r.sh[d] = sh[d].stats();
      for (int c = 0; c < 3; ++c) r.sh_channel[d][c] = sh_channel[d][c].stats();
    }
    return r;
  }
};

/// Rotation angle in degrees between the orientations of two quaternions (normalized here).
inline double rotation_angle_deg(const float* q1f, const float* q2f) {
  double q1[4], q2[4];
  double n1 = 0, n2 = 0, dot = 0;
  for (int a = 0; a < 4; ++a) {
    q1[a] = q1f[a];
    q2[a] = q2f[a];
    n1 += q1[a] * q1[a];
    n2 += q2[a] * q2[a];
  }
  // A zero quaternion has no orientation: equal to another zero one, maximally far from anything else.
  if (n1 == 0 || n2 == 0) return n1 == n2 ? 0.0 : 180.0;
  n1 = 1.0 / std::sqrt(n1);
  n2 = 1.0 / std::sqrt(n2);
  for (int a = 0; a < 4; ++a) {
    q1[a] *= n1;
    q2[a] *= n2;
    dot += q1[a] * q2[a];
  }
  const double sign = dot < 0 ? -1.0 : 1.0;  // q and −q are the same rotation
  double diff = 0, sum = 0;
  for (int a = 0; a < 4; ++a) {
    const double b = sign * q2[a];
    diff += (q1[a] - b) * (q1[a] - b);
    sum += (q1[a] + b) * (q1[a] + b);
  }
  return 4.0 * std::atan2(std::sqrt(diff), std::sqrt(sum)) * kRadToDeg;
}

/// One Gaussian's attributes as float32 pointers: mean [3], rotation [4], scale [3], opacity, sh [K, 3].
struct GaussianView {
  const float* mean;
  const float* rotation;
  const float* scale;
  float opacity;
  const float* sh;
};

/// Adds the errors of `test` against `ref` (one Gaussian with k_count SH coefficients per channel).
inline void accumulate_gaussian(const GaussianView& ref, const GaussianView& test, uint32_t k_count,
                                Accumulators* acc) {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = static_cast<double>(test.mean[a]) - ref.mean[a];
    d2 += d * d;
  }
  acc->position.add(std::sqrt(d2));
  acc->rotation.add(rotation_angle_deg(ref.rotation, test.rotation));
  const double largest = std::fmax(std::fmax(ref.scale[0], ref.scale[1]), ref.scale[2]);
  for (int a = 0; a < 3; ++a) {
    const double s = ref.scale[a];
    const double t = test.scale[a];
    acc->scale.add(t == s ? 0.0 : std::fabs(t - s) / s);
    acc->scale_of_largest.add(t == s ? 0.0 : std::fabs(t - s) / largest);
  }
  acc->opacity.add(std::fabs(static_cast<double>(test.opacity) - ref.opacity));
  for (uint32_t k = 0; k < k_count; ++k) {
    const uint32_t d = format::sh_degree_of_coefficient(k);
    for (uint32_t c = 0; c < 3; ++c) {
      const double e = std::fabs(static_cast<double>(test.sh[k * 3 + c]) - ref.sh[k * 3 + c]);
      acc->sh[d].add(e);
      acc->sh_channel[d][c].add(e);
    }
  }
}

}  // namespace rgs::converter::detail
