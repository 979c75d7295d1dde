// Opens .rgs files: header (§2), section table (§3), metadata (§4.1) and provenance (§4.2), in the
// check order of SPEC.md §5; runtime sections are only touched on request.
#include "rgs/format/reader.h"

#define XXH_STATIC_LINKING_ONLY  // XXH64_state_t on the stack
#include <xxhash.h>
#include <zstd.h>
#include <zstd_errors.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "internal_archive.h"
#include "internal_bytes.h"
#include "internal_lod.h"
#include "internal_sections.h"

namespace rgs::format {

namespace detail {

uint64_t xxh64(const void* data, size_t size) { return XXH64(size == 0 ? "" : data, size, 0); }

uint64_t header_checksum(const uint8_t* header, const uint8_t* table, size_t table_size) {
  XXH64_state_t state;
  XXH64_reset(&state, 0);
  XXH64_update(&state, header, kHeaderChecksumOffset);
  if (table_size > 0) XXH64_update(&state, table, table_size);
  return XXH64_digest(&state);
}

bool expected_layout(SectionId id, uint32_t sh_degree, SectionLayout* out) {
  switch (id) {
    case SectionId::kMetadata:
    case SectionId::kProvenance:
    case SectionId::kLod: *out = {ElementType::kBytes, 1, false}; return true;
    case SectionId::kMeans: *out = {ElementType::kFloat32, 3, true}; return true;
    case SectionId::kRotations: *out = {ElementType::kFloat16, 4, true}; return true;
    case SectionId::kScales: *out = {ElementType::kFloat16, 3, true}; return true;
    case SectionId::kOpacities: *out = {ElementType::kFloat16, 1, true}; return true;
    case SectionId::kSh: *out = {ElementType::kInt8, 3 * sh_coefficient_count(sh_degree), true}; return true;
    case SectionId::kShDcResidual: *out = {ElementType::kInt8, 3, true}; return true;
  }
  return false;
}

bool is_known_section(SectionId id) {
  SectionLayout unused;
  return expected_layout(id, 0, &unused);
}

std::string section_label(size_t index, SectionId id) {
  std::string s = "section " + dec(index) + " (";
  if (is_known_section(id)) return s + section_name(id) + ")";
  return s + "id " + dec(static_cast<uint32_t>(id)) + ")";
}

Status decode_metadata(const uint8_t* raw, size_t size, SceneMetadata* out) {
  RGS_RETURN_ERROR_IF(size != kMetadataSize, StatusCode::kCorruptData,
                      "metadata record is " + dec(size) + " bytes, expected " + dec(kMetadataSize));
  // Reserved bytes first: a non-zero one means a writer we do not understand, whatever the fields say.
  for (size_t i = 0; i < kMetadataSize; ++i) {
    const bool reserved = (i >= 9 && i < 16) || i >= 112;
    RGS_RETURN_ERROR_IF(reserved && raw[i] != 0, StatusCode::kCorruptData,
                        "reserved byte " + dec(i) + " of the metadata record is " + dec(raw[i]) + ", must be 0");
  }
  ByteReader r(raw, size);
  SceneMetadata m;
  uint8_t frame = 0, quaternion_order = 0, scale_encoding = 0, opacity_encoding = 0, sh_layout = 0;
  bool ok = r.read_u32(&m.sh_degree) && r.read_u8(&frame) && r.read_u8(&quaternion_order) &&
            r.read_u8(&scale_encoding) && r.read_u8(&opacity_encoding) && r.read_u8(&sh_layout) && r.skip(7);
  for (float& v : m.bounds.aabb_min) ok = ok && r.read_f32(&v);
  for (float& v : m.bounds.aabb_max) ok = ok && r.read_f32(&v);
  for (float& v : m.bounds.sphere_center) ok = ok && r.read_f32(&v);
  ok = ok && r.read_f32(&m.bounds.sphere_radius) && r.read_u32(&m.sh_quantization.bits) &&
       r.read_f32(&m.sh_quantization.clip_percentile);
  for (auto& row : m.sh_quantization.scales) {
    for (float& v : row) ok = ok && r.read_f32(&v);
  }
  ok = ok && r.skip(16) && r.remaining() == 0;
  RGS_RETURN_ERROR_IF(!ok, StatusCode::kCorruptData, "metadata record layout mismatch");
  // Enums have a fixed uint8_t underlying type, so any byte is a representable value; check_metadata
  // rejects the unknown ones.
  m.frame = static_cast<CoordinateFrame>(frame);
  m.quaternion_order = static_cast<QuaternionOrder>(quaternion_order);
  m.scale_encoding = static_cast<ScaleEncoding>(scale_encoding);
  m.opacity_encoding = static_cast<OpacityEncoding>(opacity_encoding);
  m.sh_layout = static_cast<ShLayout>(sh_layout);
  RGS_RETURN_IF_ERROR(check_metadata(m));
  *out = m;
  return Status();
}

Status decode_provenance(const uint8_t* raw, size_t size, Provenance* out) {
  ByteReader r(raw, size);
  uint32_t count = 0;
  RGS_RETURN_ERROR_IF(!r.read_u32(&count), StatusCode::kCorruptData,
                      "the record is " + dec(size) + " bytes, too short for its 4-byte count");
  // Each entry takes at least 8 bytes (two lengths): bound the count before reserving.
  RGS_RETURN_ERROR_IF(count > r.remaining() / 8, StatusCode::kCorruptData,
                      "the record declares " + dec(count) + " entries but only " + dec(r.remaining()) +
                          " bytes follow (at least 8 per entry)");
  Provenance result;
  result.reserve(count);
  for (uint32_t i = 0; i < count; ++i) {
    uint32_t key_len = 0, value_len = 0;
    const uint8_t* key = nullptr;
    const uint8_t* value = nullptr;
    RGS_RETURN_ERROR_IF(!r.read_u32(&key_len), StatusCode::kCorruptData,
                        "entry " + dec(i) + ": key length runs past the record");
    RGS_RETURN_ERROR_IF(!r.read_view(key_len, &key), StatusCode::kCorruptData,
                        "entry " + dec(i) + ": key of " + dec(key_len) + " bytes runs past the record (" +
                            dec(r.remaining()) + " bytes left)");
    RGS_RETURN_ERROR_IF(!r.read_u32(&value_len), StatusCode::kCorruptData,
                        "entry " + dec(i) + ": value length runs past the record");
    RGS_RETURN_ERROR_IF(!r.read_view(value_len, &value), StatusCode::kCorruptData,
                        "entry " + dec(i) + ": value of " + dec(value_len) +
                            " bytes runs past the record (" + dec(r.remaining()) + " bytes left)");
    result.emplace_back(std::string(reinterpret_cast<const char*>(key), key_len),
                        std::string(reinterpret_cast<const char*>(value), value_len));
  }
  RGS_RETURN_ERROR_IF(r.remaining() != 0, StatusCode::kCorruptData,
                      "the record has " + dec(r.remaining()) + " bytes after its last entry");
  *out = std::move(result);
  return Status();
}

Status check_zstd_frame_header(const uint8_t* src, size_t stored_size, uint64_t raw_size) {
  constexpr uint32_t kZstdMagic = 0xFD2FB528u;
  RGS_RETURN_ERROR_IF(stored_size < 5, StatusCode::kCorruptData,
                      "zstd frame of " + dec(stored_size) + " bytes is shorter than a frame header");
  const uint32_t magic = load_u32_le(src);
  RGS_RETURN_ERROR_IF((magic & 0xFFFFFFF0u) == 0x184D2A50u, StatusCode::kCorruptData,
                      "zstd skippable frame where a data frame is required");
  RGS_RETURN_ERROR_IF(magic != kZstdMagic, StatusCode::kCorruptData,
                      "not a zstd frame: magic " + hex32(magic) + ", expected " + hex32(kZstdMagic));
  const uint8_t descriptor = src[4];
  RGS_RETURN_ERROR_IF((descriptor & 0x08u) != 0, StatusCode::kCorruptData,
                      "zstd frame header descriptor has its reserved bit set");
  RGS_RETURN_ERROR_IF((descriptor & 0x04u) == 0, StatusCode::kCorruptData,
                      "zstd frame has no content checksum (SPEC §3.1 requires one)");
  RGS_RETURN_ERROR_IF((descriptor & 0x03u) != 0, StatusCode::kCorruptData,
                      "zstd frame names a dictionary (SPEC §3.1 forbids dictionaries)");
  const unsigned long long content = ZSTD_getFrameContentSize(src, stored_size);
  RGS_RETURN_ERROR_IF(content == ZSTD_CONTENTSIZE_ERROR, StatusCode::kCorruptData, "invalid zstd frame header");
  RGS_RETURN_ERROR_IF(content == ZSTD_CONTENTSIZE_UNKNOWN, StatusCode::kCorruptData,
                      "zstd frame header has no content size (SPEC §3.1 requires one)");
  RGS_RETURN_ERROR_IF(content != raw_size, StatusCode::kCorruptData,
                      "zstd frame content size " + dec(content) + " != raw_size " + dec(raw_size));
  // RFC 8878 §3.1.1.1.2: a single-segment frame's window is its content size; otherwise the
  // Window_Descriptor byte after the descriptor gives 2^(10 + exponent) * (1 + mantissa / 8).
  uint64_t window = content;
  if ((descriptor & 0x20u) == 0) {
    const uint8_t w = src[5];  // present: ZSTD_getFrameContentSize accepted the whole header
    const uint64_t base = uint64_t{1} << (10 + (w >> 3));
    window = base + (base >> 3) * (w & 7u);
  }
  RGS_RETURN_ERROR_IF(window > kZstdMaxWindow, StatusCode::kCorruptData,
                      "zstd frame window of " + dec(window) + " bytes exceeds the " + dec(kZstdMaxWindow) +
                          " SPEC §3.1 allows");
  return Status();
}

Status zstd_error_status(size_t code, const std::string& what) {
  switch (ZSTD_getErrorCode(code)) {
    case ZSTD_error_checksum_wrong:
      return Status(StatusCode::kChecksumMismatch, what + ": zstd content checksum does not match the decoded bytes");
    case ZSTD_error_memory_allocation: return Status(StatusCode::kOutOfMemory, what + ": zstd: out of memory");
    default: break;
  }
  return Status(StatusCode::kCorruptData, what + ": zstd: " + ZSTD_getErrorName(code));
}

namespace {

using DctxPtr = std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)>;

/// Checks that the section's stored bytes are exactly one zstd frame and makes its decompression context.
Status start_zstd_frame(const uint8_t* src, size_t stored_size, DctxPtr* dctx) {
  const size_t frame_size = ZSTD_findFrameCompressedSize(src, stored_size);
  if (ZSTD_isError(frame_size)) return zstd_error_status(frame_size, "zstd frame");
  RGS_RETURN_ERROR_IF(frame_size != stored_size, StatusCode::kCorruptData,
                      "zstd frame is " + dec(frame_size) + " bytes but the section stores " + dec(stored_size) +
                          " (trailing data or a second frame)");
  dctx->reset(ZSTD_createDCtx());
  RGS_RETURN_ERROR_IF(!*dctx, StatusCode::kOutOfMemory, "cannot create a zstd decompression context");
  return Status();
}

/// Decodes a zstd section in bounded chunks of whole records, checking values as they come when `metadata` is
/// given. A frame error (corrupt block, content checksum) outranks a value error seen before it, since the
/// values of a corrupt frame mean nothing.
Status stream_zstd_frame(SectionId id, const SceneMetadata* metadata, const uint8_t* src, size_t stored_size,
                         uint64_t raw_size, size_t record_size) {
  DctxPtr dctx(nullptr, ZSTD_freeDCtx);
  RGS_RETURN_IF_ERROR(start_zstd_frame(src, stored_size, &dctx));
  // At most 1 MiB of whole records, and no more records than raw_size claims (a section of a few KB needs no
  // 1 MiB buffer; a claim too small is caught below, when the frame decodes to more).
  const uint64_t records = std::min<uint64_t>(raw_size / record_size + (raw_size % record_size != 0),
                                              std::max<size_t>(1, (size_t{1} << 20) / record_size));
  const size_t chunk = record_size * static_cast<size_t>(std::max<uint64_t>(1, records));
  std::vector<uint8_t> buffer(chunk);
  ZSTD_inBuffer in{src, stored_size, 0};
  uint64_t total = 0, index = 0;
  size_t fill = 0;
  Status value_error;
  for (;;) {
    ZSTD_outBuffer out{buffer.data(), chunk, fill};
    const size_t ret = ZSTD_decompressStream(dctx.get(), &out, &in);
    if (ZSTD_isError(ret)) return zstd_error_status(ret, "zstd frame");
    total += out.pos - fill;
    RGS_RETURN_ERROR_IF(total > raw_size, StatusCode::kCorruptData,
                        "zstd frame decodes to more than raw_size " + dec(raw_size) + " bytes");
    const size_t complete = out.pos / record_size * record_size;
    if (metadata && value_error.ok() && complete > 0)
      value_error = check_records(id, *metadata, buffer.data(), complete / record_size, record_size, index);
    index += complete / record_size;
    fill = out.pos - complete;
    if (fill > 0) std::memmove(buffer.data(), buffer.data() + complete, fill);
    if (ret == 0) break;
    RGS_RETURN_ERROR_IF(in.pos == in.size && out.pos < out.size, StatusCode::kCorruptData,
                        "zstd frame ends early after " + dec(total) + " of " + dec(raw_size) + " bytes");
  }
  RGS_RETURN_ERROR_IF(total != raw_size || fill != 0, StatusCode::kCorruptData,
                      "zstd frame decoded to " + dec(total) + " bytes, expected " + dec(raw_size));
  return value_error;
}

}  // namespace

Status decode_zstd_frame(const uint8_t* src, size_t stored_size, uint8_t* dst, size_t raw_size) {
  DctxPtr dctx(nullptr, ZSTD_freeDCtx);
  RGS_RETURN_IF_ERROR(start_zstd_frame(src, stored_size, &dctx));
  uint8_t empty = 0;
  const size_t n = ZSTD_decompressDCtx(dctx.get(), raw_size == 0 ? &empty : dst, raw_size, src, stored_size);
  if (ZSTD_isError(n)) return zstd_error_status(n, "zstd frame");
  RGS_RETURN_ERROR_IF(n != raw_size, StatusCode::kCorruptData,
                      "zstd frame decoded to " + dec(n) + " bytes, expected " + dec(raw_size));
  return Status();
}

}  // namespace detail

