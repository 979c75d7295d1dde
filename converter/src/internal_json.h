// The JSON files of scenes (SOG meta.json, streamed SOG lod-meta.json, glTF): parsed with a bounded nesting
// depth, and described in messages without echoing unbounded input (private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// Deepest nesting of arrays and objects accepted in a scene's JSON (real files nest fewer than 10 levels;
/// the bound keeps every later walk and message of the document shallow).
inline constexpr size_t kMaxJsonDepth = 64;

/// Parses `size` bytes as one JSON value. Nesting is checked on the raw bytes first, so a hostile document
/// costs one pass over its bytes before it is refused.
/// Errors: kCorruptData naming `where`: "JSON nested deeper than 64 levels", or "invalid JSON: <parser's
/// message, at most 160 bytes>".
Result<nlohmann::json> parse_scene_json(const uint8_t* data, size_t size, const std::string& where);

/// A JSON value for a message, never longer than about 100 bytes: a string quoted (its first 64 bytes),
/// a number, boolean or null as written, "an array of N values", "an object of N members".
std::string describe_json_value(const nlohmann::json& value);

/// `text` cut to at most `max_bytes` bytes, with "..." when cut (for library messages that embed input).
std::string bounded_text(const std::string& text, size_t max_bytes = 160);

}  // namespace rgs::converter::detail
