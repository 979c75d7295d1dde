// The rgs-view protocol's client messages: parsing and validation of what a page sends (view/PROTOCOL.md), and
// writing them (for clients such as benchmarks). Everything a client sends is untrusted: parse_client_message
// accepts only messages within ProtocolLimits and never throws.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/api/preset.h"
#include "rgs/format/status.h"

namespace rgs::view {

/// The protocol version the hello message announces (view/PROTOCOL.md).
inline constexpr int kProtocolVersion = 1;

/// How a frame's images are encoded (PROTOCOL.md "view": `encoding`).
enum class Encoding {
  kJpeg = 0,      ///< libturbojpeg, lossy; 4:2:0 chroma below quality 90, 4:4:4 from 90
  kWebp = 1,      ///< libwebp, lossy
  kLossless = 2,  ///< libwebp lossless: decodes to exactly the 8-bit RGB that was encoded
};

/// "jpeg", "webp", "lossless" (the request's names); encoded_name gives the frame header's ("jpeg", "webp",
/// "webp-lossless").
const char* encoding_name(Encoding encoding);
const char* encoded_name(Encoding encoding);

/// What a frame shows when the server has two scenes (PROTOCOL.md "view": `compare`).
enum class CompareMode {
  kOff = 0,    ///< images: a
  kSplit = 1,  ///< images: a, b (the page draws the split)
  kDiff = 2,   ///< images: diff (heatmap of |a − b|)
};

/// "off", "split", "diff".
const char* compare_mode_name(CompareMode mode);

/// A view's camera, in the INRIA 3DGS cameras.json convention (api::InriaCamera): `rotation_c2w` camera-to-world,
/// row-major [3, 3], `position` the camera centre, fx, fy in pixels for width × height, principal point at the
/// image centre.
using api::InriaCamera;

/// The INRIA form of `camera` (rotation_c2w = Rᵀ, position = −Rᵀ·t); cx, cy are not kept (the convention puts
/// the principal point at the image centre).
InriaCamera inria_from_camera(const api::Camera& camera);

/// A "view" message: what the client wants rendered next.
struct ViewRequest {
  uint64_t seq = 0;  ///< 0 ≤ seq < 2^53, echoed in the frame
  InriaCamera camera;
  api::Preset preset = api::Preset::kFastest;
  std::array<float, 3> background = {0.f, 0.f, 0.f};  ///< linear RGB in [0, 1]
  Encoding encoding = Encoding::kJpeg;
  int quality = 85;  ///< 1..100 (jpeg, webp)
  CompareMode compare = CompareMode::kOff;
  float diff_scale = 32.f;  ///< [1, 255]: |a − b| in 8-bit levels at the top of the heatmap's colour map
  /// The camera has stopped: rendered at full size and quality whatever the bandwidth budget.
  bool still = false;
  /// The client's bandwidth budget, Mbit/s in [0, kMaxMbps]; 0: none (PROTOCOL.md "Bandwidth budget").
  double max_mbps = 0;
};

/// The largest bandwidth budget a view or the server may name, Mbit/s.
inline constexpr double kMaxMbps = 100000;

/// One parsed client message.
struct ClientMessage {
  enum class Type { kView, kPing };
  Type type = Type::kPing;
  ViewRequest view;  ///< kView only
};

/// What a message may contain; the server's values are in its hello message.
struct ProtocolLimits {
  size_t max_message_bytes = 64 * 1024;  ///< larger messages are refused (kLimitExceeded)
  uint32_t max_width = 7680, max_height = 4320;
  /// The presets a view may name (hello's "presets"); empty: all three.
  std::vector<api::Preset> presets;
  /// The preset of a view that names none.
  api::Preset default_preset = api::Preset::kFastest;
  /// Whether compare modes other than "off" are allowed (the server has a second scene).
  bool compare_available = false;
};

/// Parses and validates one text message (PROTOCOL.md): a JSON object of "type" "view" or "ping". A view's
/// camera: a cameras.json entry's checks (api::parse_inria_camera: every number finite, rotation a proper rotation,
/// fx, fy in (0, 1e6], position components within ±1e9), width 1..max_width and height 1..max_height (JSON
/// integers); background three numbers in [0, 1]; quality an integer 1..100; diff_scale
/// in [1, 255]; still a boolean; max_mbps in [0, kMaxMbps]; preset among `limits.presets`; compare
/// "split"/"diff" only with compare_available. Unknown keys are ignored. Never throws; nesting deeper than 8
/// levels is refused before parsing.
/// @return kLimitExceeded (over max_message_bytes, or nested too deep), kInvalidArgument (malformed JSON, a
/// missing key, a wrong type, a value out of range; the message names the key).
Result<ClientMessage> parse_client_message(std::string_view text, const ProtocolLimits& limits);

/// The api::Camera a validated view renders with (api::camera_from_inria, default near plane).
/// @return kInvalidArgument (what camera_from_inria refuses).
Result<api::Camera> camera_from_request(const InriaCamera& camera);

/// The JSON text of `view` as a client sends it (the inverse of parse_client_message for valid views).
std::string view_message_json(const ViewRequest& view);

}  // namespace rgs::view
