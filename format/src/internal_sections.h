// Private pieces shared by the writer, reader and validator: section layouts, metadata and provenance
// records, value rules, checksums and zstd frames. Section numbers refer to format/SPEC.md.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "rgs/format/metadata.h"
#include "rgs/format/spec.h"
#include "rgs/format/status.h"

namespace rgs::format::detail {

/// §2 The header checksum covers header bytes [0, 56) and then the whole section table.
inline constexpr size_t kHeaderChecksumOffset = 56;
/// §3.1 A zstd block decodes to at most 128 KiB and takes at least 4 stored bytes (an RLE block), so
/// no valid frame expands more than 32768 times.
inline constexpr uint64_t kZstdMaxExpansion = 32768;

/// §3.1 Largest zstd window a frame may use: zstd's default decoder limit (ZSTD_WINDOWLOG_LIMIT_DEFAULT),
/// so every conforming frame also decodes with a default streaming decoder.
inline constexpr uint64_t kZstdMaxWindow = uint64_t{1} << 27;

/// XXH64 with seed 0 (§2, §3.1).
uint64_t xxh64(const void* data, size_t size);
/// §2 XXH64 (seed 0) of header bytes [0, 56) followed by `table` (section_count * 64 bytes).
uint64_t header_checksum(const uint8_t* header, const uint8_t* table, size_t table_size);

/// §4 Layout a known section must have.
struct SectionLayout {
  ElementType element_type = ElementType::kBytes;
  uint32_t components = 1;
  bool per_gaussian = false;  ///< element_count must equal the header's gaussian_count
};

/// True for the section ids version 1.0 defines.
bool is_known_section(SectionId id);
/// Layout of known section `id` for an SH degree (it sets the components of kSh); false if unknown.
bool expected_layout(SectionId id, uint32_t sh_degree, SectionLayout* out);

/// "section 2 (means)" or "section 7 (id 4096)": how messages name table entry `index`.
std::string section_label(size_t index, SectionId id);

/// §4.1 Serializes metadata into its fixed kMetadataSize-byte record (writer.cpp).
void encode_metadata(const SceneMetadata& metadata, uint8_t* out);
/// §4.1 Parses a metadata record. Checks size, reserved bytes (kCorruptData) and enum values
/// (kUnsupportedFeature), then check_metadata() (reader.cpp).
Status decode_metadata(const uint8_t* raw, size_t size, SceneMetadata* out);
/// §4.1 Value rules on metadata shared by writer and reader: known enums and SH degree
/// (kUnsupportedFeature), is_valid_quantization and finite, ordered bounds (kCorruptData) (validate.cpp).
Status check_metadata(const SceneMetadata& metadata);

/// §4.2 Encoded size of a provenance record; false when a length does not fit its u32 field or the
/// total overflows (writer.cpp).
bool provenance_size(const Provenance& provenance, uint64_t* size, std::string* why);
/// §4.2 Serializes provenance into exactly provenance_size() bytes (writer.cpp).
void encode_provenance(const Provenance& provenance, uint8_t* out, size_t size);
/// §4.2 Parses a provenance record that must consume exactly `size` bytes (reader.cpp).
Status decode_provenance(const uint8_t* raw, size_t size, Provenance* out);

/// §5.4 Value rules of the runtime sections, one Gaussian at a time (validate.cpp). They return
/// kCorruptData with the Gaussian's index and the offending value; the writer maps that to
/// kInvalidArgument.
Status check_mean(const float xyz[3], uint64_t index, const SceneBounds& bounds);
Status check_rotation(const uint16_t wxyz[4], uint64_t index);
Status check_scale(const uint16_t xyz[3], uint64_t index, ScaleEncoding encoding);
Status check_opacity(uint16_t opacity, uint64_t index);
/// `q` holds the 3K quantized SH values of Gaussian `index`.
Status check_sh(const int8_t* q, size_t count, uint64_t index);
/// The rules above on `records` whole records (Gaussians first, first + 1, ...) of runtime section `id`'s raw
/// little-endian bytes at `p`; ok for a section that is not a runtime one. Runs records_pass first and the
/// per-record rules only when that fails, to name the first failing Gaussian.
Status check_records(SectionId id, const SceneMetadata& metadata, const uint8_t* p, size_t records,
                     size_t record_size, uint64_t first);
/// Whether every record passes the rules above, without naming a failure: loops with no Status per record,
/// several times faster than them (the level-of-detail reader checks every range it streams). Accepts only
/// what the rules accept: exactly on rotations, scales, opacities and SH (the binary16 rules on the bits
/// below), and means a hair inside the sphere test, so a mean within 1e−9 of its limit goes to check_mean.
bool records_pass(SectionId id, const SceneMetadata& metadata, const uint8_t* p, size_t records, size_t record_size);
/// check_rotation's, check_scale's and check_opacity's rules on one binary16 value's bits (for finite
/// binary16 values the order of the positive ones is the order of their bits).
inline bool rotation_component_passes(uint16_t bits) { return (bits & 0x7c00u) != 0x7c00u; }  // finite
inline bool scale_component_passes(uint16_t bits, ScaleEncoding encoding) {
  if ((bits & 0x7c00u) == 0x7c00u) return false;  // not finite
  const bool negative = (bits & 0x8000u) != 0;
  if (encoding == ScaleEncoding::kLog) return negative || bits < 0x558cu;  // v < 88.75 (= 0x558c)
  return !negative || bits == 0x8000u;                                     // v >= 0, −0 included
}
inline bool opacity_passes(uint16_t bits) { return bits <= 0x3c00u || bits == 0x8000u; }  // v in [0, 1], −0 too

/// §3.1 Checks the frame header of a zstd section without decoding it: a zstd frame (not skippable),
/// no dictionary, content checksum flag set, content size present and equal to raw_size, window at most
/// kZstdMaxWindow (reader.cpp).
Status check_zstd_frame_header(const uint8_t* src, size_t stored_size, uint64_t raw_size);
/// Turns a zstd error code into kChecksumMismatch (content checksum) or kCorruptData (reader.cpp).
Status zstd_error_status(size_t code, const std::string& what);
/// Runs the jobs on up to `threads` threads (the calling one included; fewer when no thread can be started);
/// job j's result goes to (*results)[j], an exception escaping it to kOutOfMemory "out of memory <what>"
/// (writer.cpp).
void run_jobs(std::vector<std::function<Status()>>& jobs, uint32_t threads, const char* what,
              std::vector<Status>* results);
/// kInvalidArgument unless `level` is a zstd level, 1..ZSTD_maxCLevel() (writer.cpp).
Status check_zstd_level(int level);
/// §3.1, §7 Appends one single-threaded zstd frame of `size` raw bytes, with content size and checksum, to `out`.
/// Errors: kOutOfMemory, kInvalidArgument (level or size refused) (writer.cpp).
Status compress_zstd_frame(const uint8_t* raw, size_t size, int level, std::vector<uint8_t>* out);
/// §3.1 Decodes one whole zstd frame of exactly `stored_size` bytes into exactly `raw_size` bytes.
Status decode_zstd_frame(const uint8_t* src, size_t stored_size, uint8_t* dst, size_t raw_size);

}  // namespace rgs::format::detail
