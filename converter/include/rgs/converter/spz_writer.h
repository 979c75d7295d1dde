// Writes float Gaussians as a Niantic SPZ file (version 4 by default; 2 and 3 for older viewers).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/converter/interop.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/file_io.h"
#include "rgs/format/status.h"

namespace rgs::converter {

struct SpzWriteOptions {
  /// SPZ version 2, 3 (gzip-wrapped; 2 stores rotations as 3 × 8 bits) or 4 (zstd streams).
  uint32_t version = 4;
  /// Fractional bits of the 24-bit fixed-point positions; -1 chooses 12 (the spz library's value, a
  /// step of 1/4096 scene units), or fewer when the largest |coordinate| needs more integer bits.
  int fractional_bits = -1;
  /// Bits kept of each 8-bit SH rest value, degree 1 and degrees 2..3 (1..8; fewer compress better).
  /// The defaults are the spz library's.
  uint32_t sh1_bits = 5;
  uint32_t sh_rest_bits = 4;
  /// kRub: turn RoofGS's RDF frame into the RUB axes the SPZ format prescribes (y → −y, z → −z; read_spz
  /// documents it). kAsStored: store the axes unchanged, for readers that skip the turn (INTEROP.md).
  SpzFrame frame = SpzFrame::kRub;
  /// zstd level of the version 4 streams (the spz library uses 12).
  int zstd_level = 12;
};

/// What the SPZ output keeps and loses, for the conversion summary.
struct SpzWriteSummary {
  uint32_t version = 0;
  uint32_t sh_degree = 0;
  uint32_t fractional_bits = 0;
  /// Position step 2^-fractional_bits, scene units (the maximum position error is half of it).
  double position_step = 0;
  /// Values outside what SPZ can hold, clamped to its range: log scales outside [−10, 5.9375] (scale 0
  /// included), DC colours f_dc outside about [−3.33, 3.33], SH rest values outside [−1, 127/128].
  uint64_t scales_clamped = 0;
  uint64_t colors_clamped = 0;
  uint64_t sh_clamped = 0;
  /// Bytes of the file.
  uint64_t bytes = 0;
  /// What the format cannot carry, one sentence each (precision of every attribute, frame).
  std::vector<std::string> limitations;
};

/// Encodes `cloud` (consistent and finite; SH degree 0..3 is carried whole) as SPZ. Quantization, as the
/// spz library reads it back: positions round(x·2^fb) in 24 bits; alpha round(o·255); DC colour
/// round(f_dc·0.15·255 + 127.5); scales round((ln s + 10)·16); rotations normalized, then smallest three
/// (v3+, 9-bit magnitudes over [0, sqrt(1/2)], ≤ 0.08° per component) or x, y, z with w >= 0 as
/// round(q·127.5 + 127.5) (v2); SH rest round(v·128) + 128 rounded to multiples of 2^(8 − bits).
/// Rounding is half away from zero; the output is deterministic (zstd frames with content checksums;
/// gzip without a timestamp). Errors: kInvalidArgument (inconsistent or non-finite cloud, version,
/// bits or fractional_bits out of range, more than 2^32 − 1 Gaussians, a coordinate beyond the 24-bit
/// range at the requested fractional_bits, or at 0 fractional bits).
Result<std::vector<uint8_t>> serialize_spz(const format::GaussianCloud& cloud, const SpzWriteOptions& options = {},
                                           SpzWriteSummary* summary = nullptr);

/// serialize_spz() written atomically to `path`. Errors: as serialize_spz, kIoError naming `path`.
Result<SpzWriteSummary> write_spz(const std::string& path, const format::GaussianCloud& cloud,
                                  const SpzWriteOptions& options = {},
                                  format::FileSink& files = format::atomic_files());

}  // namespace rgs::converter
