// Reads Niantic SPZ files (versions 2 and 3: gzip-wrapped; version 4: plaintext header + zstd streams).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "rgs/converter/interop.h"
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
/// "NGSP" with version 4, or a gzip member (1f 8b 08) whose first inflated bytes are "NGSP". When the
/// head is too short to inflate four bytes, a gzip member alone counts. Never reads past head[n - 1].
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
/// (0xADBE0003) naming a flip-only frame overrides RUB as the stored frame; a rotated frame
/// (LFD..RBU) is kUnsupportedFeature. Other extensions are skipped and listed in notes.
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

}  // namespace rgs::converter