using detail::dec;
using detail::hex32;
using detail::hex64;
using detail::section_label;

/// Parses and checks an RgsFile's bytes in SPEC §5 order; the only code that fills its private state.
struct RgsFileAccess {
  static Status parse(RgsFile* f);

 private:
  static Status parse_header(RgsFile* f);
  static Status parse_table(RgsFile* f);
  static Status check_placement(const RgsFile& f);
  static Status check_entry(const RgsFile& f, size_t index);
  static Status check_decoded_total(const RgsFile& f);
  static Status check_layout(const RgsFile& f, size_t index, uint32_t sh_degree);
  static Status read_small_section(const RgsFile& f, size_t index, uint64_t max_raw, std::vector<uint8_t>* raw);
  static Status parse_lod(RgsFile* f);
  static Status check_sh_colour_differences(const RgsFile& f);
  static Status check_xz_codes(const RgsFile& f);
  /// kCorruptData "<what> in a version M.m file" unless the file's version is at least `min` (§6).
  static Status require_version(const RgsFile& f, FormatVersion min, const std::string& what);

 public:
  /// kInvalidArgument naming the file unless `f` has a level-of-detail index holding (level, chunk).
  static Status check_range_index(const RgsFile& f, uint32_t level, uint32_t chunk);
  /// §4.9 Views of level `level` of chunk `chunk` (both in range), unchecked.
  static LodRangeView range_view(const RgsFile& f, uint32_t level, uint32_t chunk);
  /// Entry `index`'s stored bytes, checksum verified when enabled. Messages name the section, not the file.
  static Status stored_view(const RgsFile& f, size_t index, ByteView* out);
  /// Decodes entry `index` into exactly raw_size bytes. Messages name the section, not the file.
  static Status decode(const RgsFile& f, size_t index, void* dst, size_t dst_size);
  /// Index of the entry with `id`, or an error naming the missing section.
  static Status index_of(const RgsFile& f, SectionId id, size_t* index);
};

