// Reading entries of a ZIP archive through libzip, and writing a stored one (the bundled .sog container;
// private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgs/format/status.h"

struct zip;

namespace rgs::converter::detail {

/// One file of the archive, from its central directory record.
struct ZipEntry {
  std::string name;  ///< as stored (no character-set conversion)
  uint64_t index = 0;
  uint16_t method = 0;  ///< 0 stored, 8 deflate
  bool encrypted = false;
  uint64_t compressed_size = 0;
  uint64_t uncompressed_size = 0;
};

/// A ZIP archive over caller-owned bytes (they must outlive it), read through libzip. Extracts what SOG writers
/// produce: stored and deflated entries, no encryption. Not for concurrent use.
class ZipArchive {
 public:
  /// Reads the end record and the central directory. Errors name `name`: kCorruptData (no or malformed
  /// directory), kUnsupportedFeature (multi-disk), kOutOfMemory.
  static Result<ZipArchive> open(const uint8_t* data, size_t size, const std::string& name);
  /// The entry names of the regular file `path`, reading only its end record and central directory (format
  /// detection). Errors as open(), and kIoError.
  static Result<std::vector<std::string>> list(const std::string& path);

  const std::vector<ZipEntry>& entries() const { return entries_; }
  /// The first entry named exactly `name`, or null.
  const ZipEntry* find(const std::string& name) const;

  /// Copies or inflates `entry` into `out` (CRC-32 checked). Sizes the archive's bytes cannot produce are
  /// refused before anything is allocated. Errors: kLimitExceeded (uncompressed size above max_bytes),
  /// kCorruptData (sizes, bad deflate stream), kChecksumMismatch (CRC-32), kUnsupportedFeature (another
  /// method, encryption).
  Status extract(const ZipEntry& entry, uint64_t max_bytes, std::vector<uint8_t>* out) const;

 private:
  std::shared_ptr<zip> zip_;
  size_t size_ = 0;
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
