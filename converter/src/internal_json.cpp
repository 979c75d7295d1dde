#include "internal_json.h"

#include <algorithm>

namespace rgs::converter::detail {

namespace {

/// The deepest nesting of '[' and '{' outside strings, stopping once it exceeds `limit`.
size_t nesting_depth(const uint8_t* data, size_t size, size_t limit) {
  size_t depth = 0, deepest = 0;
  bool in_string = false;
  for (size_t i = 0; i < size; ++i) {
    const uint8_t c = data[i];
    if (in_string) {
      if (c == '\\') {
        ++i;
      } else if (c == '"') {
        in_string = false;
      }
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) return deepest;
    } else if ((c == ']' || c == '}') && depth > 0) {
      --depth;
    }
  }
  return deepest;
}

}  // namespace

std::string bounded_text(const std::string& text, size_t max_bytes) {
  return text.size() <= max_bytes ? text : text.substr(0, max_bytes) + "...";
}

Result<nlohmann::json> parse_scene_json(const uint8_t* data, size_t size, const std::string& where) {
  if (nesting_depth(data, size, kMaxJsonDepth) > kMaxJsonDepth) {
    return Status(StatusCode::kCorruptData,
                  where + ": JSON nested deeper than " + std::to_string(kMaxJsonDepth) + " levels");
  }
  try {
    return nlohmann::json::parse(data, data + size);
  } catch (const nlohmann::json::exception& e) {
    return Status(StatusCode::kCorruptData, where + ": invalid JSON: " + bounded_text(e.what()));
  }
}

Result<nlohmann::json> parse_json_outline(const uint8_t* data, size_t size) {
  // nlohmann's parser keeps its own stack (no recursion); values below the top level's members are dropped
  // as they are parsed, so no deep document is ever built.
  const nlohmann::json::parser_callback_t shallow = [](int depth, nlohmann::json::parse_event_t, nlohmann::json&) {
    return depth <= 1;
  };
  try {
    return nlohmann::json::parse(data, data + size, shallow);
  } catch (const nlohmann::json::exception& e) {
    return Status(StatusCode::kCorruptData, "invalid JSON: " + bounded_text(e.what()));
  }
}

std::string describe_json_value(const nlohmann::json& value) {
  if (value.is_string()) {
    const std::string& s = value.get_ref<const std::string&>();
    return "'" + bounded_text(s, 64) + "'";
  }
  if (value.is_array()) return "an array of " + std::to_string(value.size()) + " values";
  if (value.is_object()) return "an object of " + std::to_string(value.size()) + " members";
  return value.dump();  // a number, boolean or null: short
}

}  // namespace rgs::converter::detail
