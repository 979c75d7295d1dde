// Reads .rgs files: structural checks up front, sections as zero-copy views or decoded on demand.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/file_io.h"
#include "rgs/format/lod.h"
#include "rgs/format/metadata.h"
#include "rgs/format/spec.h"
#include "rgs/format/status.h"

namespace rgs::format {

/// File size below which max_decompression_ratio is applied to this many bytes instead (SPEC §5.5): any
/// file may decode to max_decompression_ratio MiB, however small it is.
inline constexpr uint64_t kDecompressionRatioMinBytes = uint64_t{1} << 20;

/// Bounds applied before any allocation sized by file content (SPEC §5.5, CONTRIBUTING.md#format-changes).
/// Exceeding one gives kLimitExceeded naming the value and the limit.
struct ReadLimits {
  uint64_t max_gaussians = uint64_t{1} << 28;          ///< 268M
  uint64_t max_file_bytes = uint64_t{1} << 40;         ///< 1 TiB
  uint64_t max_section_raw_bytes = uint64_t{1} << 38;  ///< decoded size of one section
  uint32_t max_sections = 64;
  uint32_t max_sh_degree = 3;
  uint64_t max_provenance_bytes = uint64_t{1} << 20;
  /// The known sections (SPEC §3.2) may decode to at most this many bytes per byte of file, counting the
  /// file as at least kDecompressionRatioMinBytes. A zstd frame may legally claim 32768 times its size;
  /// this bound makes what a reader allocates follow what the file's bytes can hold (real scenes compress
  /// less than 2x), so a file under 1 MiB never decodes to more than 8 MiB by default.
  uint32_t max_decompression_ratio = 8;
};

struct ReadOptions {
  ReadLimits limits;
  /// Verify each section's XXH64 when its bytes are accessed (the header + table checksum is always
  /// verified). Turn off only to measure its cost.
  bool verify_checksums = true;
};

/// §2 Header fields as read (magic and reserved bytes already checked).
struct FileHeader {
  uint16_t major = 0;
  uint16_t minor = 0;
  uint32_t required_flags = 0;
  uint32_t optional_flags = 0;
  uint64_t gaussian_count = 0;
  uint32_t section_count = 0;
  uint64_t table_offset = 0;
  uint64_t file_size = 0;
  uint64_t checksum = 0;  ///< XXH64 over header bytes [0, 56) and the section table
};

/// §3.1 One section-table entry as read.
struct SectionEntry {
  SectionId id{};
  Codec codec = Codec::kNone;
  ElementType element_type = ElementType::kBytes;
  uint32_t components = 0;     ///< components per element (3 for means, 4 for rotations, 3K for sh; §3.2)
  uint64_t element_count = 0;  ///< N for per-Gaussian sections, raw_size for byte sections
  uint64_t offset = 0;
  uint64_t stored_size = 0;
  uint64_t raw_size = 0;
  uint64_t checksum = 0;       ///< XXH64 of the stored bytes
};

/// Non-owning byte range.
struct ByteView {
  const uint8_t* data = nullptr;
  size_t size = 0;
};

/// §4.9 Zero-copy views of one level of one chunk of a level-of-detail file: Gaussians [first, first + count)
/// of each per-Gaussian section, as stored (codec none, little-endian), in the file's mapping.
struct LodRangeView {
  uint64_t first = 0;
  uint64_t count = 0;
  ByteView means;           ///< [count, 3] f32
  ByteView rotations;       ///< [count, 4] f16 bits
  ByteView scales;          ///< [count, 3] f16 bits
  ByteView opacities;       ///< [count] f16 bits
  ByteView sh;              ///< [count, K, 3] i8
  ByteView sh_dc_residual;  ///< [count, 3] i8, or empty when the file has none
};

/// Where RgsFile::read_lod_range() copies one range: a destination per part of LodRangeView, each with room for
/// the range's `count` records (the sizes of LodRangeView's parts). `sh_dc_residual` is needed only when the
/// file has that section.
struct LodRangeTarget {
  uint8_t* means = nullptr;           ///< [count, 3] f32
  uint8_t* rotations = nullptr;       ///< [count, 4] f16 bits
  uint8_t* scales = nullptr;          ///< [count, 3] f16 bits
  uint8_t* opacities = nullptr;       ///< [count] f16 bits
  uint8_t* sh = nullptr;              ///< [count, K, 3] i8
  uint8_t* sh_dc_residual = nullptr;  ///< [count, 3] i8
};

/// An opened .rgs file. Opening checks the header, the section table (bounds, alignment, overlap, sizes
/// implied by count and SH degree), the header checksum, and decodes metadata and provenance; section
/// payloads are only touched when asked for. Copies share the underlying mapping; thread-safe for reads.
class RgsFile {
 public:
  /// Memory-maps and opens `path`. Errors name the path: kIoError, kNotRgsFile, kUnsupportedVersion,
  /// kUnsupportedFeature, kCorruptData, kChecksumMismatch, kLimitExceeded.
  static Result<RgsFile> open(const std::string& path, const ReadOptions& options = {});
  /// Opens bytes owned by the caller, which must outlive the RgsFile and its views. `name` is used in
  /// error messages.
  static Result<RgsFile> from_bytes(const uint8_t* data, size_t size, const ReadOptions& options = {},
                                    const std::string& name = "<memory>");

