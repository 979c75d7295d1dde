// PLY header parsing: line based, bounds checked, LF or CRLF line ends.
#include <charconv>
#include <cstring>
#include <string_view>
#include <unordered_set>

#include "../internal_interop.h"
#include "internal_ply_header.h"
#include "rgs/converter/ply_reader.h"

namespace rgs::converter::detail {

namespace {

/// Splits a header line into whitespace-separated tokens (spaces and tabs).
std::vector<std::string_view> split_tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

/// Header text with non-printable bytes escaped, truncated, for messages.
std::string quote(std::string_view text) {
  std::string out = "'";
  for (size_t i = 0; i < text.size() && i < 64; ++i) {
    const unsigned char ch = static_cast<unsigned char>(text[i]);
    if (ch >= 0x20 && ch < 0x7f) {
      out.push_back(static_cast<char>(ch));
    } else {
      static const char kHex[] = "0123456789abcdef";
      out += "\\x";
      out.push_back(kHex[ch >> 4]);
      out.push_back(kHex[ch & 15]);
    }
  }
  if (text.size() > 64) out += "...";
  return out + "'";
}

Status header_error(size_t line, const std::string& what) {
  return Status(StatusCode::kCorruptData, "PLY header line " + std::to_string(line) + ": " + what);
}

/// Every PLY type name, the first of each type its canonical name (ply_type_name).
struct PlyTypeName {
  const char* name;
  PlyType type;
};
constexpr PlyTypeName kPlyTypes[] = {
    {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
    {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
    {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
    {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
    {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
    {"float64", PlyType::kFloat64},
};

}  // namespace

bool parse_ply_type(const std::string& name, PlyType* type) {
  for (const PlyTypeName& e : kPlyTypes) {
    if (name == e.name) {
      *type = e.type;
      return true;
    }
  }
  return false;
}

const char* ply_type_name(PlyType type) {
  for (const PlyTypeName& e : kPlyTypes) {
    if (type == e.type) return e.name;
  }
  return "?";
}

const char* ply_storage_name(PlyStorage storage) {
  switch (storage) {
    case PlyStorage::kAscii: return "ascii";
    case PlyStorage::kBinaryLittleEndian: return "binary_little_endian";
    case PlyStorage::kBinaryBigEndian: return "binary_big_endian";
  }
  return "unknown";
}

bool starts_with_ply_magic(const uint8_t* data, size_t size) {
  if (size >= 4 && std::memcmp(data, "ply\n", 4) == 0) return true;
  return size >= 5 && std::memcmp(data, "ply\r\n", 5) == 0;
}

size_t find_ply_header_end(const uint8_t* data, size_t size) {
  static constexpr char kEnd[] = "end_header";
  constexpr size_t kEndLen = sizeof(kEnd) - 1;
  size_t line_start = 0;
  while (line_start < size) {
    const void* nl = std::memchr(data + line_start, '\n', size - line_start);
    if (nl == nullptr) return 0;
    const size_t line_end = static_cast<size_t>(static_cast<const uint8_t*>(nl) - data);
    size_t len = line_end - line_start;
    if (len > 0 && data[line_start + len - 1] == '\r') --len;
    // Trailing spaces after end_header are tolerated (some writers emit them).
    while (len > kEndLen && (data[line_start + len - 1] == ' ' || data[line_start + len - 1] == '\t')) --len;
    if (len == kEndLen && std::memcmp(data + line_start, kEnd, kEndLen) == 0) return line_end + 1;
    line_start = line_end + 1;
  }
  return 0;
}

Status parse_ply_header(const uint8_t* data, size_t header_end, PlyHeader* out) {
  *out = PlyHeader();
  const std::string_view text(reinterpret_cast<const char*>(data), header_end);
  bool have_format = false;
  bool done = false;
  size_t line_no = 0;
  size_t pos = 0;
  std::unordered_set<std::string> property_names;  // of the current element
  while (pos < text.size() && !done) {
    size_t nl = text.find('\n', pos);
    if (nl == std::string_view::npos) nl = text.size();
    std::string_view line = text.substr(pos, nl - pos);
    pos = nl + 1;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line_no == 1) {
      if (line != "ply") return Status(StatusCode::kCorruptData, "not a PLY file (first line is not 'ply')");
      continue;
    }
    const std::vector<std::string_view> tok = split_tokens(line);
    if (tok.empty()) continue;  // blank lines carry nothing; tolerated
    const std::string_view key = tok[0];
    if (key == "comment" || key == "obj_info") continue;
    if (key == "format") {
      if (have_format) return header_error(line_no, "second 'format' line");
      if (tok.size() != 3) return header_error(line_no, "expected 'format <storage> 1.0', got " + quote(line));
      if (tok[1] == "ascii") {
        out->storage = PlyStorage::kAscii;
      } else if (tok[1] == "binary_little_endian") {
        out->storage = PlyStorage::kBinaryLittleEndian;
      } else if (tok[1] == "binary_big_endian") {
        out->storage = PlyStorage::kBinaryBigEndian;
      } else {
        return header_error(line_no, "unknown storage format " + quote(tok[1]) +
                                         " (expected ascii, binary_little_endian or binary_big_endian)");
      }
      if (tok[2] != "1.0" && tok[2] != "1") {
        return Status(StatusCode::kUnsupportedFeature, "PLY header line " + std::to_string(line_no) +
                                                           ": PLY version " + quote(tok[2]) +
                                                           " (only 1.0 is supported)");
      }
      have_format = true;
      continue;
    }
    if (key == "element") {
      if (!have_format) return header_error(line_no, "'element' before the 'format' line (missing format?)");
      if (tok.size() != 3) return header_error(line_no, "expected 'element <name> <count>', got " + quote(line));
      PlyElement element;
      element.name = std::string(tok[1]);
      element.header_line = line_no;
      const char* first = tok[2].data();
      const char* last = first + tok[2].size();
      auto [ptr, ec] = std::from_chars(first, last, element.count);
      if (ec != std::errc() || ptr != last) {
        return header_error(line_no, "element " + quote(tok[1]) + " count " + quote(tok[2]) +
                                         " is not an unsigned 64-bit integer");
      }
      out->elements.push_back(std::move(element));
      property_names.clear();
      continue;
    }
    if (key == "property") {
      if (out->elements.empty()) return header_error(line_no, "'property' before any 'element'");
      PlyElement& element = out->elements.back();
      PlyProperty prop;
      prop.header_line = line_no;
      if (tok.size() >= 2 && tok[1] == "list") {
        if (tok.size() != 5) {
          return header_error(line_no, "expected 'property list <count type> <item type> <name>', got " +
                                           quote(line));
        }
        prop.is_list = true;
        prop.type_name = std::string(tok[3]);
        PlyType count_type;
        prop.known_type = parse_ply_type(std::string(tok[2]), &count_type) && parse_ply_type(prop.type_name, &prop.type);
        prop.name = std::string(tok[4]);
      } else {
        if (tok.size() != 3) return header_error(line_no, "expected 'property <type> <name>', got " + quote(line));
        prop.type_name = std::string(tok[1]);
        prop.known_type = parse_ply_type(prop.type_name, &prop.type);
        prop.name = std::string(tok[2]);
      }
      if (!property_names.insert(prop.name).second) {
        return header_error(line_no, "duplicate property " + quote(prop.name) + " in element " + quote(element.name));
      }
      element.properties.push_back(std::move(prop));
      continue;
    }
    if (key == "end_header") {
      if (tok.size() != 1) return header_error(line_no, "unexpected text after 'end_header'");
      done = true;
      continue;
    }
    return header_error(line_no, "unknown keyword " + quote(key));
  }
  if (!done) return Status(StatusCode::kCorruptData, "PLY header has no 'end_header' line");
  if (!have_format) return Status(StatusCode::kCorruptData, "PLY header has no 'format' line");
  out->data_offset = header_end;
  out->header_lines = line_no;
  return Status();
}

}  // namespace rgs::converter::detail

namespace rgs::converter {

Result<uint64_t> ply_stream_bytes(const uint8_t* data, size_t size, uint64_t max_gaussians) {
  if (size >= 5 && !detail::starts_with_ply_magic(data, size)) {
    return Status(StatusCode::kCorruptData, "not a PLY file (no 'ply' line first)");
  }
  const size_t end = detail::find_ply_header_end(data, size);
  if (end == 0) {
    RGS_RETURN_ERROR_IF(size >= detail::kMaxPlyHeaderBytes, StatusCode::kCorruptData,
                        "no end_header line in the first " + std::to_string(detail::kMaxPlyHeaderBytes) + " bytes");
    return uint64_t{0};
  }
  detail::PlyHeader header;
  RGS_RETURN_IF_ERROR(detail::parse_ply_header(data, end, &header));
  constexpr uint64_t kValueBound = 64, kListRowBound = uint64_t{64} << 10;
  uint64_t total = header.data_offset;
  for (const detail::PlyElement& e : header.elements) {
    if (e.name == "vertex") {
      RGS_RETURN_IF_ERROR(detail::check_limit("PLY declares ", e.count, "vertices", max_gaussians,
                                              " (refused from its header, before its data is read)"));
    }
    uint64_t row = 0;
    for (const detail::PlyProperty& p : e.properties) {
      const bool exact = header.storage != detail::PlyStorage::kAscii && !p.is_list && p.known_type;
      row += p.is_list ? kListRowBound : exact ? detail::ply_type_size(p.type) : kValueBound;
    }
    // Saturates: a count no stream can hold is refused by the reader with its own message.
    total = e.count != 0 && row > (UINT64_MAX - total) / e.count ? UINT64_MAX : total + e.count * row;
  }
  return total;
}

}  // namespace rgs::converter