namespace {

bool is_known_codec(Codec c) {
  return c == Codec::kNone || c == Codec::kZstd || c == Codec::kDraco || c == Codec::kQuantized;
}

}  // namespace

Status RgsFileAccess::parse_header(RgsFile* f) {
  const uint8_t* data = f->data_;
  const size_t size = f->size_;
  const ReadLimits& limits = f->options_.limits;
  // §5.1 The magic decides whether this is an .rgs file at all; a short file that matches the magic as
  // far as it goes is a truncated .rgs file.
  const size_t probe = size < 8 ? size : 8;
  if (probe == 0 || std::memcmp(data, kMagic, probe) != 0) {
    std::string got;
    for (size_t i = 0; i < probe; ++i) got += (i ? " " : "") + hex64(data[i]).substr(16);
    return Status(StatusCode::kNotRgsFile,
                  "not an .rgs file: " +
                      (probe == 0 ? std::string("it is empty")
                                  : "first bytes are " + got + ", expected the magic 89 52 47 53 0d 0a 1a 0a"));
  }
  RGS_RETURN_ERROR_IF(size < kHeaderSize, StatusCode::kCorruptData,
                      "truncated: " + dec(size) + " bytes, shorter than the " + dec(kHeaderSize) + "-byte header");

  detail::ByteReader r(data, kHeaderSize);
  FileHeader h;
  uint32_t header_size = 0, reserved = 0;
  const bool ok = r.skip(8) && r.read_u16(&h.major) && r.read_u16(&h.minor) && r.read_u32(&header_size) &&
                  r.read_u32(&h.required_flags) && r.read_u32(&h.optional_flags) && r.read_u64(&h.gaussian_count) &&
                  r.read_u32(&h.section_count) && r.read_u32(&reserved) && r.read_u64(&h.table_offset) &&
                  r.read_u64(&h.file_size) && r.read_u64(&h.checksum) && r.remaining() == 0;
  RGS_RETURN_ERROR_IF(!ok, StatusCode::kCorruptData, "header layout mismatch");

  // §5.1 Fields that say how to read the rest come before anything else.
  RGS_RETURN_ERROR_IF(h.major > kFormatMajor, StatusCode::kUnsupportedVersion,
                      "format version " + dec(h.major) + "." + dec(h.minor) + " is newer than this reader (" +
                          dec(kFormatMajor) + ".x)");
  RGS_RETURN_ERROR_IF(h.major < kFormatMajor, StatusCode::kUnsupportedVersion,
                      "format version " + dec(h.major) + "." + dec(h.minor) +
                          " was never released; this reader reads " + dec(kFormatMajor) + ".x");
  const uint32_t unknown_required = h.required_flags & ~kKnownRequiredFlags;
  RGS_RETURN_ERROR_IF(unknown_required != 0, StatusCode::kUnsupportedFeature,
                      "unknown required flag bits " + hex32(unknown_required) + " (this reader knows " +
                          hex32(kKnownRequiredFlags) + ")");
  RGS_RETURN_ERROR_IF(header_size != kHeaderSize, StatusCode::kCorruptData,
                      "header_size is " + dec(header_size) + ", must be " + dec(kHeaderSize));
  RGS_RETURN_ERROR_IF(reserved != 0, StatusCode::kCorruptData,
                      "header reserved field (bytes 36..39) is " + dec(reserved) + ", must be 0");
  RGS_RETURN_ERROR_IF(h.table_offset != kHeaderSize, StatusCode::kCorruptData,
                      "table_offset is " + dec(h.table_offset) + ", must be " + dec(kHeaderSize));
  RGS_RETURN_ERROR_IF(h.file_size != size, StatusCode::kCorruptData,
                      "header says the file is " + dec(h.file_size) + " bytes but it is " + dec(size) +
                          (size < h.file_size ? " (truncated)" : " (trailing bytes)"));
  RGS_RETURN_ERROR_IF(size > limits.max_file_bytes, StatusCode::kLimitExceeded,
                      "file of " + dec(size) + " bytes exceeds the limit of " + dec(limits.max_file_bytes));
  RGS_RETURN_ERROR_IF(h.section_count > limits.max_sections, StatusCode::kLimitExceeded,
                      dec(h.section_count) + " sections exceed the limit of " + dec(limits.max_sections));
  // section_count is a u32, so the table end cannot overflow 64 bits.
  const uint64_t table_end = kHeaderSize + uint64_t{kSectionEntrySize} * h.section_count;
  RGS_RETURN_ERROR_IF(table_end > size, StatusCode::kCorruptData,
                      "section table of " + dec(h.section_count) + " entries ends at " + dec(table_end) +
                          " > file size " + dec(size));
  const uint64_t computed = detail::header_checksum(data, data + kHeaderSize, table_end - kHeaderSize);
  RGS_RETURN_ERROR_IF(computed != h.checksum, StatusCode::kChecksumMismatch,
                      "header checksum " + hex64(h.checksum) + " does not match the computed " + hex64(computed));
  RGS_RETURN_ERROR_IF(h.gaussian_count > limits.max_gaussians, StatusCode::kLimitExceeded,
                      dec(h.gaussian_count) + " Gaussians exceed the limit of " + dec(limits.max_gaussians) +
                          " (a file you trust reads with a higher max_gaussians: --max-gaussians)");
  f->header_ = h;
  return Status();
}

Status RgsFileAccess::parse_table(RgsFile* f) {
  const uint32_t count = f->header_.section_count;
  detail::ByteReader r(f->data_ + kHeaderSize, uint64_t{kSectionEntrySize} * count);
  f->sections_.resize(count);  // bounded by max_sections and by the file size, both checked
  std::map<uint32_t, size_t> seen;
  for (uint32_t i = 0; i < count; ++i) {
    SectionEntry& e = f->sections_[i];
    uint32_t id = 0, reserved0 = 0;
    uint16_t codec = 0, element_type = 0;
    uint64_t reserved1 = 0;
    const bool ok = r.read_u32(&id) && r.read_u16(&codec) && r.read_u16(&element_type) &&
                    r.read_u32(&e.components) && r.read_u32(&reserved0) && r.read_u64(&e.element_count) &&
                    r.read_u64(&e.offset) && r.read_u64(&e.stored_size) && r.read_u64(&e.raw_size) &&
                    r.read_u64(&e.checksum) && r.read_u64(&reserved1);
    RGS_RETURN_ERROR_IF(!ok, StatusCode::kCorruptData, "section table entry " + dec(i) + " is truncated");
    e.id = static_cast<SectionId>(id);
    e.codec = static_cast<Codec>(codec);
    e.element_type = static_cast<ElementType>(element_type);
    const std::string label = section_label(i, e.id);
    RGS_RETURN_ERROR_IF(reserved0 != 0 || reserved1 != 0, StatusCode::kCorruptData,
                        label + ": reserved table fields are " + dec(reserved0) + " and " + dec(reserved1) +
                            ", must be 0");
    const auto [it, inserted] = seen.emplace(id, i);
    RGS_RETURN_ERROR_IF(!inserted, StatusCode::kCorruptData,
                        label + " repeats the id of section " + dec(it->second));
  }
  return Status();
}

