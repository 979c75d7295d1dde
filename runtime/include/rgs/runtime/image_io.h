// Minimal image output for debugging and for GPU-host binaries that must not link OpenImageIO
// (CONTRIBUTING.md#one-build-two-hosts): 8-bit conversion as 3DGS saves images, and binary PPM (P6).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::runtime {

/// Converts a float image to 8 bits per channel the way 3DGS writes PNGs: v8 = floor(clamp(v, 0, 1)·255 + 0.5),
/// no gamma change. NaN maps to 0.
/// @param rgb  [H, W, 3] float32 (any channel count works: the conversion is per value).
/// @return the same shape as uint8.
std::vector<uint8_t> to_8bit(const std::vector<float>& rgb);

/// Writes a binary PPM (P6, maxval 255) of `width` × `height` RGB pixels.
/// @param rgb8  [H, W, 3] uint8, row-major, top row first.
/// @return kInvalidArgument if rgb8.size() != width·height·3 or a side is 0; kIoError naming `path` if the
/// file cannot be written.
Status write_ppm(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgb8);

}  // namespace rgs::runtime
