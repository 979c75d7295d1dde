// The quantized runtime profile of a scene, section by section, as stored in a .rgs file.
#pragma once

#include <cstdint>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"

namespace rgs::format {

/// A scene in the .rgs runtime profile (SPEC.md §4). Arrays hold `count` Gaussians in the same order.
struct EncodedScene {
  SceneMetadata metadata;
  Provenance provenance;
  uint64_t count = 0;
  /// [N, 3] float32 means, world units (bit-exact copy of the source).
  std::vector<float> means;
  /// [N, 4] binary16 bits of the normalized quaternion, order metadata.quaternion_order (w, x, y, z).
  std::vector<uint16_t> rotations;
  /// [N, 3] binary16 bits of the scales, encoding metadata.scale_encoding.
  std::vector<uint16_t> scales;
  /// [N] binary16 bits of the sigmoid-activated opacity.
  std::vector<uint16_t> opacities;
  /// [N, K, 3] int8 SH, K = (sh_degree+1)^2, channel fastest; value = sh_quantization.scales[d][c] * q.
  std::vector<int8_t> sh;
  /// Empty, or [N, 3] int8 residuals r of the DC term (SPEC §4.8): DC = scales[0][c] * (q + r / 256),
  /// q the DC code of `sh`. Refines the INT8 DC to 1/256 of its step; other coefficients are unaffected.
  std::vector<int8_t> sh_dc_residual;

  /// True when every array has the length that count and metadata.sh_degree imply (sh_dc_residual: 0 or 3N).
  bool is_consistent() const;
};

/// Decodes the runtime profile into float32 Gaussians, the way both renderers see them: FP16 widened,
/// scales exp'd when stored as log, SH = s[d][c] * q (paper Eq. quant), the DC term refined by its residual when
/// there is one (sh_dc_value). Rotations are returned as stored
/// (not renormalized). Ranges of the scene are decoded on up to `threads` threads (0: the machine's hardware
/// threads); the values do not depend on them. Errors: kCorruptData when the arrays are inconsistent with count
/// and degree, kOutOfMemory when the float arrays cannot be allocated.
Result<GaussianCloud> dequantize(const EncodedScene& scene, uint32_t threads = 0);

/// Dequantizes Gaussians [first, first + count) of `scene` into `out` (resized to count, sh_degree set),
/// as dequantize() does for the whole scene; lets callers bound memory by working in chunks.
/// Errors: kCorruptData (inconsistent arrays), kInvalidArgument (range outside [0, scene.count)),
/// kOutOfMemory (`out` is then left empty).
Status dequantize_range(const EncodedScene& scene, uint64_t first, uint64_t count, GaussianCloud* out);

/// The DC value of channel c for DC code q, scale s = scales[0][c] and residual r (SPEC §4.8): s * (q + r / 256),
/// one rounded product, since q + r / 256 is exact in float32. Every renderer decodes the DC term through it
/// (the GPU kernels with the same expression).
inline float sh_dc_value(float s, int8_t q, int8_t r) {
  return s * (static_cast<float>(q) + static_cast<float>(r) * (1.0f / 256.0f));
}

/// Degree d of SH coefficient index k (0 for k = 0, 1 for 1..3, 2 for 4..8, 3 for 9..15).
constexpr uint32_t sh_degree_of_coefficient(uint32_t k) { return k == 0 ? 0 : k < 4 ? 1 : k < 9 ? 2 : 3; }

}  // namespace rgs::format