Status RgsFileAccess::check_placement(const RgsFile& f) {
  // §3 Sections follow the table in table order, each at the first multiple of kSectionAlignment at or
  // after the previous end, zero padding between; the last one ends at EOF.
  uint64_t prev_end = kHeaderSize + uint64_t{kSectionEntrySize} * f.sections_.size();
  for (size_t i = 0; i < f.sections_.size(); ++i) {
    const SectionEntry& e = f.sections_[i];
    const std::string label = section_label(i, e.id);
    RGS_RETURN_ERROR_IF(e.offset % kSectionAlignment != 0, StatusCode::kCorruptData,
                        label + ": offset " + dec(e.offset) + " is not a multiple of " + dec(kSectionAlignment));
    RGS_RETURN_ERROR_IF(e.offset < prev_end, StatusCode::kCorruptData,
                        label + " starts at " + dec(e.offset) + ", inside " +
                            (i == 0 ? std::string("the header and section table, which end at ")
                                    : section_label(i - 1, f.sections_[i - 1].id) + ", which ends at ") +
                            dec(prev_end));
    uint64_t expected = 0;
    RGS_RETURN_ERROR_IF(!detail::checked_align_up(prev_end, kSectionAlignment, &expected) || e.offset != expected,
                        StatusCode::kCorruptData,
                        label + " starts at " + dec(e.offset) + ", expected " + dec(expected) +
                            " (the first multiple of " + dec(kSectionAlignment) + " after the previous end " +
                            dec(prev_end) + ")");
    uint64_t end = 0;
    RGS_RETURN_ERROR_IF(!checked_add(e.offset, e.stored_size, &end), StatusCode::kCorruptData,
                        label + ": offset " + dec(e.offset) + " + stored_size " + dec(e.stored_size) +
                            " overflows 64 bits");
    RGS_RETURN_ERROR_IF(end > f.size_, StatusCode::kCorruptData,
                        label + " ends at " + dec(end) + " > file size " + dec(f.size_));
    for (uint64_t p = prev_end; p < e.offset; ++p) {
      RGS_RETURN_ERROR_IF(f.data_[p] != 0, StatusCode::kCorruptData,
                          "padding byte at " + dec(p) + " before " + label + " is " + dec(f.data_[p]) +
                              ", must be 0");
    }
    prev_end = end;
  }
  RGS_RETURN_ERROR_IF(prev_end != f.size_, StatusCode::kCorruptData,
                      "the last section ends at " + dec(prev_end) + " but the file is " + dec(f.size_) +
                          " bytes (" + dec(f.size_ - prev_end) + " trailing bytes)");
  return Status();
}

Status RgsFileAccess::require_version(const RgsFile& f, FormatVersion min, const std::string& what) {
  RGS_RETURN_ERROR_IF(!version_at_least({f.header_.major, f.header_.minor}, min), StatusCode::kCorruptData,
                      what + " in a version " + dec(f.header_.major) + "." + dec(f.header_.minor) + " file");
  return Status();
}

Status RgsFileAccess::check_entry(const RgsFile& f, size_t index) {
  // §3.1 Rules that hold for every entry, known or not.
  const SectionEntry& e = f.sections_[index];
  const std::string label = section_label(index, e.id);
  const bool known = detail::is_known_section(e.id);
  const ReadLimits& limits = f.options_.limits;
  if (!is_known_codec(e.codec)) {
    RGS_RETURN_ERROR_IF(known, StatusCode::kUnsupportedFeature,
                        label + ": codec " + dec(static_cast<uint16_t>(e.codec)) +
                            " is unknown (this reader knows 0 = none, 1 = zstd, 2 = draco, 3 = quantized)");
  }
  const uint32_t type_size = element_type_size(e.element_type);
  if (type_size != 0) {
    uint64_t implied = 0;
    const bool fits = checked_mul(e.element_count, e.components, &implied) &&
                      checked_mul(implied, type_size, &implied);
    RGS_RETURN_ERROR_IF(!fits || implied != e.raw_size, StatusCode::kCorruptData,
                        label + ": raw_size " + dec(e.raw_size) + " != element_count " + dec(e.element_count) +
                            " x components " + dec(e.components) + " x " + dec(type_size) + " bytes" +
                            (fits ? " = " + dec(implied) : std::string(" (overflows 64 bits)")));
  }
  RGS_RETURN_ERROR_IF(e.raw_size > limits.max_section_raw_bytes, StatusCode::kLimitExceeded,
                      label + ": raw size " + dec(e.raw_size) + " bytes exceeds the limit of " +
                          dec(limits.max_section_raw_bytes));
  if (e.codec == Codec::kNone) {
    RGS_RETURN_ERROR_IF(e.stored_size != e.raw_size, StatusCode::kCorruptData,
                        label + ": codec none but stored_size " + dec(e.stored_size) + " != raw_size " +
                            dec(e.raw_size));
  } else if (e.codec == Codec::kZstd) {
    RGS_RETURN_IF_ERROR(require_version(f, kMinVersionForZstdCodec, label + ": zstd codec"));
    uint64_t max_raw = 0;
    const bool bounded = checked_mul(e.stored_size, detail::kZstdMaxExpansion, &max_raw);
    RGS_RETURN_ERROR_IF(bounded && e.raw_size > max_raw, StatusCode::kCorruptData,
                        label + ": raw_size " + dec(e.raw_size) + " cannot come from a " + dec(e.stored_size) +
                            "-byte zstd frame (at most " + dec(detail::kZstdMaxExpansion) + "x expansion)");
    Status s = detail::check_zstd_frame_header(f.data_ + e.offset, static_cast<size_t>(e.stored_size), e.raw_size);
    if (!s.ok()) return Status(s).prepend(label);
  } else if (is_archive_codec(e.codec)) {
    // §3.3 Archive codecs: gated by version and the required flag, only on their sections, headers
    // checked here (the point or code count before anything is allocated from it).
    RGS_RETURN_IF_ERROR(require_version(f, kMinVersionForArchiveCodecs, label + ": " + codec_name(e.codec) + " codec"));
    RGS_RETURN_ERROR_IF((f.header_.required_flags & kRequiredFlagArchiveCodecs) == 0, StatusCode::kCorruptData,
                        label + ": " + codec_name(e.codec) + " codec without the archive-codecs required flag");
    RGS_RETURN_ERROR_IF(!detail::archive_codec_allowed(e.id, e.codec), StatusCode::kCorruptData,
                        label + ": codec " + codec_name(e.codec) + " is not allowed on this section (SPEC 3.3)");
    RGS_RETURN_ERROR_IF(e.element_count != f.header_.gaussian_count, StatusCode::kCorruptData,
                        label + ": element_count " + dec(e.element_count) + " != gaussian_count " +
                            dec(f.header_.gaussian_count));
    const uint8_t* src = f.data_ + e.offset;
    const size_t size = static_cast<size_t>(e.stored_size);
    bool xz = false;
    Status s = e.codec == Codec::kDraco
                   ? detail::check_draco_header(src, size, e.element_count)
                   : detail::check_quantized_header(e.id, src, size, e.element_count, e.components, &xz);
    if (!s.ok()) return Status(s).prepend(label);
    // §2.2, §3.3.2 Codes in an .xz stream come with their required flag, in a 1.5 file (check_xz_codes checks
    // the converse).
    RGS_RETURN_ERROR_IF(xz && (f.header_.required_flags & kRequiredFlagXzCodes) == 0, StatusCode::kCorruptData,
                        label + ": codes in an .xz stream without their required flag");
    if (xz) RGS_RETURN_IF_ERROR(require_version(f, kMinVersionForXzCodes, label + ": codes in an .xz stream"));
  }
  return Status();
}

