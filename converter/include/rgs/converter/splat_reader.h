// Reads antimatter15 `.splat` files: headerless 32-byte records, as the web viewer of that name loads them.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "rgs/converter/interop.h"
#include "rgs/format/status.h"

namespace rgs::converter {

/// Bytes of one .splat record.
constexpr size_t kSplatRecordBytes = 32;

/// True when a file of `file_size` bytes whose first `n` bytes are `head` plausibly is a .splat file.
/// The format has no magic, so dispatch should try this only after every format with a signature
/// failed. Requires: file_size a non-zero multiple of 32; a head that does not start like another
/// known format (ply, NGSP, gzip, glTF, JSON); and every whole record in the head (at least one) with
/// finite positions below 1e7 in magnitude, finite non-negative scales below 1e6 and a rotation whose
/// decoded norm is within [0.7, 1.3] (writers store a unit quaternion).
bool looks_like_splat(const uint8_t* head, size_t n, uint64_t file_size);

/// Reads a .splat file (antimatter15/splat convert.py and main.js; converter/INTEROP.md). Each record,
/// little-endian: position 3 × f32; linear scale 3 × f32; colour RGBA 4 × u8 with RGB = (0.5 +
/// 0.28209479·f_dc)·255 and A = opacity·255; rotation 4 × u8 (w, x, y, z) as floor(q·128 + 128). Decoded as
/// f_dc = (c/255 − 0.5)/0.28209479, opacity = a/255, q = (b − 127.5)/128 (the middle of the interval the
/// byte stands for; measured in converter/INTEROP.md ".splat") then normalized. SH degree 0 (the
/// format has no higher coefficients). Frame: writers copy the PLY's axes unchanged, so the stored frame
/// is RDF and convert_frame changes nothing.
/// Errors name `path` and the format: kIoError (unreadable), kCorruptData (size not a non-zero multiple of
/// 32, negative scales with the first record holding one, invalid values under kReject: non-finite numbers), kLimitExceeded (more than max_gaussians
/// records), kOutOfMemory.
Result<InteropScene> read_splat(const std::string& path, const InteropReadOptions& options = {});

/// Same as read_splat on bytes in memory. `name` is used in error messages.
Result<InteropScene> read_splat_bytes(const uint8_t* data, size_t size, const std::string& name,
                                      const InteropReadOptions& options = {});

}  // namespace rgs::converter
