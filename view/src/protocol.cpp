// Client messages of the rgs-view protocol (view/PROTOCOL.md): parsing, validation and writing.
#include "rgs/view/protocol.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "internal_pipeline.h"

namespace rgs::view {

namespace {

using nlohmann::json;

constexpr int kMaxNesting = 8;
constexpr double kMaxSeq = 9007199254740992.0;  // 2^53

Status bad(const std::string& what) { return Status(StatusCode::kInvalidArgument, "view message: " + what); }

// Deepest nesting of objects and arrays, outside strings; stops counting past `limit`.
int nesting_depth(std::string_view text, int limit) {
  int depth = 0, deepest = 0;
  bool in_string = false, escaped = false;
  for (char c : text) {
    if (in_string) {
      if (escaped) escaped = false;
      else if (c == '\\') escaped = true;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') in_string = true;
    else if (c == '[' || c == '{') {
      deepest = std::max(deepest, ++depth);
      if (deepest > limit) return deepest;
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return deepest;
}

Status read_number(const json& object, const char* key, double* out) {
  const auto it = object.find(key);
  if (it == object.end()) return bad(std::string("missing \"") + key + "\"");
  if (!it->is_number()) return bad(std::string("\"") + key + "\" is not a number");
  *out = it->get<double>();
  if (!std::isfinite(*out)) return bad(std::string("\"") + key + "\" is not finite");
  return Status();
}

Status read_camera(const json& value, const ProtocolLimits& limits, InriaCamera* camera) {
  if (!value.is_object()) return bad("\"camera\" is not an object");
  // The cameras.json reader's checks (runtime::parse_inria_camera), within this server's frame size.
  auto parsed = api::parse_inria_camera(value.dump(), limits.max_width, limits.max_height, "camera.");
  if (!parsed.ok()) return bad(parsed.status().message());
  *camera = *parsed;
  return Status();
}

Status read_string(const json& object, const char* key, std::string* out) {
  const auto it = object.find(key);
  if (it == object.end()) return Status();
  if (!it->is_string()) return bad(std::string("\"") + key + "\" is not a string");
  *out = it->get<std::string>();
  return Status();
}

Status read_view(const json& message, const ProtocolLimits& limits, ViewRequest* view) {
  double seq = 0;
  RGS_RETURN_IF_ERROR(read_number(message, "seq", &seq));
  if (seq < 0 || seq >= kMaxSeq || seq != std::floor(seq)) return bad("\"seq\" must be an integer in [0, 2^53)");
  view->seq = static_cast<uint64_t>(seq);
  const auto camera = message.find("camera");
  if (camera == message.end()) return bad("missing \"camera\"");
  RGS_RETURN_IF_ERROR(read_camera(*camera, limits, &view->camera));

  std::string preset;
  RGS_RETURN_IF_ERROR(read_string(message, "preset", &preset));
  view->preset = limits.default_preset;
  if (!preset.empty()) {
    auto parsed = api::parse_preset(preset);
    if (!parsed.ok()) return bad("\"preset\": " + parsed.status().message());
    view->preset = *parsed;
  }
  if (!limits.presets.empty() &&
      std::find(limits.presets.begin(), limits.presets.end(), view->preset) == limits.presets.end()) {
    return bad(std::string("\"preset\" ") + api::preset_name(view->preset) + " is not offered by this server");
  }
  if (const auto background = message.find("background"); background != message.end()) {
    if (!background->is_array() || background->size() != 3) return bad("\"background\" is not 3 numbers");
    for (size_t c = 0; c < 3; ++c) {
      const json& value = (*background)[c];
      if (!value.is_number() || !(value.get<double>() >= 0 && value.get<double>() <= 1)) {
        return bad("\"background\" values must be numbers in [0, 1]");
      }
      view->background[c] = value.get<float>();
    }
  }
  std::string encoding;
  RGS_RETURN_IF_ERROR(read_string(message, "encoding", &encoding));
  if (encoding.empty() || encoding == "jpeg") view->encoding = Encoding::kJpeg;
  else if (encoding == "webp") view->encoding = Encoding::kWebp;
  else if (encoding == "lossless") view->encoding = Encoding::kLossless;
  else return bad("\"encoding\" must be \"jpeg\", \"webp\" or \"lossless\"");
  if (message.contains("quality")) {
    double quality = 0;
    RGS_RETURN_IF_ERROR(read_number(message, "quality", &quality));
    if (quality != std::floor(quality) || quality < 1 || quality > 100) {
      return bad("\"quality\" must be an integer in 1..100");
    }
    view->quality = static_cast<int>(quality);
  }
  std::string compare;
  RGS_RETURN_IF_ERROR(read_string(message, "compare", &compare));
  if (compare.empty() || compare == "off") view->compare = CompareMode::kOff;
  else if (compare == "split") view->compare = CompareMode::kSplit;
  else if (compare == "diff") view->compare = CompareMode::kDiff;
  else return bad("\"compare\" must be \"off\", \"split\" or \"diff\"");
  if (view->compare != CompareMode::kOff && !limits.compare_available) {
    return bad("\"compare\" " + compare + " needs a second scene (rgs-view SCENE SCENE2)");
  }
  if (message.contains("diff_scale")) {
    double scale = 0;
    RGS_RETURN_IF_ERROR(read_number(message, "diff_scale", &scale));
    if (scale < 1 || scale > 255) return bad("\"diff_scale\" must be in [1, 255]");
    view->diff_scale = static_cast<float>(scale);
  }
  if (const auto still = message.find("still"); still != message.end()) {
    if (!still->is_boolean()) return bad("\"still\" is not a boolean");
    view->still = still->get<bool>();
  }
  if (message.contains("max_mbps") && !message["max_mbps"].is_null()) {  // null: none, as a frame's header says
    RGS_RETURN_IF_ERROR(read_number(message, "max_mbps", &view->max_mbps));
    if (view->max_mbps < 0 || view->max_mbps > kMaxMbps) return bad("\"max_mbps\" must be in [0, 100000]");
  }
  return Status();
}

}  // namespace

const char* encoding_name(Encoding encoding) {
  switch (encoding) {
    case Encoding::kJpeg: return "jpeg";
    case Encoding::kWebp: return "webp";
    case Encoding::kLossless: return "lossless";
  }
  return "jpeg";
}

const char* encoded_name(Encoding encoding) {
  return encoding == Encoding::kLossless ? "webp-lossless" : encoding_name(encoding);
}

const char* compare_mode_name(CompareMode mode) {
  switch (mode) {
    case CompareMode::kOff: return "off";
    case CompareMode::kSplit: return "split";
    case CompareMode::kDiff: return "diff";
  }
  return "off";
}

InriaCamera inria_from_camera(const api::Camera& camera) {
  InriaCamera out;
  const auto& R = camera.rotation;
  const auto& t = camera.translation;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) out.rotation_c2w[r * 3 + c] = R[c * 3 + r];
  }
  for (int r = 0; r < 3; ++r) {
    double s = 0;
    for (int k = 0; k < 3; ++k) s += double(R[k * 3 + r]) * t[k];
    out.position[r] = -s;
  }
  out.fx = camera.fx;
  out.fy = camera.fy;
  out.width = camera.width;
  out.height = camera.height;
  return out;
}

Result<api::Camera> camera_from_request(const InriaCamera& camera) {
  return api::camera_from_inria(camera.rotation_c2w, camera.position, camera.fx, camera.fy, camera.width,
                                camera.height);
}

Result<ClientMessage> parse_client_message(std::string_view text, const ProtocolLimits& limits) {
  RGS_RETURN_ERROR_IF(text.size() > limits.max_message_bytes, StatusCode::kLimitExceeded,
                      "message of " + std::to_string(text.size()) + " bytes exceeds the limit of " +
                          std::to_string(limits.max_message_bytes));
  RGS_RETURN_ERROR_IF(nesting_depth(text, kMaxNesting) > kMaxNesting, StatusCode::kLimitExceeded,
                      "message nests arrays or objects deeper than " + std::to_string(kMaxNesting) + " levels");
  const json message = json::parse(text.begin(), text.end(), nullptr, /*allow_exceptions=*/false);
  if (message.is_discarded()) return bad("not valid JSON");
  if (!message.is_object()) return bad("not a JSON object");
  std::string type;
  RGS_RETURN_IF_ERROR(read_string(message, "type", &type));
  ClientMessage out;
  if (type == "ping") {
    out.type = ClientMessage::Type::kPing;
    return out;
  }
  if (type != "view") return bad(type.empty() ? std::string("missing \"type\"") : "unknown type \"" + type + "\"");
  out.type = ClientMessage::Type::kView;
  RGS_RETURN_IF_ERROR(read_view(message, limits, &out.view));
  return out;
}

std::string view_message_json(const ViewRequest& view) {
  json message = {
      {"type", "view"},
      {"seq", view.seq},
      {"camera", detail::camera_json(view.camera)},
      {"preset", api::preset_name(view.preset)},
      {"background", {view.background[0], view.background[1], view.background[2]}},
      {"encoding", encoding_name(view.encoding)},
      {"quality", view.quality},
      {"compare", compare_mode_name(view.compare)},
      {"diff_scale", view.diff_scale},
      {"still", view.still}};
  if (view.max_mbps > 0) message["max_mbps"] = view.max_mbps;
  return message.dump();
}

}  // namespace rgs::view
