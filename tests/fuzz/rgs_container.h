// A lenient model of the .rgs container (SPEC §2-§3) for the structure-aware fuzzer: it parses damaged
// files as far as it can, lets the mutator edit header fields, table entries and section bytes, and writes
// them back with the SPEC §3 layout and freshly computed XXH64 checksums, so mutations get past the
// integrity checks and reach the value checks and decoders behind them.
//
// Test code only: it trusts nothing it reads but makes no claim of validity about what it writes.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace rgs::fuzz {

/// Byte offsets of the header fields (SPEC §2) and of the table entry fields (SPEC §3.1).
namespace header_field {
inline constexpr size_t kMajor = 8, kMinor = 10, kHeaderSize = 12, kRequiredFlags = 16, kOptionalFlags = 20,
                        kGaussianCount = 24, kSectionCount = 32, kReserved = 36, kTableOffset = 40,
                        kFileSize = 48, kChecksum = 56;
}  // namespace header_field
namespace entry_field {
inline constexpr size_t kId = 0, kCodec = 4, kElementType = 6, kComponents = 8, kReserved = 12,
                        kElementCount = 16, kOffset = 24, kStoredSize = 32, kRawSize = 40, kChecksum = 48,
                        kReserved2 = 56;
}  // namespace entry_field

/// Little-endian load and store of `bytes` (1..8) bytes.
uint64_t load_le(const uint8_t* p, size_t bytes);
void store_le(uint8_t* p, size_t bytes, uint64_t value);

/// One section: its 64-byte table entry as found (offset, sizes and checksum are rewritten on
/// serialization) and its stored bytes.
struct LooseSection {
  std::array<uint8_t, 64> entry{};
  std::vector<uint8_t> stored;

  uint32_t id() const { return static_cast<uint32_t>(load_le(&entry[entry_field::kId], 4)); }
  uint16_t codec() const { return static_cast<uint16_t>(load_le(&entry[entry_field::kCodec], 2)); }
  uint64_t get(size_t field, size_t bytes) const { return load_le(&entry[field], bytes); }
  void set(size_t field, size_t bytes, uint64_t value) { store_le(&entry[field], bytes, value); }
};

/// A header and its sections in table order.
struct LooseContainer {
  std::array<uint8_t, 64> header{};
  std::vector<LooseSection> sections;

  uint64_t get(size_t field, size_t bytes) const { return load_le(&header[field], bytes); }
  void set(size_t field, size_t bytes, uint64_t value) { store_le(&header[field], bytes, value); }
};

/// Parses `data` leniently: needs the 64 header bytes and a table of at most `max_sections` entries that
/// fits in the input; a section whose range leaves the input keeps the part inside it. Returns false when
/// there is no such header and table.
bool parse_loose(const uint8_t* data, size_t size, LooseContainer* out, uint32_t max_sections = 64);

/// Writes `c` with the SPEC §3 layout: section_count, table_offset 64, offsets at align256 of the previous
/// end, zero padding, stored_size and file_size from the bytes, every section checksum and then the header
/// checksum recomputed. Other fields (header_size, counts, raw sizes, reserved fields) are written as they
/// are in `c`, so the mutator controls them.
std::vector<uint8_t> serialize_loose(const LooseContainer& c);

/// In place, for a buffer that may not parse: recomputes the checksum of every table entry whose stored
/// range lies inside the buffer, then the header checksum over [0, 56) and the part of the table inside the
/// buffer. Does nothing to buffers shorter than the header.
void fix_checksums(uint8_t* data, size_t size);

/// Bytes per component of a known element type (SPEC §3.1), 0 for an unknown one.
uint32_t element_size(uint16_t element_type);

}  // namespace rgs::fuzz
