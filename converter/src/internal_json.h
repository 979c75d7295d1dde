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

/// The outline of a JSON document that parse_scene_json refuses for its nesting alone: the top level with each
/// member's container emptied (`{"tree": [[[...]]]}` gives `{"tree": []}`), built without the deep values, so that
/// format detection still recognises a scene's JSON by its keys and hands it to the reader that names the problem.
/// Errors: kCorruptData when the bytes are not JSON at all.
Result<nlohmann::json> parse_json_outline(const uint8_t* data, size_t size);

/// A JSON value for a message, never longer than about 100 bytes: a string quoted (its first 64 bytes),
/// a number, boolean or null as written, "an array of N values", "an object of N members".
std::string describe_json_value(const nlohmann::json& value);

/// `text` cut to at most `max_bytes` bytes, with "..." when cut (for library messages that embed input).
std::string bounded_text(const std::string& text, size_t max_bytes = 160);

}  // namespace rgs::converter::detail
