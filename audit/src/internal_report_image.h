// The report's images as data URIs: PNG written by the audit (zlib), base64, and the heatmaps' colour map.
#pragma once

#include <array>
#include <cstdint>
#include <string>

#include "rgs/audit/audit.h"
#include "rgs/format/status.h"

namespace rgs::audit::detail {

/// Matplotlib's "inferno" colour map (its 256 entries, rounded to 8 bits): black at 0, pale yellow at 255.
std::array<uint8_t, 3> inferno(uint8_t level);

/// `image` as "data:image/png;base64,..." (8-bit RGB or grey, no interlace). A grey image with `heat` is
/// coloured through inferno(), so that level 255 (the heat scale) is the top colour.
/// Errors: kInvalidArgument when the pixels do not match the size or channels is not 1 or 3.
Result<std::string> png_data_uri(const Image8& image, bool heat);

}  // namespace rgs::audit::detail
