// Fuzz target: a client message of the rgs-view protocol (view::parse_client_message, view/PROTOCOL.md), the text
// a browser sends over the WebSocket. Input: 1 byte of limits (bit 0: a second scene, compare modes allowed; bit
// 1: only the fastest preset offered; bit 2: frames up to 1920 x 1080), then the message text.
// Any input must give ok or an error Status; an accepted view must be within the limits, give a camera the front
// door accepts, and parse back to itself from view_message_json.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "fuzz_check.h"
#include "rgs/view/protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  rgs::view::ProtocolLimits limits;
  limits.compare_available = (data[0] & 1) != 0;
  if (data[0] & 2) limits.presets = {rgs::api::Preset::kFastest};
  if (data[0] & 4) {
    limits.max_width = 1920;
    limits.max_height = 1080;
  }
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  auto message = rgs::view::parse_client_message(text, limits);
  if (!message.ok() || message->type != rgs::view::ClientMessage::Type::kView) return 0;
  const rgs::view::ViewRequest& view = message->view;
  RGS_FUZZ_CHECK(view.camera.width >= 1 && view.camera.width <= limits.max_width, "width out of range");
  RGS_FUZZ_CHECK(view.camera.height >= 1 && view.camera.height <= limits.max_height, "height out of range");
  RGS_FUZZ_CHECK(view.quality >= 1 && view.quality <= 100, "quality out of range");
  RGS_FUZZ_CHECK(limits.compare_available || view.compare == rgs::view::CompareMode::kOff, "compare without b");
  for (float c : view.background) RGS_FUZZ_CHECK(c >= 0.f && c <= 1.f, "background out of range");
  auto camera = rgs::view::camera_from_request(view.camera);
  RGS_FUZZ_CHECK(camera.ok(), camera.status().to_string());
  auto again = rgs::view::parse_client_message(rgs::view::view_message_json(view), limits);
  RGS_FUZZ_CHECK(again.ok(), again.status().to_string());
  RGS_FUZZ_CHECK(again->view.seq == view.seq && again->view.camera.width == view.camera.width &&
                     again->view.preset == view.preset && again->view.encoding == view.encoding,
                 "view_message_json does not parse back to the same view");
  return 0;
}
