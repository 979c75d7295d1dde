// Lenient .rgs container model for the structure-aware fuzzer (rgs_container.h).
#include "rgs_container.h"

#include <xxhash.h>

#include <algorithm>

namespace rgs::fuzz {
namespace {

constexpr size_t kHeaderBytes = 64;
constexpr size_t kEntryBytes = 64;
constexpr uint64_t kAlignment = 256;

uint64_t align_up(uint64_t x) { return (x + kAlignment - 1) / kAlignment * kAlignment; }

// SPEC §2.3: XXH64 over header bytes [0, 56) and the table as one stream.
uint64_t header_checksum(const uint8_t* header, const uint8_t* table, size_t table_bytes) {
  XXH64_state_t* state = XXH64_createState();
  XXH64_reset(state, 0);
  XXH64_update(state, header, 56);
  if (table_bytes > 0) XXH64_update(state, table, table_bytes);
  const uint64_t sum = XXH64_digest(state);
  XXH64_freeState(state);
  return sum;
}

}  // namespace

uint64_t load_le(const uint8_t* p, size_t bytes) {
  uint64_t v = 0;
  for (size_t i = 0; i < bytes; ++i) v |= uint64_t{p[i]} << (8 * i);
  return v;
}

void store_le(uint8_t* p, size_t bytes, uint64_t value) {
  for (size_t i = 0; i < bytes; ++i) p[i] = static_cast<uint8_t>(value >> (8 * i));
}

uint32_t element_size(uint16_t element_type) {
  switch (element_type) {
    case 0: return 1;
    case 1: return 1;
    case 2: return 2;
    case 3: return 4;
    default: return 0;
  }
}

bool parse_loose(const uint8_t* data, size_t size, LooseContainer* out, uint32_t max_sections) {
  if (size < kHeaderBytes) return false;
  const uint64_t count = load_le(data + header_field::kSectionCount, 4);
  if (count > max_sections || kHeaderBytes + count * kEntryBytes > size) return false;
  std::copy(data, data + kHeaderBytes, out->header.begin());
  out->sections.clear();
  out->sections.resize(count);
  for (size_t i = 0; i < count; ++i) {
    LooseSection& s = out->sections[i];
    const uint8_t* e = data + kHeaderBytes + i * kEntryBytes;
    std::copy(e, e + kEntryBytes, s.entry.begin());
    const uint64_t offset = s.get(entry_field::kOffset, 8);
    const uint64_t stored = s.get(entry_field::kStoredSize, 8);
    if (offset >= size) continue;
    const uint64_t n = std::min<uint64_t>(stored, size - offset);
    s.stored.assign(data + offset, data + offset + n);
  }
  return true;
}

std::vector<uint8_t> serialize_loose(const LooseContainer& c) {
  const size_t count = c.sections.size();
  const size_t table_end = kHeaderBytes + count * kEntryBytes;
  std::vector<uint64_t> offsets(count);
  uint64_t end = table_end;
  for (size_t i = 0; i < count; ++i) {
    offsets[i] = align_up(end);
    end = offsets[i] + c.sections[i].stored.size();
  }
  std::vector<uint8_t> out(end, 0);
  std::copy(c.header.begin(), c.header.end(), out.begin());
  store_le(&out[header_field::kSectionCount], 4, count);
  store_le(&out[header_field::kTableOffset], 8, kHeaderBytes);
  store_le(&out[header_field::kFileSize], 8, end);
  for (size_t i = 0; i < count; ++i) {
    const LooseSection& s = c.sections[i];
    uint8_t* e = &out[kHeaderBytes + i * kEntryBytes];
    std::copy(s.entry.begin(), s.entry.end(), e);
    store_le(e + entry_field::kOffset, 8, offsets[i]);
    store_le(e + entry_field::kStoredSize, 8, s.stored.size());
    store_le(e + entry_field::kChecksum, 8, XXH64(s.stored.data(), s.stored.size(), 0));
    std::copy(s.stored.begin(), s.stored.end(), out.begin() + static_cast<std::ptrdiff_t>(offsets[i]));
  }
  store_le(&out[header_field::kChecksum], 8,
           header_checksum(out.data(), out.data() + kHeaderBytes, count * kEntryBytes));
  return out;
}

void fix_checksums(uint8_t* data, size_t size) {
  if (size < kHeaderBytes) return;
  const uint64_t count = load_le(data + header_field::kSectionCount, 4);
  const uint64_t entries_inside = std::min<uint64_t>(count, (size - kHeaderBytes) / kEntryBytes);
  for (uint64_t i = 0; i < entries_inside; ++i) {
    uint8_t* e = data + kHeaderBytes + i * kEntryBytes;
    const uint64_t offset = load_le(e + entry_field::kOffset, 8);
    const uint64_t stored = load_le(e + entry_field::kStoredSize, 8);
    if (offset > size || stored > size - offset) continue;
    store_le(e + entry_field::kChecksum, 8, XXH64(data + offset, stored, 0));
  }
  // The reader hashes the whole declared table; when it runs past the end it fails before the checksum.
  store_le(data + header_field::kChecksum, 8,
           header_checksum(data, data + kHeaderBytes, entries_inside * kEntryBytes));
}

}  // namespace rgs::fuzz