Status RgsFileAccess::check_decoded_total(const RgsFile& f) {
  // §5.5 A zstd frame may claim up to 32768 times its own size, and readers allocate what the table
  // claims; bound the total by the file's size before anything is allocated from it.
  uint64_t total = 0;
  for (const SectionEntry& e : f.sections_) {
    if (!detail::is_known_section(e.id)) continue;
    // §5.5 Archive-coded sections count a fraction of their raw size (internal_archive.h).
    const bool archive = is_archive_codec(e.codec);
    const uint64_t counted = archive ? e.raw_size / detail::kArchiveRatioAllowance : e.raw_size;
    if (!checked_add(total, counted, &total)) total = UINT64_MAX;
  }
  const ReadLimits& limits = f.options_.limits;
  const uint64_t basis = std::max<uint64_t>(f.size_, kDecompressionRatioMinBytes);
  uint64_t allowed = 0;
  if (!checked_mul(basis, limits.max_decompression_ratio, &allowed)) allowed = UINT64_MAX;
  RGS_RETURN_ERROR_IF(total > allowed, StatusCode::kLimitExceeded,
                      "the sections decode to " + dec(total) + " bytes (archive sections counted at 1/" +
                          dec(detail::kArchiveRatioAllowance) + "), more than the decompression-ratio limit of " +
                          dec(limits.max_decompression_ratio) + " x " + dec(basis) + " bytes (" +
                          (f.size_ < kDecompressionRatioMinBytes ? "1 MiB, the least a file counts as"
                                                                 : std::string("the file's size")) +
                          ", SPEC 5.5) allows; raise ReadLimits::max_decompression_ratio to read it");
  return Status();
}

Status RgsFileAccess::check_layout(const RgsFile& f, size_t index, uint32_t sh_degree) {
  // §4 Known sections have a fixed element type and component count; per-Gaussian ones hold N elements.
  const SectionEntry& e = f.sections_[index];
  detail::SectionLayout want;
  if (!detail::expected_layout(e.id, sh_degree, &want)) return Status();
  const std::string label = section_label(index, e.id);
  RGS_RETURN_ERROR_IF(e.element_type != want.element_type || e.components != want.components,
                      StatusCode::kCorruptData,
                      label + ": element type " + element_type_name(e.element_type) + " x " + dec(e.components) +
                          ", expected " + element_type_name(want.element_type) + " x " + dec(want.components) +
                          (e.id == SectionId::kSh ? " for SH degree " + dec(sh_degree) : std::string()));
  RGS_RETURN_ERROR_IF(want.per_gaussian && e.element_count != f.header_.gaussian_count, StatusCode::kCorruptData,
                      label + ": element_count " + dec(e.element_count) + " != gaussian_count " +
                          dec(f.header_.gaussian_count));
  RGS_RETURN_ERROR_IF(e.id == SectionId::kMetadata && e.raw_size != kMetadataSize, StatusCode::kCorruptData,
                      label + ": raw_size " + dec(e.raw_size) + " != " + dec(kMetadataSize));
  return Status();
}

Status RgsFileAccess::read_small_section(const RgsFile& f, size_t index, uint64_t max_raw,
                                         std::vector<uint8_t>* raw) {
  const SectionEntry& e = f.sections_[index];
  // Callers have checked raw_size against its limit; this guards the allocation regardless.
  RGS_RETURN_ERROR_IF(e.raw_size > max_raw, StatusCode::kLimitExceeded,
                      section_label(index, e.id) + ": raw size " + dec(e.raw_size) + " bytes exceeds the limit of " +
                          dec(max_raw));
  raw->resize(static_cast<size_t>(e.raw_size));
  return decode(f, index, raw->data(), raw->size());
}

Status RgsFileAccess::stored_view(const RgsFile& f, size_t index, ByteView* out) {
  const SectionEntry& e = f.sections_[index];
  const ByteView view{f.data_ + e.offset, static_cast<size_t>(e.stored_size)};
  if (f.options_.verify_checksums) {
    const uint64_t computed = detail::xxh64(view.data, view.size);
    RGS_RETURN_ERROR_IF(computed != e.checksum, StatusCode::kChecksumMismatch,
                        section_label(index, e.id) + ": checksum " + hex64(e.checksum) +
                            " does not match the computed " + hex64(computed));
  }
  *out = view;
  return Status();
}

Status RgsFileAccess::decode(const RgsFile& f, size_t index, void* dst, size_t dst_size) {
  const SectionEntry& e = f.sections_[index];
  const std::string label = section_label(index, e.id);
  RGS_RETURN_ERROR_IF(dst_size != e.raw_size, StatusCode::kInvalidArgument,
                      label + ": destination holds " + dec(dst_size) + " bytes, raw size is " + dec(e.raw_size));
  RGS_RETURN_ERROR_IF(dst == nullptr && dst_size > 0, StatusCode::kInvalidArgument, label + ": null destination");
  RGS_RETURN_ERROR_IF(!is_known_codec(e.codec), StatusCode::kUnsupportedFeature,
                      label + ": codec " + dec(static_cast<uint16_t>(e.codec)) + " is unknown");
  ByteView stored;
  RGS_RETURN_IF_ERROR(stored_view(f, index, &stored));
  if (e.codec == Codec::kNone) {
    if (stored.size > 0) std::memcpy(dst, stored.data, stored.size);
    return Status();
  }
  uint8_t* out = static_cast<uint8_t*>(dst);
  const uint64_t n = e.element_count;
  Status s = e.codec == Codec::kDraco ? detail::decode_draco_means(stored.data, stored.size, n, out, dst_size)
             : e.codec == Codec::kQuantized
                 ? detail::decode_quantized(e.id, f.metadata_, stored.data, stored.size, n, e.components, out, dst_size)
                 : detail::decode_zstd_frame(stored.data, stored.size, out, dst_size);
  return s.ok() ? s : s.prepend(label);
}

Status RgsFileAccess::index_of(const RgsFile& f, SectionId id, size_t* index) {
  const SectionEntry* e = f.find(id);
  RGS_RETURN_ERROR_IF(e == nullptr, StatusCode::kInvalidArgument,
                      std::string("no section ") + section_name(id) + " (id " + dec(static_cast<uint32_t>(id)) + ")");
  *index = static_cast<size_t>(e - f.sections_.data());
  return Status();
}

