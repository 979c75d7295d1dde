// PNG and EXR output through OpenImageIO (host-only tools; GPU binaries use runtime/image_io.h instead).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::tools {

/// Writes an 8-bit PNG atomically (a temporary in the same directory, renamed on success).
/// @param pixels  [H, W, channels] uint8, row-major, top row first; channels 1 (grey) or 3 (RGB).
/// @return kInvalidArgument on a size mismatch; kIoError naming `path` with OpenImageIO's message.
Status write_png8(const std::string& path, uint32_t width, uint32_t height, uint32_t channels,
                  const std::vector<uint8_t>& pixels);

/// Writes a float32 RGBA OpenEXR file atomically: linear RGB as rendered (not clamped) and alpha = 1 − T.
/// @param rgb    [H, W, 3] float32.  @param alpha  [H, W] float32.
/// @return kInvalidArgument on a size mismatch; kIoError naming `path`.
Status write_exr_rgba(const std::string& path, uint32_t width, uint32_t height, const std::vector<float>& rgb,
                      const std::vector<float>& alpha);

}  // namespace rgs::tools
