// Reading entries of a ZIP archive held in memory, and writing a stored one (the bundled .sog container;
// private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// One file of the archive, from its central directory record.
struct ZipEntry {
  std::string name;
  uint16_t method = 0;  ///< 0 stored, 8 deflate
  uint32_t crc32 = 0;
  uint64_t compressed_size = 0;
  uint64_t uncompressed_size = 0;
  uint64_t local_header_offset = 0;
};

/// A ZIP archive over caller-owned bytes (they must outlive it). Supports what SOG writers produce: stored
/// and deflated entries, data descriptors, no ZIP64, no encryption, one disk.
class ZipArchive {
 public:
  /// Parses the end-of-central-directory record and the central directory, checking every offset and size
  /// against `size`. Errors name `name`: kCorruptData (no or malformed directory, offsets outside the
  /// archive), kUnsupportedFeature (ZIP64, multi-disk, encrypted entries).
  /// `data` may also be only the end of the file, from byte `base_offset` on (detection reads a tail): the
  /// entries are then listed, but extract() needs the whole file (base_offset 0).
  static Result<ZipArchive> parse(const uint8_t* data, size_t size, const std::string& name, uint64_t base_offset = 0);

  const std::vector<ZipEntry>& entries() const { return entries_; }
  /// The entry named exactly `name`, or null.
  const ZipEntry* find(const std::string& name) const;

  /// Copies (stored) or inflates (deflate, through zlib) `entry` into `out` and checks its CRC-32.
  /// Errors: kLimitExceeded (uncompressed size above max_bytes), kCorruptData (local header or size
  /// mismatch, bad deflate stream), kChecksumMismatch (CRC-32), kUnsupportedFeature (another method).
  Status extract(const ZipEntry& entry, uint64_t max_bytes, std::vector<uint8_t>* out) const;

 private:
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  uint64_t base_offset_ = 0;
  std::string name_;
  std::vector<ZipEntry> entries_;
};

/// True when `data` starts with a ZIP local file header or an empty archive's end record ("PK\3\4"/"PK\5\6").
bool has_zip_magic(const uint8_t* data, size_t size);

/// One file to archive by write_stored_zip.
struct ZipSource {
  std::string name;
  const std::vector<uint8_t>* bytes = nullptr;
};

/// A ZIP archive of `sources` in order, every entry stored (method 0: the SOG images are WebP already), with
/// a zero timestamp so the same files give the same bytes. No ZIP64: the caller keeps every size, offset and
/// the entry count below 2^32 − 1 and 65,535 (assert).
std::vector<uint8_t> write_stored_zip(const std::vector<ZipSource>& sources);

}  // namespace rgs::converter::detail
