// PLY header model and parser shared by the PLY reader (private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// Storage format named on the `format` line.
enum class PlyStorage : uint8_t { kAscii, kBinaryLittleEndian, kBinaryBigEndian };

/// Scalar property types of the PLY specification (with their int8..float64 aliases).
enum class PlyType : uint8_t { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

/// Size in bytes of one binary value of `type`.
constexpr size_t ply_type_size(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8: return 1;
    case PlyType::kInt16:
    case PlyType::kUint16: return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32: return 4;
    case PlyType::kFloat64: return 8;
  }
  return 0;
}

/// Parses a PLY type name ("float", "float32", "uchar", ...). Returns false for an unknown name.
bool parse_ply_type(const std::string& name, PlyType* type);

/// The PLY specification's name of `type` ("float", "uchar", ...).
const char* ply_type_name(PlyType type);

/// Name of the storage format as written on the `format` line ("binary_little_endian", ...).
const char* ply_storage_name(PlyStorage storage);

/// One `property` line. List properties keep their declared type strings only (they are never decoded).
struct PlyProperty {
  std::string name;
  std::string type_name;      ///< as written (scalar type, or the item type of a list)
  bool known_type = false;    ///< type_name (and for lists the count type) parsed
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  size_t offset = 0;          ///< byte offset in a binary row (scalar properties before any list)
  size_t header_line = 0;     ///< 1-based header line number, for messages
};

/// One `element` line and its properties.
struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
  size_t header_line = 0;
};

/// The parsed header. The vertex element's binary row layout is not validated here (see the reader).
struct PlyHeader {
  PlyStorage storage = PlyStorage::kBinaryLittleEndian;
  std::vector<PlyElement> elements;
  /// Byte offset of the first data byte (just after the `end_header` line's newline).
  size_t data_offset = 0;
  /// Number of header lines (the `end_header` line included); ascii data starts on line header_lines+1.
  size_t header_lines = 0;
};

/// The SH degree (0..3) of a vertex with `rest_count` f_rest_* properties (0, 9, 24 or 45); false otherwise.
inline bool sh_degree_of_rest_count(size_t rest_count, uint32_t* degree) {
  for (uint32_t d = 0; d <= 3; ++d) {
    if (rest_count == 3 * (size_t{d + 1} * (d + 1) - 1)) {
      *degree = d;
      return true;
    }
  }
  return false;
}

/// Upper bound on the header size: a header longer than this is rejected (kCorruptData) so a file
/// without `end_header` cannot make the reader buffer it whole.
constexpr size_t kMaxPlyHeaderBytes = size_t{1} << 20;

/// True when `data` begins with the line "ply" (LF or CRLF); needs at least 5 bytes to say no.
bool starts_with_ply_magic(const uint8_t* data, size_t size);

/// Byte offset just past the `end_header` line in `data[0, size)`, or 0 when the line is not there (yet).
size_t find_ply_header_end(const uint8_t* data, size_t size);

/// Parses the header text `data[0, header_end)` (header_end from find_ply_header_end).
/// Checks the structure only: `ply` first, one `format <storage> 1.0` before any element, `element`
/// and `property` syntax, counts as unsigned 64-bit integers, no duplicate property names within an
/// element. Type names are recorded; unknown ones are reported by the reader only for the elements it
/// decodes. Errors: kCorruptData naming the header line; kUnsupportedFeature for a version other than 1.0.
Status parse_ply_header(const uint8_t* data, size_t header_end, PlyHeader* out);

}  // namespace rgs::converter::detail
