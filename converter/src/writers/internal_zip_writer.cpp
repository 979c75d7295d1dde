// A stored-only ZIP writer (APPNOTE 6.3: local headers, central directory, end record). zlib gives the CRC-32.
// Not libzip, which reads the bundles: libzip 1.7.3 writes "version made by" 6.3 and "version needed" 1.0 for a
// stored entry, with no call to set either, so every .sog would change in three bytes per entry (ours: 2.0, 2.0).
#include <zlib.h>

#include <cassert>

#include "../internal_zip.h"

namespace rgs::converter::detail {

namespace {

void put16(std::vector<uint8_t>* out, uint32_t v) {
  out->push_back(static_cast<uint8_t>(v));
  out->push_back(static_cast<uint8_t>(v >> 8));
}
void put32(std::vector<uint8_t>* out, uint32_t v) {
  put16(out, v & 0xffffu);
  put16(out, v >> 16);
}

/// The fields local and central headers share, from "version needed" to the extra field's length.
void put_common(std::vector<uint8_t>* out, uint32_t crc, uint32_t size, size_t name_bytes) {
  put16(out, 20);  // version needed: 2.0
  put16(out, 0);   // flags
  put16(out, 0);   // method: stored
  put16(out, 0);   // time
  put16(out, 0x21);  // date: 1980-01-01
  put32(out, crc);
  put32(out, size);  // compressed
  put32(out, size);  // uncompressed
  put16(out, static_cast<uint32_t>(name_bytes));
  put16(out, 0);  // extra field
}

}  // namespace

std::vector<uint8_t> write_stored_zip(const std::vector<ZipSource>& sources) {
  assert(sources.size() < 0xffff);
  std::vector<uint8_t> out, central;
  for (const ZipSource& s : sources) {
    const std::vector<uint8_t>& b = *s.bytes;
    assert(b.size() < 0xffffffffu && out.size() < 0xffffffffu);
    const auto crc = static_cast<uint32_t>(crc32_z(crc32(0L, Z_NULL, 0), b.data(), b.size()));
    const auto offset = static_cast<uint32_t>(out.size());
    put32(&out, 0x04034b50);
    put_common(&out, crc, static_cast<uint32_t>(b.size()), s.name.size());
    out.insert(out.end(), s.name.begin(), s.name.end());
    out.insert(out.end(), b.begin(), b.end());
    put32(&central, 0x02014b50);
    put16(&central, 20);  // made by: MS-DOS attributes, 2.0
    put_common(&central, crc, static_cast<uint32_t>(b.size()), s.name.size());
    put16(&central, 0);  // comment
    put16(&central, 0);  // disk
    put16(&central, 0);  // internal attributes
    put32(&central, 0);  // external attributes
    put32(&central, offset);
    central.insert(central.end(), s.name.begin(), s.name.end());
  }
  const auto central_offset = static_cast<uint32_t>(out.size());
  assert(out.size() + central.size() < 0xffffffffu);
  out.insert(out.end(), central.begin(), central.end());
  put32(&out, 0x06054b50);
  put16(&out, 0);
  put16(&out, 0);
  put16(&out, static_cast<uint32_t>(sources.size()));
  put16(&out, static_cast<uint32_t>(sources.size()));
  put32(&out, static_cast<uint32_t>(central.size()));
  put32(&out, central_offset);
  put16(&out, 0);
  return out;
}

}  // namespace rgs::converter::detail
