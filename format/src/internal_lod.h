// Private pieces of the level-of-detail index (format/SPEC.md §4.9) shared by the writer, the reader and the
// validator: its record, its structural rules, and the per-range checks (lod.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "rgs/format/lod.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"

namespace rgs::format::detail {

/// §4.9 The structural rules of an index for a file of `gaussian_count` Gaussians: 1 ≤ C ≤ N, 1 ≤ L ≤
/// kMaxLodLevels, L·C records whose ranges tile [0, N) in record order (`first` is checked, not trusted),
/// counts ≥ 1 and non-increasing with the level, errors finite, 0 at level 0 and non-decreasing, chunk centres
/// finite and radii finite and ≥ 0. kCorruptData naming the chunk and level otherwise.
Status check_lod_structure(const LodIndex& index, uint64_t gaussian_count);

/// §4.9 Serializes a checked index (check_lod_structure) into its section_bytes() raw bytes.
std::vector<uint8_t> encode_lod(const LodIndex& index);

/// §4.9 Parses the raw bytes of a lod section (size 16 + 16·C + 24·L·C exactly, reserved fields 0), fills each
/// level's `first` from the record order and applies check_lod_structure(). kCorruptData otherwise.
Status decode_lod(const uint8_t* raw, size_t size, uint64_t gaussian_count, LodIndex* out);

/// §4.9 Views of Gaussians [first, first + count) of the per-Gaussian sections whose raw little-endian bytes start
/// at `parts` (means, rotations, scales, opacities, sh, sh_dc_residual; a null part gives an empty view) in a scene
/// of SH degree `sh_degree`.
LodRangeView lod_range_view(const std::array<const uint8_t*, 6>& parts, uint64_t first, uint64_t count,
                            uint32_t sh_degree);

/// §4.9 XXH64 of a range's bytes: means, rotations, scales, opacities, sh, then sh_dc_residual when present,
/// as one stream.
uint64_t lod_range_checksum(const LodRangeView& range);

/// §4.9 The XXH64 of the whole range `range` (level `level` of chunk `chunk`) against the index:
/// kChecksumMismatch naming the chunk and level.
Status check_lod_checksum(const LodIndex& index, uint32_t level, uint32_t chunk, const LodRangeView& range);

/// §4.9 The value rules of SPEC §4.3–§4.7 and the chunk sphere's rule for the Gaussians `range` holds: the whole
/// range or a slice of it (range.first is then the slice's first Gaussian, which messages name).
/// kCorruptData naming the chunk, level and Gaussian.
Status check_lod_values(const LodIndex& index, uint32_t level, uint32_t chunk, const LodRangeView& range,
                        const SceneMetadata& metadata);

/// §4.9 Checks level `level` of chunk `chunk` whose bytes `range` holds: the range checksum (when
/// `verify_checksum`), the value rules of SPEC §4.3–§4.7 for each Gaussian, and that each Gaussian's 3σ
/// extent lies inside the chunk's sphere. kChecksumMismatch / kCorruptData naming the chunk, level and Gaussian.
Status check_lod_range(const LodIndex& index, uint32_t level, uint32_t chunk, const LodRangeView& range,
                       const SceneMetadata& metadata, bool verify_checksum);

}  // namespace rgs::format::detail