  const FileHeader& header() const { return header_; }
  const std::vector<SectionEntry>& sections() const { return sections_; }
  const SceneMetadata& metadata() const { return metadata_; }
  const Provenance& provenance() const { return provenance_; }
  uint64_t gaussian_count() const { return header_.gaussian_count; }
  const std::string& name() const { return name_; }
  size_t file_size() const { return size_; }

  /// The level-of-detail index (SPEC §4.9), decoded and checked by open(), or null for a file without one.
  const LodIndex* lod() const { return lod_.get(); }
  /// The Gaussians read_scene() returns: the full-detail level of a level-of-detail file, else all of them.
  uint64_t full_detail_count() const { return lod_ ? lod_->full_detail_count() : header_.gaussian_count; }
  /// Views of level `level` of chunk `chunk` of a level-of-detail file, checked without reading any other range:
  /// its XXH64 (SPEC §4.9, when verify_checksums), the value rules of §4.3–§4.7 and the chunk sphere's rule.
  /// For checking a file in place (validate()); a loader copies with read_lod_range(). Errors name the file,
  /// chunk and level: kInvalidArgument (no index, level or chunk out of range), kChecksumMismatch, kCorruptData.
  Result<LodRangeView> lod_range(uint32_t level, uint32_t chunk) const;
  /// Copies level `level` of chunk `chunk` into `target`, then checks the copy as lod_range() checks the file's
  /// bytes (checksum first, then the values). What the caller holds is therefore what was checked, even should the
  /// mapped file change meanwhile, and the file is read once. Returns views of the copy. Errors: those of
  /// lod_range(), and kInvalidArgument for a destination missing for a part the file has. On error the
  /// destinations hold unchecked bytes. The same as read_lod_slice() over the whole range, then
  /// check_lod_checksum().
  Result<LodRangeView> read_lod_range(uint32_t level, uint32_t chunk, const LodRangeTarget& target) const;
  /// Gaussians [begin, end) of the range (indices within it) copied into `target`, each at the place the whole
  /// range's copy puts it, and checked in the copy: the value rules and the chunk sphere's rule (not the checksum,
  /// which covers the whole range). Slices let a loader spread one range over threads. Errors: those of
  /// read_lod_range() but kChecksumMismatch, and kInvalidArgument for begin > end or end past the range.
  Status read_lod_slice(uint32_t level, uint32_t chunk, const LodRangeTarget& target, uint64_t begin,
                        uint64_t end) const;
  /// The XXH64 of a range's whole copy in `copy` (every slice read) against the index, when verify_checksums.
  /// Errors: kChecksumMismatch naming the file, chunk and level; kInvalidArgument as read_lod_range().
  Status check_lod_checksum(uint32_t level, uint32_t chunk, const LodRangeTarget& copy) const;

