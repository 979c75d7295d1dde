// Constants of PlayCanvas SOG that the reader and the writers share (private to rgs_converter).
#pragma once

#include <cstdint>

namespace rgs::converter::detail {

/// Entries of every v2 codebook (one per 8-bit code).
inline constexpr uint32_t kCodebookSize = 256;
/// Largest SH palette: labels are 16-bit.
inline constexpr uint32_t kMaxPaletteEntries = 65536;
/// Palette entries per row of the shN centroids image.
inline constexpr uint32_t kPaletteColumns = 64;

}  // namespace rgs::converter::detail
