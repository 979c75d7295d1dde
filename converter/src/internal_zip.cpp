// ZIP structures as in PKWARE's APPNOTE.TXT: end of central directory (4.3.16), central directory file
// header (4.3.12), local file header (4.3.7).
#include "internal_zip.h"

#include <zlib.h>

#include <algorithm>
#include <limits>
#include <new>

#include "internal_interop.h"

namespace rgs::converter::detail {

namespace {

constexpr uint32_t kLocalHeaderSignature = 0x04034b50;
constexpr uint32_t kCentralHeaderSignature = 0x02014b50;
constexpr uint32_t kEndSignature = 0x06054b50;
constexpr size_t kEndRecordBytes = 22;
constexpr size_t kCentralHeaderBytes = 46;
constexpr size_t kLocalHeaderBytes = 30;
constexpr size_t kMaxCommentBytes = 0xffff;

}  // namespace

bool has_zip_magic(const uint8_t* data, size_t size) {
  if (size < 4) return false;
  const uint32_t sig = le_u32(data);
  return sig == kLocalHeaderSignature || sig == kEndSignature;
}

Result<ZipArchive> ZipArchive::parse(const uint8_t* data, size_t size, const std::string& name, uint64_t base_offset) {
  ZipArchive zip;
  zip.data_ = data;
  zip.size_ = size;
  zip.name_ = name;
  zip.base_offset_ = base_offset;
  if (size < kEndRecordBytes) {
    return Status(StatusCode::kCorruptData,
                  name + ": ZIP archive of " + std::to_string(size) + " bytes is too short for an end record");
  }
  // The end record is the last 22 bytes plus a comment of up to 65535 bytes: search backwards.
  size_t end = size;  // offset of the end record; size = not found
  const size_t lowest = size - kEndRecordBytes > kMaxCommentBytes ? size - kEndRecordBytes - kMaxCommentBytes : 0;
  for (size_t at = size - kEndRecordBytes + 1; at-- > lowest;) {
    if (le_u32(data + at) == kEndSignature && at + kEndRecordBytes + le_u16(data + at + 20) == size) {
      end = at;
      break;
    }
  }
  if (end == size) {
    return Status(StatusCode::kCorruptData, name + ": no ZIP end-of-central-directory record (truncated archive?)");
  }
  const uint8_t* e = data + end;
  const uint16_t disk = le_u16(e + 4), cd_disk = le_u16(e + 6);
  const uint16_t disk_entries = le_u16(e + 8), entries = le_u16(e + 10);
  const uint32_t cd_size = le_u32(e + 12), cd_offset = le_u32(e + 16);
  if (entries == 0xffff || cd_size == 0xffffffffu || cd_offset == 0xffffffffu) {
    return Status(StatusCode::kUnsupportedFeature, name + ": ZIP64 archives are not supported");
  }
  if (disk != 0 || cd_disk != 0 || disk_entries != entries) {
    return Status(StatusCode::kUnsupportedFeature, name + ": multi-disk ZIP archives are not supported");
  }
  if (cd_offset < base_offset) {
    return Status(StatusCode::kCorruptData, name + ": ZIP central directory starts at " + std::to_string(cd_offset) +
                                                ", before the " + std::to_string(size) + " bytes read");
  }
  if (uint64_t{cd_offset} + cd_size > base_offset + end) {
    return Status(StatusCode::kCorruptData, name + ": ZIP central directory [" + std::to_string(cd_offset) + ", " +
                                                std::to_string(uint64_t{cd_offset} + cd_size) +
                                                ") overlaps the end record at " + std::to_string(end));
  }
  const uint8_t* p = data + (cd_offset - base_offset);
  const uint8_t* cd_end = p + cd_size;
  zip.entries_.reserve(entries);
  for (uint32_t i = 0; i < entries; ++i) {
    if (static_cast<size_t>(cd_end - p) < kCentralHeaderBytes || le_u32(p) != kCentralHeaderSignature) {
      return Status(StatusCode::kCorruptData, name + ": ZIP central directory entry " + std::to_string(i) + " of " +
                                                  std::to_string(entries) + " is malformed or missing");
    }
    const uint16_t flags = le_u16(p + 8);
    ZipEntry entry;
    entry.method = le_u16(p + 10);
    entry.crc32 = le_u32(p + 16);
    entry.compressed_size = le_u32(p + 20);
    entry.uncompressed_size = le_u32(p + 24);
    const size_t name_len = le_u16(p + 28), extra_len = le_u16(p + 30), comment_len = le_u16(p + 32);
    entry.local_header_offset = le_u32(p + 42);
    const size_t record = kCentralHeaderBytes + name_len + extra_len + comment_len;
    if (static_cast<size_t>(cd_end - p) < record) {
      return Status(StatusCode::kCorruptData,
                    name + ": ZIP central directory entry " + std::to_string(i) + " runs past the directory");
    }
    entry.name.assign(reinterpret_cast<const char*>(p + kCentralHeaderBytes), name_len);
    if (flags & 0x1) {
      return Status(StatusCode::kUnsupportedFeature, name + ": ZIP entry '" + entry.name + "' is encrypted");
    }
    if (entry.compressed_size == 0xffffffffu || entry.uncompressed_size == 0xffffffffu ||
        entry.local_header_offset == 0xffffffffu) {
      return Status(StatusCode::kUnsupportedFeature, name + ": ZIP entry '" + entry.name + "' uses ZIP64 sizes");
    }
    if (entry.local_header_offset + kLocalHeaderBytes + entry.compressed_size > cd_offset) {
      return Status(StatusCode::kCorruptData,
                    name + ": ZIP entry '" + entry.name + "' (" + std::to_string(entry.compressed_size) + " bytes at " +
                        std::to_string(entry.local_header_offset) + ") extends past the central directory at " +
                        std::to_string(cd_offset));
    }
    zip.entries_.push_back(std::move(entry));
    p += record;
  }
  return zip;
}

const ZipEntry* ZipArchive::find(const std::string& name) const {
  for (const ZipEntry& e : entries_) {
    if (e.name == name) return &e;
  }
  return nullptr;
}

Status ZipArchive::extract(const ZipEntry& entry, uint64_t max_bytes, std::vector<uint8_t>* out) const {
  const std::string where = name_ + ": ZIP entry '" + entry.name + "'";
  if (base_offset_ != 0) {
    return Status(StatusCode::kInvalidArgument, where + ": the archive was parsed from its tail only");
  }
  if (entry.uncompressed_size > max_bytes) {
    return Status(StatusCode::kLimitExceeded, where + " is " + std::to_string(entry.uncompressed_size) +
                                                  " bytes, above the limit of " + std::to_string(max_bytes));
  }
  const uint8_t* local = data_ + entry.local_header_offset;
  if (le_u32(local) != kLocalHeaderSignature) {
    return Status(StatusCode::kCorruptData,
                  where + ": no local file header at offset " + std::to_string(entry.local_header_offset));
  }
  const uint64_t data_offset = entry.local_header_offset + kLocalHeaderBytes + le_u16(local + 26) + le_u16(local + 28);
  if (data_offset + entry.compressed_size > size_) {
    return Status(StatusCode::kCorruptData, where + ": data [" + std::to_string(data_offset) + ", " +
                                                std::to_string(data_offset + entry.compressed_size) +
                                                ") ends past the archive's " + std::to_string(size_) + " bytes");
  }
  const uint8_t* src = data_ + data_offset;
  // Sizes the entry's bytes cannot produce are refused before allocating: a stored entry is its bytes, and
  // deflate expands at most 1032:1 (RFC 1951: a 258-byte match costs at least 2 bits).
  if (entry.method == 0 && entry.compressed_size != entry.uncompressed_size) {
    return Status(StatusCode::kCorruptData, where + " is stored but its sizes differ (" +
                                                std::to_string(entry.compressed_size) + " vs " +
                                                std::to_string(entry.uncompressed_size) + ")");
  }
  if (entry.method == 8 && entry.uncompressed_size / 1032 > entry.compressed_size) {
    return Status(StatusCode::kCorruptData, where + " claims " + std::to_string(entry.uncompressed_size) +
                                                " bytes, more than its " + std::to_string(entry.compressed_size) +
                                                " deflated bytes can hold");
  }
  try {
    out->resize(static_cast<size_t>(entry.uncompressed_size));
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory,
                  where + ": cannot allocate " + std::to_string(entry.uncompressed_size) + " bytes");
  }
  if (entry.method == 0) {
    std::copy(src, src + entry.compressed_size, out->begin());
  } else if (entry.method == 8) {
    z_stream z{};
    if (inflateInit2(&z, -MAX_WBITS) != Z_OK) {
      return Status(StatusCode::kOutOfMemory, where + ": cannot initialize zlib");
    }
    // Entries of a .sog are at most a few hundred MB, far below the 4 GiB that uInt counts.
    z.next_in = const_cast<Bytef*>(src);
    z.avail_in = static_cast<uInt>(entry.compressed_size);
    z.next_out = out->data();
    z.avail_out = static_cast<uInt>(out->size());
    const int rc = inflate(&z, Z_FINISH);
    const uint64_t produced = z.total_out;
    inflateEnd(&z);
    if (rc != Z_STREAM_END || produced != entry.uncompressed_size) {
      return Status(StatusCode::kCorruptData, where + ": deflate stream is corrupt or does not give the declared " +
                                                  std::to_string(entry.uncompressed_size) + " bytes (zlib status " +
                                                  std::to_string(rc) + ", " + std::to_string(produced) + " bytes)");
    }
  } else {
    return Status(StatusCode::kUnsupportedFeature, where + " uses compression method " + std::to_string(entry.method) +
                                                       " (supported: 0 stored, 8 deflate)");
  }
  const uLong crc = crc32(crc32(0L, Z_NULL, 0), out->data(), static_cast<uInt>(out->size()));
  if (static_cast<uint32_t>(crc) != entry.crc32) {
    return Status(StatusCode::kChecksumMismatch, where + ": CRC-32 mismatch (stored " + std::to_string(entry.crc32) +
                                                     ", computed " + std::to_string(static_cast<uint32_t>(crc)) + ")");
  }
  return Status();
}

}  // namespace rgs::converter::detail