Status RgsFileAccess::parse(RgsFile* f) {
  RGS_RETURN_IF_ERROR(parse_header(f));
  RGS_RETURN_IF_ERROR(parse_table(f));
  RGS_RETURN_IF_ERROR(check_placement(*f));
  for (size_t i = 0; i < f->sections_.size(); ++i) RGS_RETURN_IF_ERROR(check_entry(*f, i));
  RGS_RETURN_IF_ERROR(check_decoded_total(*f));
  for (SectionId id : {SectionId::kMetadata, SectionId::kMeans, SectionId::kRotations, SectionId::kScales,
                       SectionId::kOpacities, SectionId::kSh}) {
    RGS_RETURN_ERROR_IF(f->find(id) == nullptr, StatusCode::kCorruptData,
                        std::string("required section ") + section_name(id) + " (id " +
                            dec(static_cast<uint32_t>(id)) + ") is missing");
  }

  // §4.1 Metadata: its layout, then its content, then the limits that depend on it.
  const SectionEntry* meta = f->find(SectionId::kMetadata);
  const size_t meta_index = static_cast<size_t>(meta - f->sections_.data());
  RGS_RETURN_IF_ERROR(check_layout(*f, meta_index, 0));
  std::vector<uint8_t> raw;
  {
    Status s = read_small_section(*f, meta_index, kMetadataSize, &raw);
    if (!s.ok()) return s;
    s = detail::decode_metadata(raw.data(), raw.size(), &f->metadata_);
    if (!s.ok()) return s.prepend(section_label(meta_index, meta->id));
  }
  const ReadLimits& limits = f->options_.limits;
  RGS_RETURN_ERROR_IF(f->metadata_.sh_degree > limits.max_sh_degree, StatusCode::kLimitExceeded,
                      "SH degree " + dec(f->metadata_.sh_degree) + " exceeds the limit of " +
                          dec(limits.max_sh_degree));
  if (f->metadata_.scale_encoding == ScaleEncoding::kLog) {
    RGS_RETURN_IF_ERROR(require_version(*f, kMinVersionForLogScales, "log scales"));
  }
  // §2.2 The anti-aliased scene's flag, in a 1.6 file.
  f->metadata_.antialiased = (f->header_.required_flags & kRequiredFlagAntialiased) != 0;
  if (f->metadata_.antialiased) {
    RGS_RETURN_IF_ERROR(require_version(*f, kMinVersionForAntialiased, "the anti-aliased flag"));
  }

  for (size_t i = 0; i < f->sections_.size(); ++i) {
    RGS_RETURN_IF_ERROR(check_layout(*f, i, f->metadata_.sh_degree));
  }

  if (const SectionEntry* residual = f->find(SectionId::kShDcResidual)) {
    RGS_RETURN_IF_ERROR(require_version(
        *f, kMinVersionForShDcResidual,
        section_label(static_cast<size_t>(residual - f->sections_.data()), residual->id)));
  }

  RGS_RETURN_IF_ERROR(parse_lod(f));
  RGS_RETURN_IF_ERROR(check_sh_colour_differences(*f));
  RGS_RETURN_IF_ERROR(check_xz_codes(*f));

  // §4.2 Provenance (optional).
  if (const SectionEntry* prov = f->find(SectionId::kProvenance)) {
    const size_t index = static_cast<size_t>(prov - f->sections_.data());
    const std::string label = section_label(index, prov->id);
    RGS_RETURN_IF_ERROR(require_version(*f, kMinVersionForProvenance, label));
    RGS_RETURN_ERROR_IF(prov->raw_size > limits.max_provenance_bytes, StatusCode::kLimitExceeded,
                        label + ": " + dec(prov->raw_size) + " bytes exceed the limit of " +
                            dec(limits.max_provenance_bytes));
    RGS_RETURN_IF_ERROR(read_small_section(*f, index, limits.max_provenance_bytes, &raw));
    Status s = detail::decode_provenance(raw.data(), raw.size(), &f->provenance_);
    if (!s.ok()) return s.prepend(label);
  }
  return Status();
}

Status RgsFileAccess::check_sh_colour_differences(const RgsFile& f) {
  // §2.2, §3.3.2 SH transform 6 comes with its required flag, in a 1.4 file, and the flag with it. check_entry
  // has checked the quantized header, whose first byte is the transform.
  const SectionEntry* e = f.find(SectionId::kSh);
  const bool colour = e != nullptr && e->codec == Codec::kQuantized &&
                      f.data_[e->offset] == static_cast<uint8_t>(detail::QuantizedTransform::kShColourDifferences);
  const bool flagged = (f.header_.required_flags & kRequiredFlagShColourDifferences) != 0;
  if (!colour) {
    RGS_RETURN_ERROR_IF(flagged, StatusCode::kCorruptData,
                        "the SH colour-differences flag is set but the sh section does not use transform 6");
    return Status();
  }
  const std::string label = section_label(static_cast<size_t>(e - f.sections_.data()), e->id);
  RGS_RETURN_ERROR_IF(!flagged, StatusCode::kCorruptData,
                      label + ": transform 6 (colour differences) without its required flag");
  return require_version(f, kMinVersionForShColourDifferences, label + ": transform 6 (colour differences)");
}

Status RgsFileAccess::check_xz_codes(const RgsFile& f) {
  // §2.2 The .xz flag comes with codes in an .xz stream (check_entry checks the converse on each section, whose
  // quantized header it has checked).
  if ((f.header_.required_flags & kRequiredFlagXzCodes) == 0) return Status();
  for (const SectionEntry& e : f.sections_) {
    if (e.codec == Codec::kQuantized &&
        detail::quantized_codes_are_xz(f.data_ + e.offset, static_cast<size_t>(e.stored_size))) {
      return Status();
    }
  }
  return Status(StatusCode::kCorruptData, "the .xz codes flag is set but no quantized section stores .xz codes");
}

Status RgsFileAccess::parse_lod(RgsFile* f) {
  // §4.9 The index comes with its required flag, in a 1.3 file, over sections a range can be read from in place.
  const SectionEntry* e = f->find(SectionId::kLod);
  const bool flagged = (f->header_.required_flags & kRequiredFlagLod) != 0;
  if (e == nullptr) {
    RGS_RETURN_ERROR_IF(flagged, StatusCode::kCorruptData, "the level-of-detail flag is set but there is no lod section");
    return Status();
  }
  const size_t index = static_cast<size_t>(e - f->sections_.data());
  const std::string label = section_label(index, e->id);
  RGS_RETURN_ERROR_IF(!flagged, StatusCode::kCorruptData, label + " without the level-of-detail required flag");
  RGS_RETURN_IF_ERROR(require_version(*f, kMinVersionForLod, label));
  for (size_t i = 0; i < f->sections_.size(); ++i) {
    const SectionEntry& s = f->sections_[i];
    detail::SectionLayout layout;
    if (!detail::expected_layout(s.id, 0, &layout) || !layout.per_gaussian) continue;
    RGS_RETURN_ERROR_IF(s.codec != Codec::kNone, StatusCode::kCorruptData,
                        section_label(i, s.id) + ": codec " + codec_name(s.codec) +
                            " in a level-of-detail file, whose per-Gaussian sections are stored raw (SPEC 4.9)");
  }
  // At most 16 + 400 bytes per Gaussian (C <= N, L <= 16); the raw size was also checked against the limits.
  const uint64_t max_raw = kLodHeadSize + (kLodChunkRecordSize + kLodLevelRecordSize * kMaxLodLevels) *
                                              std::min<uint64_t>(f->header_.gaussian_count, UINT32_MAX);
  RGS_RETURN_ERROR_IF(e->raw_size > max_raw, StatusCode::kCorruptData,
                      label + ": " + dec(e->raw_size) + " bytes, more than any index of " +
                          dec(f->header_.gaussian_count) + " Gaussians takes (16 + 400 N)");
  std::vector<uint8_t> raw;
  RGS_RETURN_IF_ERROR(read_small_section(*f, index, max_raw, &raw));
  auto lod = std::make_shared<LodIndex>();
  Status s = detail::decode_lod(raw.data(), raw.size(), f->header_.gaussian_count, lod.get());
  if (!s.ok()) return s.prepend(label);
  f->lod_ = std::move(lod);
  return Status();
}

Status RgsFileAccess::check_range_index(const RgsFile& f, uint32_t level, uint32_t chunk) {
  const std::string& name = f.name_;
  RGS_RETURN_ERROR_IF(f.lod_ == nullptr, StatusCode::kInvalidArgument, name + ": no level-of-detail index");
  RGS_RETURN_ERROR_IF(level >= f.lod_->level_count || chunk >= f.lod_->chunk_count, StatusCode::kInvalidArgument,
                      name + ": lod chunk " + detail::dec(chunk) + " level " + detail::dec(level) + " outside its " +
                          detail::dec(f.lod_->chunk_count) + " chunks of " + detail::dec(f.lod_->level_count) +
                          " levels");
  return Status();
}

LodRangeView RgsFileAccess::range_view(const RgsFile& f, uint32_t level, uint32_t chunk) {
  const LodLevel& v = f.lod_->at(level, chunk);
  std::array<const uint8_t*, 6> parts{};
  for (size_t a = 0; a < 6; ++a) {
    if (const SectionEntry* e = f.find(detail::kGaussianSections[a])) parts[a] = f.data_ + e->offset;
  }
  return detail::lod_range_view(parts, v.first, v.count, f.metadata_.sh_degree);
}

