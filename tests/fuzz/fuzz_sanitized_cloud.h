// What every reader's fuzz target asserts about the scenes it reads (fuzz_ply_read.cpp,
// fuzz_interop_read.cpp): the two invalid-value policies agree, kSanitize keeps only renderable Gaussians
// (docs/INPUT_HYGIENE.md), and what it keeps converts as rgs-convert does (quantize, write, validate).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_archive.h"
#include "fuzz_check.h"
#include "rgs/converter/interop.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace rgs::fuzz {

/// kSanitize keeps only Gaussians that can be rendered: finite values, opacity in [0, 1]. They quantize
/// (linear scales, or log scales when `log_scales` or when linear ones overflow FP16) unless the means span
/// more than float32 holds (their bounding sphere's radius overflows, SPEC §4.1.1: the one refusal of valid
/// values), the written file passes validate(), and the scene archives (check_archive).
inline void check_converts(const format::GaussianCloud& cloud, bool log_scales) {
  auto all_finite = [](const std::vector<float>& v) {
    return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
  };
  RGS_FUZZ_CHECK(all_finite(cloud.means) && all_finite(cloud.rotations) && all_finite(cloud.scales) &&
                     all_finite(cloud.sh),
                 "kSanitize kept a non-finite value");
  RGS_FUZZ_CHECK(std::all_of(cloud.opacities.begin(), cloud.opacities.end(),
                             [](float o) { return o >= 0.f && o <= 1.f; }),
                 "kSanitize kept an opacity outside [0, 1]");

  converter::QuantizeOptions options;
  options.scale_encoding = log_scales ? format::ScaleEncoding::kLog : format::ScaleEncoding::kLinear;
  auto scene = converter::quantize(cloud, options);
  if (!scene.ok() && options.scale_encoding == format::ScaleEncoding::kLinear) {
    // Linear scales above the FP16 range are refused with the advice to use log scales: that must work.
    options.scale_encoding = format::ScaleEncoding::kLog;
    scene = converter::quantize(cloud, options);
  }
  if (!scene.ok() && std::isinf(converter::compute_bounds(cloud).sphere_radius) &&
      scene.status().code() == StatusCode::kInvalidArgument) {
    return;
  }
  RGS_FUZZ_CHECK(scene.ok(), scene.status().to_string());
  const auto bytes = format::serialize_scene(*scene);
  RGS_FUZZ_CHECK(bytes.ok(), bytes.status().to_string());
  const Status valid = format::validate(bytes->data(), bytes->size());
  RGS_FUZZ_CHECK(valid.ok(), valid.to_string());
  check_archive(*scene);
}

inline uint64_t declared_of(const converter::PlyScene& scene) { return scene.declared_vertices; }
inline uint64_t declared_of(const converter::InputScene& scene) { return scene.declared_vertices; }
inline uint64_t declared_of(const converter::InteropScene& scene) { return scene.declared_gaussians; }

/// Reads `data` with `read` (a read_*_bytes function) under kReject, then kSanitize, with `options`
/// otherwise unchanged. Whatever kReject accepts, kSanitize accepts unchanged; what kSanitize keeps is a
/// consistent cloud, kept + dropped = declared, and it converts (check_converts).
template <typename Read, typename Options>
void check_reader(Read read, Options options, const uint8_t* data, size_t size) {
  options.max_gaussians = 1u << 20;
  options.invalid_policy = converter::InvalidPolicy::kReject;
  const auto rejected = read(data, size, "<fuzz>", options);
  options.invalid_policy = converter::InvalidPolicy::kSanitize;
  const auto sanitized = read(data, size, "<fuzz>", options);
  if (rejected.ok()) {
    RGS_FUZZ_CHECK(sanitized.ok(), sanitized.status().to_string());
    RGS_FUZZ_CHECK(sanitized->cloud.size() == rejected->cloud.size() && sanitized->hygiene.dropped_gaussians == 0,
                   "kSanitize dropped Gaussians that kReject accepted");
  }
  if (!sanitized.ok()) return;
  const format::GaussianCloud& cloud = sanitized->cloud;
  RGS_FUZZ_CHECK(cloud.is_consistent(), "inconsistent cloud");
  RGS_FUZZ_CHECK(cloud.size() + sanitized->hygiene.dropped_gaussians == declared_of(*sanitized),
                 "kept + dropped != declared Gaussians");
  check_converts(cloud, (size & 1) != 0);
}

}  // namespace rgs::fuzz
