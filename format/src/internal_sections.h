// Private pieces shared by the writer, reader and validator: section layouts, metadata and provenance
// records, value rules, checksums and zstd frames. Section numbers refer to format/SPEC.md.
#pragma once

#include <cmath>
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

/// §4.3–§4.8 The per-Gaussian sections, in file order (sh_dc_residual optional).
inline constexpr SectionId kGaussianSections[6] = {SectionId::kMeans,     SectionId::kRotations, SectionId::kScales,
                                                   SectionId::kOpacities, SectionId::kSh,        SectionId::kShDcResidual};

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

/// §4.1.1 The largest distance from `center` that a point inside the sphere may have: `radius` plus the slack
/// 1e−6·(radius + max |center|), which absorbs float32 rounding in whichever way the writer computed the
/// distance. The means' bounding sphere and the level-of-detail chunks' spheres (§4.9) use it.
inline double sphere_limit(const float center[3], float radius) {
  double c_max = 0;
  for (int a = 0; a < 3; ++a) c_max = std::fmax(c_max, std::fabs(static_cast<double>(center[a])));
  return static_cast<double>(radius) + 1e-6 * (static_cast<double>(radius) + c_max);
}
/// Squared distance from `center` to `p`, in double.
inline double distance_squared(const float p[3], const float center[3]) {
  double d2 = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = static_cast<double>(p[a]) - static_cast<double>(center[a]);
    d2 += d * d;
  }
  return d2;
}

/// The binary16 value rules on the bits themselves (for finite binary16 values the order of the positive ones
/// is the order of their bits): a finite value (every rotation component, §4.4) ...
inline bool half_bits_finite(uint16_t bits) { return (bits & 0x7c00u) != 0x7c00u; }
/// ... a scale (§4.5): finite; as a log scale below 88.75 (0x558c), the first binary16 whose exp overflows
/// float32 (ln FLT_MAX ≈ 88.72); as a linear scale not negative, so zero (the underflow of a scale below 2^-25)
/// and −0 are legal ...
/// (Written as comparisons of the bits with no branch, so that loops over many values vectorize: the finite
/// positive values are the bits below 0x7c00, the finite negative ones 0x8000..0xfbff.)
inline bool scale_component_passes(uint16_t bits, ScaleEncoding encoding) {
  if (encoding == ScaleEncoding::kLog) return (bits < 0x558cu) | ((bits >= 0x8000u) & (bits < 0xfc00u));
  return (bits < 0x7c00u) | (bits == 0x8000u);
}
/// ... and an opacity (§4.6) in [0, 1], −0 included.
inline bool opacity_passes(uint16_t bits) { return (bits <= 0x3c00u) | (bits == 0x8000u); }

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
/// Whether every record passes the rules above (the same rules, the same arithmetic), without naming a
/// failure: loops with no Status and no branch per record, which the compiler vectorizes where it can (the
/// level-of-detail reader checks every range it streams). `record_size` must be the section's (opening a
/// file checks the section table for it): means, rotations, scales and opacities are read at their fixed
/// sizes, 12, 8, 6 and 2 bytes.
bool records_pass(SectionId id, const SceneMetadata& metadata, const uint8_t* p, size_t records, size_t record_size);

/// §3.1 Checks the frame header of a zstd section without decoding it: a zstd frame (not skippable),
/// no dictionary, content checksum flag set, content size present and equal to raw_size, window at most
/// kZstdMaxWindow (reader.cpp).
Status check_zstd_frame_header(const uint8_t* src, size_t stored_size, uint64_t raw_size);
/// Turns a zstd error code into kChecksumMismatch (content checksum) or kCorruptData (reader.cpp).
Status zstd_error_status(size_t code, const std::string& what);
/// Runs the jobs on up to `threads` threads (0: the machine's hardware threads), never more than there are jobs
/// (the calling one included; fewer when no thread can be started). Returns the status of the first job, in job
/// order, that failed once all have run; an exception escaping a job is kOutOfMemory "out of memory <what>"
/// (writer.cpp).
Status run_jobs(std::vector<std::function<Status()>>& jobs, uint32_t threads, const char* what);
/// Each of `jobs` jobs' share of `threads` threads (0: the machine's hardware threads), rounded up, at least 1:
/// what a job that runs threads of its own (a zstd frame's workers) may use beside the others (writer.cpp).
uint32_t threads_per_job(uint32_t threads, size_t jobs);
/// kInvalidArgument unless `level` is a zstd level, 1..ZSTD_maxCLevel() (writer.cpp).
Status check_zstd_level(int level);
/// §7 The raw bytes each job of a zstd frame compresses (zstd's ZSTD_c_jobSize), and how much of the data before
/// a job it may refer to (ZSTD_c_overlapLog: 6 is an eighth of the window; the default, the whole window, makes
/// each job index up to 8 MiB again at level 19). The frame's bytes depend on them, not on how many workers run
/// the jobs; taebak's archive sections at level 19 take 0.02-0.07 % more bytes than in one job, jobs of 4 MiB
/// 0.65 % (docs/lab/TRIED.md#tried-and-not-kept).
inline constexpr size_t kZstdJobBytes = size_t{8} << 20;
inline constexpr int kZstdOverlapLog = 6;
/// §3.1, §7 Appends one zstd frame of `size` raw bytes, with content size and checksum, to `out`: jobs of
/// kZstdJobBytes compressed by up to `workers` threads (at most one a job; 0 counts as 1), the same bytes for
/// any `workers`; each worker holds a compression context (ZSTD_estimateCCtxSize: 81 MB at level 19).
/// Errors: kOutOfMemory, kInvalidArgument (level or size refused) (writer.cpp).
Status compress_zstd_frame(const uint8_t* raw, size_t size, int level, uint32_t workers, std::vector<uint8_t>* out);
/// §3.1 Decodes one whole zstd frame of exactly `stored_size` bytes into exactly `raw_size` bytes.
Status decode_zstd_frame(const uint8_t* src, size_t stored_size, uint8_t* dst, size_t raw_size);

}  // namespace rgs::format::detail