Result<LodRangeView> RgsFile::lod_range(uint32_t level, uint32_t chunk) const {
  RGS_RETURN_IF_ERROR(RgsFileAccess::check_range_index(*this, level, chunk));
  const LodRangeView view = RgsFileAccess::range_view(*this, level, chunk);
  Status s = detail::check_lod_range(*lod_, level, chunk, view, metadata_, options_.verify_checksums);
  if (!s.ok()) return s.prepend(name_);
  return view;
}

namespace {

/// The destinations of `target` in LodRangeView's order of parts.
std::array<uint8_t*, 6> destinations(const LodRangeTarget& target) {
  return {target.means, target.rotations, target.scales, target.opacities, target.sh, target.sh_dc_residual};
}

/// Views of Gaussians [begin, end) of `range` (a whole range as the file stores it, or the file's parts in
/// `range` replaced by a copy's destinations in `target` when `target` is not null): each part's records
/// [begin, end). kInvalidArgument when `target` lacks a destination for a part the file has.
Status slice_views(const LodRangeView& range, const LodRangeTarget* target, uint64_t begin, uint64_t end,
                   const std::string& name, LodRangeView* out) {
  *out = range;
  out->first = range.first + begin;
  out->count = end - begin;
  ByteView* views[6] = {&out->means, &out->rotations, &out->scales, &out->opacities, &out->sh, &out->sh_dc_residual};
  const std::array<uint8_t*, 6> copies = target != nullptr ? destinations(*target) : std::array<uint8_t*, 6>{};
  for (int a = 0; a < 6; ++a) {
    if (views[a]->size == 0) continue;
    RGS_RETURN_ERROR_IF(target != nullptr && copies[a] == nullptr, StatusCode::kInvalidArgument,
                        name + ": a level-of-detail copy without a destination for a part of the range");
    const size_t record = views[a]->size / static_cast<size_t>(range.count);
    *views[a] = ByteView{(target != nullptr ? copies[a] : views[a]->data) + begin * record,
                         static_cast<size_t>((end - begin) * record)};
  }
  return Status();
}

/// Copies Gaussians [begin, end) of `range` into `target` (at the places the whole range's copy takes) and
/// returns views of the copied Gaussians in `copy`.
Status copy_slice(const LodRangeView& range, const LodRangeTarget& target, uint64_t begin, uint64_t end,
                  const std::string& name, LodRangeView* copy) {
  LodRangeView source;
  RGS_RETURN_IF_ERROR(slice_views(range, nullptr, begin, end, name, &source));
  RGS_RETURN_IF_ERROR(slice_views(range, &target, begin, end, name, copy));
  const std::array<uint8_t*, 6> to = destinations(target);
  const ByteView* from[6] = {&source.means, &source.rotations, &source.scales,
                             &source.opacities, &source.sh, &source.sh_dc_residual};
  for (int a = 0; a < 6; ++a) {
    if (from[a]->size == 0) continue;
    const size_t record = from[a]->size / static_cast<size_t>(end - begin);
    std::memcpy(to[a] + begin * record, from[a]->data, from[a]->size);
  }
  return Status();
}

}  // namespace

Result<LodRangeView> RgsFile::read_lod_range(uint32_t level, uint32_t chunk, const LodRangeTarget& target) const {
  RGS_RETURN_IF_ERROR(RgsFileAccess::check_range_index(*this, level, chunk));
  const LodRangeView range = RgsFileAccess::range_view(*this, level, chunk);
  LodRangeView copy;
  RGS_RETURN_IF_ERROR(copy_slice(range, target, 0, range.count, name_, &copy));
  Status s = detail::check_lod_range(*lod_, level, chunk, copy, metadata_, options_.verify_checksums);
  if (!s.ok()) return s.prepend(name_);
  return copy;
}

Status RgsFile::read_lod_slice(uint32_t level, uint32_t chunk, const LodRangeTarget& target, uint64_t begin,
                               uint64_t end) const {
  RGS_RETURN_IF_ERROR(RgsFileAccess::check_range_index(*this, level, chunk));
  const LodRangeView range = RgsFileAccess::range_view(*this, level, chunk);
  RGS_RETURN_ERROR_IF(begin > end || end > range.count, StatusCode::kInvalidArgument,
                      name_ + ": slice [" + detail::dec(begin) + ", " + detail::dec(end) + ") of a range of " +
                          detail::dec(range.count) + " Gaussians");
  if (begin == end) return Status();
  LodRangeView copy;
  RGS_RETURN_IF_ERROR(copy_slice(range, target, begin, end, name_, &copy));
  Status s = detail::check_lod_values(*lod_, level, chunk, copy, metadata_);
  return s.ok() ? s : s.prepend(name_);
}

Status RgsFile::check_lod_checksum(uint32_t level, uint32_t chunk, const LodRangeTarget& copy) const {
  RGS_RETURN_IF_ERROR(RgsFileAccess::check_range_index(*this, level, chunk));
  if (!options_.verify_checksums) return Status();
  const LodRangeView range = RgsFileAccess::range_view(*this, level, chunk);
  LodRangeView view;
  RGS_RETURN_IF_ERROR(slice_views(range, &copy, 0, range.count, name_, &view));
  Status s = detail::check_lod_checksum(*lod_, level, chunk, view);
  return s.ok() ? s : s.prepend(name_);
}

Result<RgsFile> RgsFile::open(const std::string& path, const ReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(std::shared_ptr<const MappedFile> mapping, MappedFile::open(path));
  auto file = from_bytes(mapping->data(), mapping->size(), options, path);
  if (!file.ok()) return file;
  file->mapping_ = std::move(mapping);
  return file;
}

Result<RgsFile> RgsFile::from_bytes(const uint8_t* data, size_t size, const ReadOptions& options,
                                    const std::string& name) {
  return catch_bad_alloc([&]() -> Result<RgsFile> {
    RgsFile f;
    f.name_ = name;
    if (data == nullptr && size > 0) {
      return Status(StatusCode::kInvalidArgument, name + ": null data with size " + dec(size));
    }
    static const uint8_t kEmpty[1] = {0};
    f.data_ = data == nullptr ? kEmpty : data;
    f.size_ = size;
    f.options_ = options;
    Status s = RgsFileAccess::parse(&f);
    if (!s.ok()) return s.prepend(name);
    return f;
  }, [&] { return name + ": out of memory opening the file"; });
}

const SectionEntry* RgsFile::find(SectionId id) const {
  for (const SectionEntry& e : sections_) {
    if (e.id == id) return &e;
  }
  return nullptr;
}

Result<ByteView> RgsFile::stored_bytes(SectionId id) const {
  size_t index = 0;
  ByteView view;
  Status s = RgsFileAccess::index_of(*this, id, &index);
  if (s.ok()) s = RgsFileAccess::stored_view(*this, index, &view);
  if (!s.ok()) return s.prepend(name_);
  return view;
}

Status RgsFile::decode_section(SectionId id, void* dst, size_t dst_size) const {
  size_t index = 0;
  Status s = RgsFileAccess::index_of(*this, id, &index);
  if (s.ok()) s = RgsFileAccess::decode(*this, index, dst, dst_size);
  return s.ok() ? s : s.prepend(name_);
}

