// Per-attribute error between two versions of the same Gaussians (source vs decoded .rgs).
#pragma once

#include <cstdint>
#include <vector>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Maximum and root-mean-square of one error measure over all its samples.
struct ErrorStats {
  double max = 0;
  double rms = 0;
  uint64_t samples = 0;
};

/// Errors of `test` against `reference`, one sample per Gaussian (or per coefficient for SH).
struct AttributeErrors {
  /// Euclidean distance between means, world units (scene units; × 1000 gives mm for metric scenes).
  ErrorStats position;
  /// Angle of the rotation taking one orientation to the other, degrees, after normalizing both:
  /// 4·atan2(|q1 − q2|, |q1 + q2|) with q2's sign chosen so q1·q2 >= 0 (q and −q are the same rotation);
  /// equal to 2·acos(|q1·q2|) but accurate for tiny angles.
  ErrorStats rotation_deg;
  /// Relative scale error |s' − s| / s per axis (linear scales). Large for axes far thinner than the
  /// Gaussian's others (FP16 subnormals and flushed zeros below 6.1e-5) without any visible effect: those
  /// axes vanish under the renderers' 0.3 px² dilation. scale_of_largest_axis is the one to act on.
  ErrorStats scale_relative;
  /// Scale error per axis relative to the Gaussian's largest axis, |s' − s| / max(s0, s1, s2) (0 when both
  /// are 0): how much the footprint of the Gaussian changes, in units of its size, which is what a render
  /// sees. A thin axis that FP16 flushes to 0 contributes its own (tiny) size here, not 100 %.
  ErrorStats scale_of_largest_axis;
  /// Absolute error of activated opacity.
  ErrorStats opacity;
  /// Absolute error per SH coefficient, grouped by degree 0..3 (degrees above the cloud's are empty).
  ErrorStats sh[4];
  /// Same, split by degree and channel (R, G, B), for the audit table.
  ErrorStats sh_channel[4][3];
};

/// Compares two clouds of equal size and SH degree. Errors: kInvalidArgument otherwise.
Result<AttributeErrors> measure_attribute_errors(const format::GaussianCloud& reference,
                                                 const format::GaussianCloud& test);

/// Errors of each `test` Gaussian against the `reference` Gaussian it is paired with: test Gaussian j against
/// reference Gaussian reference_of_test[j] (GaussianPairing::reference_of_test, gaussian_pairing.h), for clouds
/// stored in different orders or a test cloud that lacks some reference Gaussians (those are left out of every
/// figure). Accumulated in the reference's order, so the result does not depend on the test cloud's order; for the
/// identity pairing it equals measure_attribute_errors() bit for bit. Errors: kInvalidArgument for clouds of
/// different SH degrees, a pairing whose size is not the test cloud's, or an index that is out of range or paired
/// twice.
Result<AttributeErrors> measure_paired_attribute_errors(const format::GaussianCloud& reference,
                                                        const format::GaussianCloud& test,
                                                        const std::vector<uint64_t>& reference_of_test);

/// Errors of the dequantized `encoded` scene against `reference` (the cloud it was quantized from),
/// identical to measure_attribute_errors(reference, dequantize(encoded)) but dequantizing in chunks of
/// 65,536 Gaussians so memory stays bounded on large scenes. Errors: kInvalidArgument on size or degree
/// mismatch, kCorruptData on an inconsistent `encoded`.
Result<AttributeErrors> measure_quantization_errors(const format::GaussianCloud& reference,
                                                    const format::EncodedScene& encoded);

}  // namespace rgs::converter
