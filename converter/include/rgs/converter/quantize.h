// Quantizes float Gaussians into the .rgs runtime profile (paper §"Compact Attribute Storage").
#pragma once

#include <cstdint>

#include "rgs/converter/attribute_errors.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"

namespace rgs::converter {

struct QuantizeOptions {
  /// How scales are stored in FP16 (metadata.h explains the trade-off).
  format::ScaleEncoding scale_encoding = format::ScaleEncoding::kLinear;
  /// SH scale rule: 100 = max |SH| / 127 (paper Eq. quant); P in (0, 100) uses the P-th percentile of
  /// |SH| per (degree, channel) and clips larger coefficients to ±127 (counted in the report).
  float sh_clip_percentile = 100.0f;
  /// Precision of the DC term (k = 0), 8 or 16 bits. 8: the INT8 code alone (paper Eq. quant). 16 (default):
  /// also an INT8 residual in 1/256 of the code's step (SPEC §4.8, +3 bytes a Gaussian), which keeps the DC
  /// term, the whole colour of an SH-0 scene, far below the other attributes' errors (docs/AUDITS.md).
  uint32_t sh_dc_bits = 16;
};

/// What quantization did beyond rounding, for the conversion summary and the audit.
struct QuantizationReport {
  /// SH coefficients per degree d and channel c whose |q| would exceed 127 and were clipped (only with
  /// percentile clipping).
  uint64_t sh_clipped[4][3] = {};
  /// Non-zero scale values stored as binary16 subnormals (|v| < 2^-14 ≈ 6.1e-5), where the relative
  /// precision falls below 2^-11. Only linear scales get there in practice.
  uint64_t scales_subnormal = 0;
  /// Non-zero scale values that rounded to binary16 zero (linear scales below 2^-25 ≈ 3e-8).
  uint64_t scales_flushed_to_zero = 0;
  /// Largest flushed scale relative to its own Gaussian's largest axis: what flushing changes in the
  /// Gaussian's footprint (0 when none were flushed). Typically far below 1e-3: such an axis was already
  /// thinner than the 0.3 px² dilation every 3DGS renderer adds.
  double max_flushed_of_largest_axis = 0;
};

/// Quantizes `cloud` (which must be consistent and finite): FP32 means copied bit-exactly, rotations
/// normalized then FP16, scales (log scales at most 88.6875, SPEC §4.5) and activated opacities FP16, SH
/// symmetric INT8 with s[d][c] = max_i |SH[i][d][c]| / 127 (or the chosen percentile), q =
/// round-half-away(SH / s) clamped to ±127; with sh_dc_bits 16 the DC residual r = round-half-away(256 · (SH / s
/// − q)) clamped to [−127, 127].
/// Fills metadata: SH degree, conventions, bounds (compute_bounds) and the quantization.
/// When `errors` is not null it also receives the per-attribute errors of the result, measured in the same
/// pass while the values are in cache: bit-identical to measure_quantization_errors(cloud, result).
/// Deterministic whatever the number of threads (report and errors included).
/// Errors: kInvalidArgument (inconsistent cloud, percentile outside (0, 100], sh_dc_bits not 8 or 16, a
/// non-finite or invalid value,
/// means whose bounding sphere radius overflows float32).
Result<format::EncodedScene> quantize(const format::GaussianCloud& cloud, const QuantizeOptions& options,
                                      QuantizationReport* report = nullptr, AttributeErrors* errors = nullptr);

/// The scene-wide statistics quantize() takes from a whole cloud, gathered batch by batch for a scene read in
/// batches (out-of-core conversion): every value checked as quantize() checks it, and max |SH| per (degree,
/// channel). Only the max rule (sh_clip_percentile 100): a percentile needs every coefficient at once.
class QuantizeScan {
 public:
  explicit QuantizeScan(const QuantizeOptions& options);
  /// Checks and scans `batch`, whose first Gaussian is Gaussian `first` of the scene (errors name that index).
  /// Errors: kInvalidArgument as quantize() (and for a percentile below 100), kOutOfMemory.
  Status add(const format::GaussianCloud& batch, uint64_t first);
  /// The SH scales of every batch added, as quantize() computes them for the whole cloud.
  format::ShQuantization sh_quantization(uint32_t sh_degree) const;

 private:
  QuantizeOptions options_;
  float max_abs_[4][3] = {};
};

/// quantize() with given SH scales (QuantizeScan's) instead of scales computed from `cloud`: a batch of a scene
/// gets exactly the codes quantize() of the whole scene gives its Gaussians. Metadata as quantize() fills it,
/// its bounds those of `cloud`. Errors: those of quantize() (an invalid `shq` is kInvalidArgument).
Result<format::EncodedScene> quantize(const format::GaussianCloud& cloud, const QuantizeOptions& options,
                                      const format::ShQuantization& shq, QuantizationReport* report = nullptr,
                                      AttributeErrors* errors = nullptr);

/// Bounds of the means: AABB, and a sphere centred on the AABB centre whose radius is the largest
/// distance to a mean (computed in double, rounded up, so every mean is inside in float32). The radius is
/// +inf when the means span more than float32 holds (quantize() refuses such a cloud).
format::SceneBounds compute_bounds(const format::GaussianCloud& cloud);

}  // namespace rgs::converter
