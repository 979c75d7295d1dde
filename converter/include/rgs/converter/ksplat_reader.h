// Reads GaussianSplats3D `.ksplat` files: the SplatBuffer that mkkellogg's viewer saves and loads, version 0.1.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "rgs/converter/interop.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Bytes of the file header and of each section header.
constexpr size_t kKsplatHeaderBytes = 4096;
constexpr size_t kKsplatSectionHeaderBytes = 1024;

/// True when `head` (the first `n` bytes of a file of `file_size` bytes) starts a .ksplat file read_ksplat reads:
/// bytes 0..3 = 0, 1, 0, 0 (version 0.1), a level of 0..2 in the u16 at byte 20, bytes 22..23 zero, and room for
/// the headers it declares. The format has no magic: dispatch tries this after every format with a signature.
bool looks_like_ksplat(const uint8_t* head, size_t n, uint64_t file_size);

/// Reads a .ksplat file into activated float Gaussians. Layout, all little-endian, as the SplatBuffer class of
/// GaussianSplats3D (src/loaders/SplatBuffer.js: parseHeader, parseSectionHeaders, calculateComponentStorage,
/// writeSplatDataToSectionBuffer; converter/INTEROP.md ".ksplat") lays it out:
/// - header, 4096 bytes: u8 version major (0) and minor (1); u32 at byte 4 section count, at 8 sections loaded,
///   at 12 Gaussian count, at 16 Gaussians loaded; u16 at 20 compression level; f32 at 24..32 scene centre
///   (unused); f32 at 36 and 40 the range [min, max] of 8-bit SH values (0 or NaN stands for ∓1.5, as in the JS).
/// - one 1024-byte header per section: u32 at 0 Gaussians loaded, at 4 Gaussian count, at 8 bucket size, at
///   12 bucket count; f32 at 16 bucket block size; u16 at 20 bytes per bucket (12); u32 at 24 the position range
///   R (0 stands for 32767), at 28 the section's bytes (not read: the counts decide), at 32 full buckets, at 36
///   partially filled buckets; u16 at 40 SH degree.
/// - the sections, in order: the u32 lengths of the partially filled buckets, each bucket's centre (3 × f32),
///   then the Gaussians, bucket after bucket: full buckets hold `bucket size` each, the others their length.
/// - one Gaussian: position, scale (linear), rotation (w, x, y, z), colour RGBA as 4 × u8, then SH rest.
///   Level 0 stores floats as f32; levels 1 and 2 as f16, and positions as u16 offsets from their bucket's centre:
///   centre + (u − R) · block size / 2 / R. The SH rest is f32 (level 0), f16 (1) or u8 (2: min + u/255 ·
///   (max − min)), band after band (degree 1: 9 values, 2: 15, 3: 21), within a band channel after channel, each
///   channel's coefficients in order.
/// Decoded as the viewer renders them: f_dc = (c/255 − 0.5)/0.28209479 and opacity = a/255 (the writer stores
/// floor(255 · colour) and floor(255 · sigmoid(logit))), quaternions normalized. Frame: the writer copies the
/// PLY's axes, so the stored frame is RDF and convert_frame changes nothing. The writer reorders the Gaussians
/// (by distance to the scene centre, then by bucket) and by default drops those of alpha byte 0.
/// Checked before anything is allocated: version 0.1, level 0..2, SH degree 0..3, counts loaded equal to the counts,
/// bucket lengths adding up to each section's count, every section inside the file and the last ending at its end.
/// Errors name `path` and the cause: kIoError, kCorruptData (sizes or counts that disagree, negative scales,
/// invalid values under kReject), kUnsupportedVersion, kUnsupportedFeature (level 3+, SH degree 4+),
/// kLimitExceeded, kOutOfMemory.
Result<InteropScene> read_ksplat(const std::string& path, const InteropReadOptions& options = {});

/// Same as read_ksplat on bytes in memory (tests, fuzzing). `name` is used in error messages.
Result<InteropScene> read_ksplat_bytes(const uint8_t* data, size_t size, const std::string& name,
                                       const InteropReadOptions& options = {});

}  // namespace rgs::converter
