// WebP decoding into RGBA8 for the SOG reader and lossless encoding for the SOG writer (private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// A decoded image: [height, width, 4] uint8, rows top to bottom, RGBA per pixel.
struct RgbaImage {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<uint8_t> rgba;

  uint64_t pixels() const { return uint64_t{width} * height; }
};

/// Reads the dimensions of the WebP in `data[0, size)` from its header, without decoding it.
/// Errors name `name`: kCorruptData (not a WebP, truncated RIFF, invalid header, animated, no pixels).
Status read_webp_size(const uint8_t* data, size_t size, const std::string& name, uint32_t* width, uint32_t* height);

/// Decodes the WebP (lossless or lossy) in `data[0, size)` into `out` (its buffer is reused).
/// The RIFF container's declared size is checked against `size` and the dimensions against `max_pixels`
/// before anything is allocated. Errors name `name`: kCorruptData (not a WebP, truncated, undecodable),
/// kLimitExceeded (more than max_pixels pixels), kOutOfMemory.
Status decode_webp_rgba(const uint8_t* data, size_t size, uint64_t max_pixels, const std::string& name, RgbaImage* out);

/// Encodes `image` ([height, width, 4] uint8 RGBA, width and height 1..16383) as a lossless WebP, every pixel
/// kept exactly (RGB under alpha 0 included). Deterministic. Errors: kInvalidArgument (size), kIoError
/// (libwebp failed, its error code named).
Result<std::vector<uint8_t>> encode_webp_lossless(const RgbaImage& image, const std::string& name);

}  // namespace rgs::converter::detail
