// Private decoders of the archive codecs (SPEC.md §3.3), shared by the reader, the validator and the
// archive encoder (which decodes what it wrote, so its `decoded` scene is what readers will see).
#pragma once

#include <cstddef>
#include <cstdint>

#include "rgs/format/metadata.h"
#include "rgs/format/spec.h"
#include "rgs/format/status.h"

namespace rgs::format::detail {

/// §5.5 Archive-coded sections count 1/kArchiveRatioAllowance of their raw size towards the
/// decompression-ratio limit: a real archive legitimately decodes to 4-8x its size, and a section whose
/// decoded size follows from the header's Gaussian count (already bounded by max_gaussians) cannot be
/// inflated by a crafted frame the way a zstd section can.
inline constexpr uint64_t kArchiveRatioAllowance = 4;

/// §3.3.2 Size of the quantized codec's fixed header before its parameters.
inline constexpr size_t kQuantizedHeaderSize = 8;
/// §3.3.2, §3.3.3 Bytes before a quantized section's codes: the fixed header, 4 a parameter, and for the SH
/// codebook (transform 5) the codebook size.
constexpr size_t quantized_header_bytes(size_t params, bool codebook) {
  return kQuantizedHeaderSize + 4 * params + (codebook ? 4 : 0);
}

/// §3.3.2 Transform identifiers of the quantized codec.
enum class QuantizedTransform : uint8_t {
  kSmallestThree = 1,  ///< rotations
  kLogUniform = 2,     ///< scales
  kUniform = 3,        ///< opacities
  kShMultiplier = 4,   ///< sh, per-coefficient codes
  kShCodebook = 5,     ///< sh: a codebook of rest vectors, per-Gaussian DC codes and indices (§3.3.3)
  kShColourDifferences = 6,  ///< sh: transform 4's codes as (R - G, G, B - G), DC planes, then rest records
};

/// True when `codec` may be used on section `id` (§3.3: draco on means, quantized on the other
/// runtime sections).
bool archive_codec_allowed(SectionId id, Codec codec);

/// §3.3.1 Checks a Draco means section without decoding it: the Draco header (point cloud, kd-tree,
/// no metadata) and the point count, which must equal `n`. kCorruptData.
Status check_draco_header(const uint8_t* src, size_t size, uint64_t n);
/// §3.3.1 Decodes a Draco means section into `dst`: [n, 3] float32 little-endian, exactly 12 n bytes.
/// kCorruptData (Draco refuses the stream, wrong point count or attribute), kOutOfMemory.
Status decode_draco_means(const uint8_t* src, size_t size, uint64_t n, uint8_t* dst, size_t raw_size);

/// §3.3.2 Checks a quantized section's header and the header of its codes (a zstd frame, or an .xz stream's
/// header, index and footer) without decoding: transform allowed for `id`, bits, parameter and component counts
/// (`components` = the section's components), finite parameters; `*xz` (when given) says whether the codes are
/// an .xz stream. kCorruptData.
Status check_quantized_header(SectionId id, const uint8_t* src, size_t size, uint64_t n, uint32_t components,
                              bool* xz = nullptr);
/// §3.3.2 Whether a quantized section (its header checked by check_quantized_header, or written by this
/// library) stores its codes as an .xz stream.
bool quantized_codes_are_xz(const uint8_t* src, size_t size);
/// §3.3.2 Decodes a quantized section into its raw runtime bytes (`raw_size` = the entry's raw size).
/// kCorruptData (bad header, frame or stream, or a code out of range), kChecksumMismatch (zstd content
/// checksum), kOutOfMemory.
Status decode_quantized(SectionId id, const SceneMetadata& metadata, const uint8_t* src, size_t size, uint64_t n,
                        uint32_t components, uint8_t* dst, size_t raw_size);

}  // namespace rgs::format::detail
