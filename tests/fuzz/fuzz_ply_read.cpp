// Fuzz target: parse untrusted PLY bytes (header, binary and ascii bodies) under both invalid-value
// policies. Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour.
// kSanitize must keep only renderable Gaussians, and what it keeps is then converted as rgs-convert does
// (quantize, write, validate): conversion must succeed, unless the means span more than float32 holds, and
// the file must pass validate(). Dictionary of PLY keywords: fuzz_ply_read.dict.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "fuzz_check.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::converter::PlyReadOptions options;
  options.max_gaussians = 1u << 20;
  const auto rejected = rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  options.invalid_policy = rgs::converter::InvalidPolicy::kSanitize;
  options.hash_file = true;
  const auto sanitized = rgs::converter::read_ply_bytes(data, size, "<fuzz>", options);
  if (rejected.ok()) {
    RGS_FUZZ_CHECK(sanitized.ok(), sanitized.status().to_string());
    RGS_FUZZ_CHECK(sanitized->cloud.size() == rejected->cloud.size() && sanitized->hygiene.dropped_gaussians == 0,
                   "kSanitize dropped Gaussians that kReject accepted");
  }
  if (!sanitized.ok()) return 0;
  const rgs::format::GaussianCloud& cloud = sanitized->cloud;
  RGS_FUZZ_CHECK(cloud.is_consistent(), "inconsistent cloud");
  RGS_FUZZ_CHECK(cloud.size() + sanitized->hygiene.dropped_gaussians == sanitized->declared_vertices,
                 "kept + dropped != declared vertices");
  // kSanitize keeps only Gaussians that can be rendered (docs/INPUT_HYGIENE.md): finite values, opacity in
  // [0, 1], a rotation that normalizes.
  auto all_finite = [](const std::vector<float>& v) {
    return std::all_of(v.begin(), v.end(), [](float x) { return std::isfinite(x); });
  };
  RGS_FUZZ_CHECK(all_finite(cloud.means) && all_finite(cloud.rotations) && all_finite(cloud.scales) &&
                     all_finite(cloud.sh),
                 "kSanitize kept a non-finite value");
  RGS_FUZZ_CHECK(std::all_of(cloud.opacities.begin(), cloud.opacities.end(),
                             [](float o) { return o >= 0.f && o <= 1.f; }),
                 "kSanitize kept an opacity outside [0, 1]");

  rgs::converter::QuantizeOptions quantize_options;
  quantize_options.scale_encoding = (size & 1) ? rgs::format::ScaleEncoding::kLog
                                               : rgs::format::ScaleEncoding::kLinear;
  auto scene = rgs::converter::quantize(cloud, quantize_options);
  if (!scene.ok() && quantize_options.scale_encoding == rgs::format::ScaleEncoding::kLinear) {
    // Linear scales above the FP16 range are refused with the advice to use log scales: that must work.
    quantize_options.scale_encoding = rgs::format::ScaleEncoding::kLog;
    scene = rgs::converter::quantize(cloud, quantize_options);
  }
  // The one refusal of valid values: means spanning more than float32 holds (their bounding sphere's radius
  // overflows, SPEC §4.1.1).
  if (!scene.ok() && std::isinf(rgs::converter::compute_bounds(cloud).sphere_radius) &&
      scene.status().code() == rgs::StatusCode::kInvalidArgument) {
    return 0;
  }
  RGS_FUZZ_CHECK(scene.ok(), scene.status().to_string());
  const auto bytes = rgs::format::serialize_scene(*scene);
  RGS_FUZZ_CHECK(bytes.ok(), bytes.status().to_string());
  const rgs::Status valid = rgs::format::validate(bytes->data(), bytes->size());
  RGS_FUZZ_CHECK(valid.ok(), valid.to_string());
  return 0;
}
