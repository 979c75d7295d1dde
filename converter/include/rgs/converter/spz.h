// Niantic SPZ: reads versions 2 and 3 (gzip-wrapped) and 4 (plaintext header + zstd streams), writes version 4
// by default (2 and 3 for older viewers).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/converter/interop.h"
#include "rgs/format/file_io.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Oldest and newest SPZ versions read. Version 1 (float16 positions, never released) is refused.
constexpr uint32_t kMinSpzVersion = 2;
constexpr uint32_t kMaxSpzVersion = 4;
/// First version storing rotations as "smallest three" (2-bit index + 3 × 10 bits) instead of x, y, z
/// as 8 bits each.
constexpr uint32_t kMinSpzVersionForSmallestThree = 3;
/// First version with the 32-byte plaintext header, table of contents and one zstd stream per attribute.
constexpr uint32_t kMinSpzVersionForZstd = 4;

/// True when `head` (the first `n` bytes of a file; pass at least 64, ideally 4096) starts an SPZ file:
/// "NGSP" (whatever its version: read_spz names a version it does not read, or a damaged one), or a gzip member
/// (1f 8b 08) whose first inflated bytes are "NGSP". When the
/// head is too short to inflate four bytes, or the member is damaged before them (so that the SPZ reader names
/// the damage), a gzip member alone counts. Never reads past head[n - 1].
bool looks_like_spz(const uint8_t* head, size_t n);

/// Reads an SPZ file into activated float Gaussians.
///
/// Layout (nianticlabs/spz README and load-spz.cc; converter/INTEROP.md): per Gaussian a 24-bit signed
/// fixed-point position (x, y, z, `fractionalBits` fractional bits), 8-bit alpha (opacity = a/255,
/// stored directly as the activated value), 8-bit DC colour per channel (f_dc = (c/255 − 0.5)/0.15),
/// 8-bit log scales (log s = b/16 − 10), the rotation (v2: x, y, z as b/127.5 − 1 with w = sqrt(1 −
/// |xyz|²); v3+: smallest three of (x, y, z, w)), and SH rest coefficients as (b − 128)/128, coefficient-
/// major with the channel fastest. SH degree 0..3 (degree 4 is kUnsupportedFeature: the cloud holds at
/// most 3).
///
/// Frame: the SPZ format stores RUB axes (x right, y up, z back; three.js/OpenGL). The PLY files of
/// 3DGS training are RDF (x right, y down, z forward), and the spz library's PLY loader labels them RDF,
/// so with convert_frame (default) the reader applies the 180° rotation about x from RUB to RDF:
/// y → −y, z → −z for means, quaternion (w, x, y, z) → (w, x, −y, −z), and the SH signs of that rotation
/// (converter/INTEROP.md lists them). The spz library itself converts only when its caller names the
/// frames (PackOptions::from, UnpackOptions::to), so writers that leave them unspecified store the PLY's
/// axes unchanged (splat-transform 3.7 among them): read those with convert_frame = false
/// (read_scene: SpzFrame::kAsStored; converter/INTEROP.md "SPZ axes"). A SPZ_ADOBE_coordinate_system extension
/// (0xADBE0003) naming a flip-only frame is the stored frame, turned to RDF whatever convert_frame says
/// (InteropScene::frame_declared); a rotated frame (LFD..RBU) is kUnsupportedFeature. Other extensions are skipped and listed in notes.
///
/// Checks before any allocation: version, SH degree, count <= max_gaussians, stream sizes implied by
/// the count, TOC inside the file and streams ending exactly at its end (v4), declared sizes within the
/// largest zstd (32768:1) or deflate (1032:1) expansion of the bytes present, reserved bytes zero.
/// Errors name `path` and the cause: kIoError (unreadable, truncated header, TOC or stream),
/// kCorruptData (not SPZ, bad sizes, non-zero reserved bytes, malformed gzip/zstd data),
/// kUnsupportedVersion (version 1 or above 4), kUnsupportedFeature (SH degree 4, rotated coordinate
/// frame), kChecksumMismatch (gzip CRC-32 or zstd content checksum), kLimitExceeded (count above
/// max_gaussians), kOutOfMemory.
Result<InteropScene> read_spz(const std::string& path, const InteropReadOptions& options = {});

/// Same as read_spz on bytes in memory (tests, fuzzing). `name` is used in error messages.
Result<InteropScene> read_spz_bytes(const uint8_t* data, size_t size, const std::string& name,
                                    const InteropReadOptions& options = {});

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
