// 8-bit conversion of rendered images, as 3DGS saves them.
#pragma once

#include <cstdint>
#include <vector>

namespace rgs::runtime {

/// Converts a float image to 8 bits per channel the way 3DGS writes PNGs: v8 = floor(clamp(v, 0, 1)·255 + 0.5),
/// no gamma change. NaN maps to 0.
/// @param rgb  [H, W, 3] float32 (any channel count works: the conversion is per value).
/// @return the same shape as uint8.
std::vector<uint8_t> to_8bit(const std::vector<float>& rgb);

}  // namespace rgs::runtime