namespace {

/// Decodes a section into a typed host array, converting from little-endian when the host is not. An archive
/// section is checked there (decode_verified_section), the others were verified before.
template <typename T>
Status decode_array(const RgsFile& file, SectionId id, std::vector<T>* out) {
  const SectionEntry* e = file.find(id);
  RGS_RETURN_ERROR_IF(e->raw_size > SIZE_MAX, StatusCode::kOutOfMemory,
                      file.name() + ": section " + section_name(id) + " does not fit this address space");
  out->resize(static_cast<size_t>(e->raw_size / sizeof(T)));
  uint8_t* bytes = reinterpret_cast<uint8_t*>(out->data());
  RGS_RETURN_IF_ERROR(is_archive_codec(e->codec) ? file.decode_verified_section(id, bytes, out->size() * sizeof(T))
                                                 : file.decode_section(id, bytes, out->size() * sizeof(T)));
  if constexpr (!detail::kHostLittleEndian && sizeof(T) > 1) {
    for (size_t i = 0; i < out->size(); ++i) {
      if constexpr (sizeof(T) == 2) {
        (*out)[i] = load_u16_le(bytes + 2 * i);
      } else {
        (*out)[i] = load_f32_le(bytes + 4 * i);
      }
    }
  }
  return Status();
}

}  // namespace

Result<EncodedScene> RgsFile::read_scene() const {
  return catch_bad_alloc([&]() -> Result<EncodedScene> {
    EncodedScene scene;
    scene.metadata = metadata_;
    scene.provenance = provenance_;
    scene.count = header_.gaussian_count;
    // Checksums, frames and values first, in bounded memory: a damaged zstd frame or an invalid value fails
    // before the arrays it claims are allocated, and no path renders values the spec rules out. Archive
    // sections decode whole either way: decode_array checks them once decoded, instead of decoding twice.
    for (SectionId id : detail::kGaussianSections) {
      const SectionEntry* e = find(id);
      if (id == SectionId::kShDcResidual && e == nullptr) continue;  // optional
      if (e != nullptr && is_archive_codec(e->codec)) continue;
      RGS_RETURN_IF_ERROR(verify_section(id));
    }
    RGS_RETURN_IF_ERROR(decode_array(*this, SectionId::kMeans, &scene.means));
    RGS_RETURN_IF_ERROR(decode_array(*this, SectionId::kRotations, &scene.rotations));
    RGS_RETURN_IF_ERROR(decode_array(*this, SectionId::kScales, &scene.scales));
    RGS_RETURN_IF_ERROR(decode_array(*this, SectionId::kOpacities, &scene.opacities));
    RGS_RETURN_IF_ERROR(decode_array(*this, SectionId::kSh, &scene.sh));
    if (find(SectionId::kShDcResidual) != nullptr) {
      RGS_RETURN_IF_ERROR(decode_array(*this, SectionId::kShDcResidual, &scene.sh_dc_residual));
    }
    if (lod_ != nullptr) {
      // §4.9 The full detail is the prefix of every section: the coarser levels are dropped.
      const uint64_t n = lod_->full_detail_count();
      const uint64_t k3 = uint64_t{3} * sh_coefficient_count(metadata_.sh_degree);
      scene.count = n;
      scene.means.resize(n * 3);
      scene.rotations.resize(n * 4);
      scene.scales.resize(n * 3);
      scene.opacities.resize(n);
      scene.sh.resize(n * k3);
      if (!scene.sh_dc_residual.empty()) scene.sh_dc_residual.resize(n * 3);
      // Every level-0 range of the copy is checked as a loader of ranges checks its copy (read_lod_range):
      // its XXH64 and the chunk sphere's rule, which the sections' checks above do not cover.
      const auto bytes = [](const auto& array) {
        return array.empty() ? nullptr : reinterpret_cast<const uint8_t*>(array.data());
      };
      const std::array<const uint8_t*, 6> parts = {bytes(scene.means),     bytes(scene.rotations), bytes(scene.scales),
                                                   bytes(scene.opacities), bytes(scene.sh),
                                                   bytes(scene.sh_dc_residual)};
      for (uint32_t chunk = 0; chunk < lod_->chunk_count; ++chunk) {
        const LodLevel& r = lod_->at(0, chunk);
        const LodRangeView view = detail::lod_range_view(parts, r.first, r.count, metadata_.sh_degree);
        Status s = detail::check_lod_range(*lod_, 0, chunk, view, metadata_, options_.verify_checksums);
        if (!s.ok()) return s.prepend(name_);
      }
    }
    return scene;
  }, [&] { return name_ + ": out of memory decoding " + dec(header_.gaussian_count) + " Gaussians"; });
}

namespace {

/// Checks section `index` as verify_section() documents; `raw` holds its decoded bytes when the caller already
/// has them (an archive section then is not decoded again). Errors name the file and the section.
Status validate_section(const RgsFile& file, size_t index, const uint8_t* raw = nullptr) {
  const SectionEntry& e = file.sections()[index];
  if (raw == nullptr && is_archive_codec(e.codec)) {
    // §3.3 Archive sections decode whole (their raw size is bounded by the read limits at open), then
    // their values are checked like any runtime section's.
    std::vector<uint8_t> decoded(static_cast<size_t>(e.raw_size));
    return file.decode_verified_section(e.id, decoded.data(), decoded.size());
  }
  ByteView stored{raw, static_cast<size_t>(e.raw_size)};
  if (raw == nullptr) {
    RGS_ASSIGN_OR_RETURN(stored, file.stored_bytes(e.id));  // message names the file
  }
  const size_t record_size = static_cast<size_t>(e.components) * element_type_size(e.element_type);
  detail::SectionLayout layout;  // the value rules check the records of the runtime (per-Gaussian) sections
  const bool values = detail::expected_layout(e.id, 0, &layout) && layout.per_gaussian && record_size > 0;
  Status s;
  if (raw != nullptr || e.codec == Codec::kNone) {
    if (values && e.raw_size > 0) {
      s = detail::check_records(e.id, file.metadata(), stored.data, static_cast<size_t>(e.raw_size / record_size),
                                record_size, 0);
    }
  } else if (e.codec == Codec::kZstd) {
    // Runtime sections are checked one Gaussian (record) at a time as the frame streams; others only decode.
    s = detail::stream_zstd_frame(e.id, values ? &file.metadata() : nullptr, stored.data, stored.size, e.raw_size,
                                  values ? record_size : 1);
  }
  return s.ok() ? s : s.prepend(file.name() + ": " + section_label(index, e.id));
}

}  // namespace

Status RgsFile::decode_verified_section(SectionId id, void* dst, size_t dst_size) const {
  RGS_RETURN_IF_ERROR(decode_section(id, dst, dst_size));  // names the file and the section
  return validate_section(*this, static_cast<size_t>(find(id) - sections_.data()), static_cast<const uint8_t*>(dst));
}

Status RgsFile::verify_section(SectionId id) const {
  size_t index = 0;
  Status s = RgsFileAccess::index_of(*this, id, &index);
  if (!s.ok()) return s.prepend(name_);
  return catch_bad_alloc([&] { return validate_section(*this, index); },
                         [&] { return name_ + ": out of memory checking " + section_name(id); });
}

Status validate(const uint8_t* data, size_t size, const ReadLimits& limits, const std::string& name) {
  return catch_bad_alloc([&]() -> Status {
    ReadOptions options;
    options.limits = limits;
    options.verify_checksums = true;
    RGS_ASSIGN_OR_RETURN(RgsFile file, RgsFile::from_bytes(data, size, options, name));
    for (size_t i = 0; i < file.sections().size(); ++i) RGS_RETURN_IF_ERROR(validate_section(file, i));
    if (const LodIndex* lod = file.lod()) {
      for (uint32_t l = 0; l < lod->level_count; ++l) {
        for (uint32_t c = 0; c < lod->chunk_count; ++c) RGS_RETURN_IF_ERROR(file.lod_range(l, c).status());
      }
    }
    return Status();
  }, [&] { return name + ": out of memory validating the file"; });
}

bool is_rgs_path(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  in.read(head, 8);
  if (in.gcount() == 8 && std::memcmp(head, kMagic, 8) == 0) return true;
  if (path.size() < 4) return false;
  std::string ext = path.substr(path.size() - 4);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".rgs";
}

}  // namespace rgs::format
