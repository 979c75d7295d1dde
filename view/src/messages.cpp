// The server's messages of view/PROTOCOL.md: hello, error, and the binary frame message (its images encoded, its
// header's statistics).
#include "internal_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <utility>

#include "rgs/api/scene.h"
#include "rgs/api/camera.h"
#include "rgs/view/image_codec.h"

namespace rgs::view::detail {

namespace {

using nlohmann::json;

std::string dump(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

json nullable(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

}  // namespace

json camera_json(const InriaCamera& c) {
  json rotation = json::array();
  for (int r = 0; r < 3; ++r) {
    rotation.push_back({c.rotation_c2w[r * 3], c.rotation_c2w[r * 3 + 1], c.rotation_c2w[r * 3 + 2]});
  }
  return {{"width", c.width},
          {"height", c.height},
          {"position", {c.position[0], c.position[1], c.position[2]}},
          {"rotation", rotation},
          {"fx", c.fx},
          {"fy", c.fy}};
}

std::string build_hello(const ServerState& state, const std::string& device_name) {
  json scenes = json::array();
  static const char* const kNames[] = {"a", "b"};
  for (size_t i = 0; i < state.scenes.size(); ++i) {
    const api::SceneInfo& info = state.scenes[i].info();
    const format::SceneBounds sphere = info.content.sphere();
    scenes.push_back({{"name", kNames[i]},
                      {"path_basename", std::filesystem::path(info.path).filename().string()},
                      {"gaussians", info.gaussians},
                      {"sh_degree", info.sh_degree},
                      {"center", {sphere.sphere_center[0], sphere.sphere_center[1], sphere.sphere_center[2]}},
                      {"radius", sphere.sphere_radius},
                      {"lod", info.lod.active}});
  }
  json cameras = json::array();
  for (size_t i = 0; i < state.options.cameras.size(); ++i) {
    const api::NamedInriaCamera& camera = state.options.cameras[i];
    json entry = camera_json(camera.camera);
    entry["id"] = i;
    entry["img_name"] = camera.name;
    cameras.push_back(std::move(entry));
  }
  json presets = json::array();
  for (api::Preset p : state.limits.presets) presets.push_back(api::preset_name(p));
  const uint32_t width = state.options.default_width, height = state.options.default_height;
  json home;
  if (!state.options.cameras.empty()) {
    home = camera_json(state.options.cameras.front().camera);
  } else {
    api::CameraChoice choice;
    choice.orbit = 1;
    choice.orbit_width = width;
    choice.orbit_height = height;
    auto orbit = api::make_cameras(choice, state.scenes.front().info().content);
    if (orbit.ok() && !orbit->empty()) home = camera_json(inria_from_camera(orbit->front()));
  }
  const json hello = {{"type", "hello"},
                      {"version", kProtocolVersion},
                      {"backend", api::device_name(state.device)},
                      {"device", device_name},
                      {"scenes", scenes},
                      {"compare", state.scenes.size() == 2},
                      {"cameras", cameras},
                      {"home_camera", home},
                      {"presets", presets},
                      {"preset", api::preset_name(state.limits.default_preset)},
                      {"max_width", state.limits.max_width},
                      {"max_height", state.limits.max_height},
                      {"default_width", width},
                      {"default_height", height},
                      {"max_mbps", state.options.max_mbps},
                      {"encoder", state.jpeg_encoder}};
  return dump(hello);
}

std::string error_json(const std::string& code, const std::string& message, bool fatal) {
  return dump({{"type", "error"}, {"code", code}, {"message", message}, {"fatal", fatal}});
}

Result<std::vector<uint8_t>> encode_frame(RenderedFrame& frame, parallel::WorkerPool* workers) {
  const auto start = std::chrono::steady_clock::now();
  const ViewRequest& view = frame.view;
  std::vector<std::pair<const char*, std::vector<uint8_t>>> images;
  std::optional<ImageDifference> difference;
  const bool encoded_on_gpu = !frame.jpeg_a.empty();
  const auto add_image = [&](const char* role, const std::vector<uint8_t>& pixels, int channels) -> Status {
    RGS_ASSIGN_OR_RETURN(auto bytes, encode_rgb(pixels.data(), frame.width, frame.height, view.encoding,
                                                view.quality, channels, workers));
    images.emplace_back(role, std::move(bytes));
    return Status();
  };
  std::vector<uint8_t> heatmap;
  if (view.compare != CompareMode::kOff) {
    difference = compare_rgb(frame.rgba_a.data(), frame.rgba_b.data(), frame.width, frame.height, view.diff_scale,
                             view.compare == CompareMode::kDiff ? &heatmap : nullptr, 4);
  }
  if (encoded_on_gpu) {
    images.emplace_back("a", std::move(frame.jpeg_a));
  } else if (view.compare == CompareMode::kDiff) {
    RGS_RETURN_IF_ERROR(add_image("diff", heatmap, 3));
  } else {
    RGS_RETURN_IF_ERROR(add_image("a", frame.rgba_a, 4));
    if (view.compare == CompareMode::kSplit) RGS_RETURN_IF_ERROR(add_image("b", frame.rgba_b, 4));
  }
  const double encode_ms = encoded_on_gpu ? frame.gpu_encode_ms : ms_since(start);

  const api::FrameStats& s = frame.stats;
  const api::StageTimes& t = s.times;
  const auto timed = [&](float ms) { return t.timed ? json(ms) : json(nullptr); };
  json stats = {{"preprocess_ms", timed(t.preprocess_ms)},
                {"sort_ms", timed(t.sort_ms)},
                {"render_ms", timed(t.ranges_ms + t.render_ms)},
                {"total_gpu_ms", timed(t.total_ms)},
                {"render_call_ms", frame.render_call_ms},
                {"readback_ms", frame.readback_ms},
                {"encode_ms", encode_ms},
                {"pairs", s.pairs},
                {"splats", s.gaussians},
                {"gpu_memory_used_bytes", frame.gpu_memory_used ? json(*frame.gpu_memory_used) : json(nullptr)},
                {"gpu_memory_total_bytes", frame.gpu_memory_total ? json(*frame.gpu_memory_total) : json(nullptr)},
                {"lod_bytes_streamed", s.lod.bytes_streamed},
                {"lod_bytes_resident", s.lod.bytes_resident}};
  json image_list = json::array();
  for (const auto& [role, bytes] : images) {
    image_list.push_back({{"role", role}, {"encoding", encoded_name(view.encoding)}, {"bytes", bytes.size()}});
  }
  const json header = {
      {"type", "frame"},
      {"seq", view.seq},
      {"refine", frame.refine},
      {"width", frame.width},
      {"height", frame.height},
      {"preset", api::preset_name(view.preset)},
      {"quality", view.encoding == Encoding::kLossless ? json(nullptr) : json(view.quality)},
      {"scale", frame.rate.scale},
      {"max_mbps", frame.max_mbps > 0 ? json(frame.max_mbps) : json(nullptr)},
      {"images", image_list},
      {"stats", stats},
      {"psnr", difference ? nullable(difference->psnr_db) : json(nullptr)},
      {"mse", difference ? json(difference->mse) : json(nullptr)},
      {"diff_max", difference ? json(difference->max_abs) : json(nullptr)},
      {"diff_scale", difference ? json(view.diff_scale) : json(nullptr)}};
  const std::string text = dump(header);
  size_t total = 4 + text.size();
  for (const auto& image : images) total += image.second.size();
  std::vector<uint8_t> message;
  message.reserve(total);
  const uint32_t n = static_cast<uint32_t>(text.size());
  for (int i = 0; i < 4; ++i) message.push_back(static_cast<uint8_t>(n >> (8 * i)));
  message.insert(message.end(), text.begin(), text.end());
  for (const auto& image : images) message.insert(message.end(), image.second.begin(), image.second.end());
  return message;
}

}  // namespace rgs::view::detail