  /// The table entry for `id`, or nullptr if the file has no such section.
  const SectionEntry* find(SectionId id) const;
  /// Zero-copy view of a section's stored bytes (compressed if its codec is not kNone), checksum
  /// verified when enabled. Errors: kInvalidArgument (no such section), kChecksumMismatch.
  Result<ByteView> stored_bytes(SectionId id) const;
  /// Decodes a section's raw bytes into `dst`, which must hold exactly raw_size bytes (e.g. a pinned
  /// upload buffer). Errors: kInvalidArgument (no section, wrong size), kChecksumMismatch, kCorruptData.
  Status decode_section(SectionId id, void* dst, size_t dst_size) const;
  /// Checks one section as validate() does, without allocating its raw size: the XXH64 of its stored bytes
  /// (kChecksumMismatch), for a known codec the whole frame decoded in chunks of about 1 MiB (kCorruptData,
  /// kChecksumMismatch for the zstd content checksum), and for runtime sections the value rules of SPEC
  /// §4.3-4.7 (kCorruptData naming the Gaussian and the value). Errors name the file and the section;
  /// kInvalidArgument when there is no such section. Loaders call it before allocating memory or device
  /// memory for a section, so that memory follows what a frame really decodes to.
  Status verify_section(SectionId id) const;
  /// decode_section(), then the checks of verify_section() on the decoded bytes in `dst`: one decode where
  /// verify_section() and decode_section() would decode a compressed section twice. For loaders whose
  /// destination already holds the raw size (bounded by the read limits at open: SPEC §5.5). Errors: those of
  /// verify_section() and decode_section(), naming the file and the section.
  Status decode_verified_section(SectionId id, void* dst, size_t dst_size) const;
  /// Decodes every runtime section into an EncodedScene (host memory), each checked as verify_section()
  /// checks it (checksums, frames, value rules), so a scene this returns holds only values the renderers
  /// accept. Of a level-of-detail file (SPEC §4.9) it returns the full detail, level 0 of every chunk: the
  /// first full_detail_count() Gaussians, which is the scene the file stores, each of its level-0 ranges checked
  /// in the copy as read_lod_range() checks one (its XXH64 when verify_checksums, the chunk sphere's rule). A zstd section is verified in chunks before its raw size is allocated; an archive section
  /// (Draco, quantized) is decoded once into its array and checked there (decode_verified_section()).
  /// Errors: those of verify_section(), kChecksumMismatch or kCorruptData naming the file, chunk and level of a
  /// level-0 range, kOutOfMemory.
  Result<EncodedScene> read_scene() const;

 private:
  RgsFile() = default;
  std::shared_ptr<const MappedFile> mapping_;  // null for from_bytes
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  std::string name_;
  ReadOptions options_;
  FileHeader header_;
  std::vector<SectionEntry> sections_;
  SceneMetadata metadata_;
  Provenance provenance_;
  std::shared_ptr<const LodIndex> lod_;  // null without a lod section
  friend struct RgsFileAccess;
};

/// Full validation (backs `rgs-info --check`, tests and fuzzers): everything open() checks, plus every
/// section checksum, every codec frame decoded to its raw size, every level-of-detail range (lod_range()), and
/// the values of the runtime sections
/// (SPEC §5.4: finite means inside the AABB and bounding sphere, finite non-zero rotations, scales finite
/// and not negative when linear (0 is FP16 underflow, SPEC §4.5), opacities in [0, 1], SH values in
/// [-127, 127]). Returns the first problem found with its code, the message naming `name`; ok when the
/// file is valid. Memory: zstd sections are decoded in chunks of about 1 MiB.
Status validate(const uint8_t* data, size_t size, const ReadLimits& limits = {},
                const std::string& name = "<memory>");

/// True when `path` is to be read as a .rgs file: its first 8 bytes are the .rgs magic (§2), or its name ends
/// in ".rgs" (any case), so that a missing or truncated "x.rgs" still gets RgsFile's error rather than
/// another format's. Reads at most 8 bytes; a path that cannot be read is judged by its name alone.
bool is_rgs_path(const std::string& path);

}  // namespace rgs::format
