// Constants of the .rgs container, version 1.6. Normative text: format/SPEC.md; section numbers below
// refer to it.
#pragma once

#include <cstdint>

namespace rgs::format {

/// §2 Magic: "\x89RGS\r\n\x1a\n". The non-ASCII first byte and the CR LF / ^Z bytes catch text-mode
/// transfers and 7-bit channels, as in PNG.
inline constexpr uint8_t kMagic[8] = {0x89, 'R', 'G', 'S', 0x0d, 0x0a, 0x1a, 0x0a};

/// §2 Version this library writes. Readers accept any minor of kFormatMajor; newer majors are refused
/// with kUnsupportedVersion.
inline constexpr uint16_t kFormatMajor = 1;
inline constexpr uint16_t kFormatMinor = 6;

/// §6 A format version, compared as (major, minor).
struct FormatVersion {
  uint16_t major = 0;
  uint16_t minor = 0;
};
/// True when `v` is `min` or newer.
constexpr bool version_at_least(FormatVersion v, FormatVersion min) {
  return v.major > min.major || (v.major == min.major && v.minor >= min.minor);
}

/// §6 Feature gates: the first version in which each feature may appear. The writer stamps a file with
/// the newest version any feature it uses requires (1.0 for everything version 1.0 defines); a reader
/// rejects a feature in a file stamped older than its gate with kCorruptData.
inline constexpr FormatVersion kMinVersionForZstdCodec{1, 0};
inline constexpr FormatVersion kMinVersionForProvenance{1, 0};
inline constexpr FormatVersion kMinVersionForLogScales{1, 0};
/// §3.3 Codecs 2 (draco) and 3 (quantized), the archive profile; they also set kRequiredFlagArchiveCodecs.
inline constexpr FormatVersion kMinVersionForArchiveCodecs{1, 1};
/// §4.8 The optional sh_dc_residual section, which refines the INT8 DC term to 1/256 of its step.
inline constexpr FormatVersion kMinVersionForShDcResidual{1, 2};
/// §4.9 The level-of-detail index (section lod, required flag kRequiredFlagLod).
inline constexpr FormatVersion kMinVersionForLod{1, 3};
/// §3.3.2 SH transform 6 (colour differences), with its required flag kRequiredFlagShColourDifferences.
inline constexpr FormatVersion kMinVersionForShColourDifferences{1, 4};
/// §3.3.2 Quantized codes stored as an .xz stream, with its required flag kRequiredFlagXzCodes.
inline constexpr FormatVersion kMinVersionForXzCodes{1, 5};
/// §2.2, §4.6 Opacities of a scene trained with the 2D Mip filter, with its required flag kRequiredFlagAntialiased.
inline constexpr FormatVersion kMinVersionForAntialiased{1, 6};

/// §2 Fixed sizes, in bytes.
inline constexpr uint32_t kHeaderSize = 64;
inline constexpr uint32_t kSectionEntrySize = 64;
/// §4.1 Size of the metadata record (the metadata section's raw size).
inline constexpr uint32_t kMetadataSize = 128;
/// §3 Every section starts at a multiple of this (mmap + one cudaMemcpy per section).
inline constexpr uint64_t kSectionAlignment = 256;

/// §2.2 Flag bits. Required bits this reader does not know give kUnsupportedFeature; unknown optional
/// bits are ignored. Version 1.0 defines none of either; 1.1, 1.3, 1.4, 1.5 and 1.6 define one required bit each.
/// §2.2 Set when any section uses codec 2 or 3 (§3.3), so that a 1.0 reader refuses the file
/// (kUnsupportedFeature) instead of failing on an unknown codec deeper in the table.
inline constexpr uint32_t kRequiredFlagArchiveCodecs = 1u << 0;
/// §2.2, §4.9 Set when the file has a level-of-detail index: its per-Gaussian sections hold every level of
/// every chunk, which a reader that renders them all would draw on top of each other, so a 1.2 reader must
/// refuse the file (kUnsupportedFeature).
inline constexpr uint32_t kRequiredFlagLod = 1u << 1;
/// §2.2, §3.3.2 Set when the sh section uses transform 6 (its codes stored as colour differences), which a 1.3
/// reader would refuse as corrupt: with the flag it refuses the file as unsupported (kUnsupportedFeature).
inline constexpr uint32_t kRequiredFlagShColourDifferences = 1u << 2;
/// §2.2, §3.3.2 Set when a quantized section stores its codes as an .xz stream instead of a zstd frame, which a
/// 1.4 reader would refuse as corrupt: with the flag it refuses the file as unsupported (kUnsupportedFeature).
inline constexpr uint32_t kRequiredFlagXzCodes = 1u << 3;
/// §2.2, §4.6 Set when the scene was trained with the 2D Mip filter (Mip-Splatting; gsplat's antialiased mode):
/// a renderer scales each opacity by the filter's compensation (SceneMetadata::antialiased). A 1.5 reader would
/// draw the scene too opaque where Gaussians are small on screen, so it must refuse the file (kUnsupportedFeature).
inline constexpr uint32_t kRequiredFlagAntialiased = 1u << 4;
inline constexpr uint32_t kKnownRequiredFlags = kRequiredFlagArchiveCodecs | kRequiredFlagLod |
                                                kRequiredFlagShColourDifferences | kRequiredFlagXzCodes |
                                                kRequiredFlagAntialiased;
inline constexpr uint32_t kKnownOptionalFlags = 0;

/// §4 Section identifiers. Readers skip (but still bounds- and checksum-check) ids they do not know.
enum class SectionId : uint32_t {
  kMetadata = 1,     ///< §4.1 conventions, bounds, SH quantization scales
  kProvenance = 2,   ///< §4.2 key/value strings: source file, converter version, options
  kMeans = 16,       ///< §4.3 [N, 3] float32
  kRotations = 17,   ///< §4.4 [N, 4] float16 (w, x, y, z), normalized
  kScales = 18,      ///< §4.5 [N, 3] float16, linear or log per metadata
  kOpacities = 19,   ///< §4.6 [N] float16, sigmoid-activated
  kSh = 20,          ///< §4.7 [N, K, 3] int8, symmetric per (degree, channel) scale
  kShDcResidual = 21,///< §4.8 [N, 3] int8, optional: the DC term's residual in 1/256 of its INT8 step
  kLod = 22,         ///< §4.9 bytes: chunks, their bounding spheres and level ranges (1.3, with kRequiredFlagLod)
};

/// §3.1 How a section's stored bytes encode its raw bytes.
enum class Codec : uint16_t {
  kNone = 0,  ///< stored == raw
  kZstd = 1,  ///< one zstd frame with content size and content checksum
  kDraco = 2,      ///< §3.3.1 means only: a Draco point cloud (quantized positions), archive profile
  kQuantized = 3,  ///< §3.3.2 rotations, scales, opacities, sh: transform header + zstd frame (or .xz stream) of codes
};

/// §3.3 Whether `codec` is one of the archive profile's (decoded whole, lossy at encode).
constexpr bool is_archive_codec(Codec codec) { return codec == Codec::kDraco || codec == Codec::kQuantized; }

/// §3.1 Element type of a section's raw bytes, little-endian.
enum class ElementType : uint16_t {
  kBytes = 0,    ///< opaque bytes (metadata, provenance); components = 1
  kInt8 = 1,
  kFloat16 = 2,  ///< IEEE 754 binary16
  kFloat32 = 3,  ///< IEEE 754 binary32
};

/// Size in bytes of one component of `type`, or 0 for an unknown value.
constexpr uint32_t element_type_size(ElementType type) {
  switch (type) {
    case ElementType::kBytes: return 1;
    case ElementType::kInt8: return 1;
    case ElementType::kFloat16: return 2;
    case ElementType::kFloat32: return 4;
  }
  return 0;
}

/// Human-readable names for tools ("means", "zstd", "f16"); "unknown" for other values.
const char* section_name(SectionId id);
const char* codec_name(Codec codec);
const char* element_type_name(ElementType type);

}  // namespace rgs::format
