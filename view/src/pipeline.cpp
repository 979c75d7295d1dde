// A client's frame pipeline: render (api::Renderer, one per client thread), read back, encode, hand over; and the
// server's JSON messages (hello, frame header, error) of view/PROTOCOL.md.
#include "internal_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "rgs/api/scene.h"
#include "rgs/api/camera.h"
#include "rgs/view/image_codec.h"

namespace rgs::view::detail {

namespace {

using nlohmann::json;

// Views of a level-of-detail scene rendered again while levels are still arriving (PROTOCOL.md "Refinement").
constexpr int kMaxRefinements = 8;

std::string dump(const json& value) { return value.dump(-1, ' ', false, json::error_handler_t::replace); }

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

double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

json nullable(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

}  // namespace

std::string build_hello(const ServerState& state, const std::string& device_name) {
  json scenes = json::array();
  static const char* const kNames[] = {"a", "b"};
  for (size_t i = 0; i < state.scenes.size(); ++i) {
    const api::SceneInfo& info = state.scenes[i].info();
    const auto& sphere = info.bounds;
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
    auto orbit = api::make_cameras(choice, state.scenes.front().info().bounds);
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
                      {"default_height", height}};
  return dump(hello);
}

std::string error_json(const std::string& code, const std::string& message, bool fatal) {
  return dump({{"type", "error"}, {"code", code}, {"message", message}, {"fatal", fatal}});
}

Result<std::vector<uint8_t>> encode_frame(const RenderedFrame& frame) {
  const auto start = std::chrono::steady_clock::now();
  const ViewRequest& view = frame.view;
  std::vector<std::pair<const char*, std::vector<uint8_t>>> images;
  std::optional<ImageDifference> difference;
  if (view.compare == CompareMode::kOff) {
    RGS_ASSIGN_OR_RETURN(auto a, encode_rgb(frame.rgba_a.data(), frame.width, frame.height, view.encoding,
                                            view.quality, 4));
    images.emplace_back("a", std::move(a));
  } else if (view.compare == CompareMode::kSplit) {
    difference = compare_rgb(frame.rgba_a.data(), frame.rgba_b.data(), frame.width, frame.height, view.diff_scale,
                             nullptr, 4);
    RGS_ASSIGN_OR_RETURN(auto a, encode_rgb(frame.rgba_a.data(), frame.width, frame.height, view.encoding,
                                            view.quality, 4));
    RGS_ASSIGN_OR_RETURN(auto b, encode_rgb(frame.rgba_b.data(), frame.width, frame.height, view.encoding,
                                            view.quality, 4));
    images.emplace_back("a", std::move(a));
    images.emplace_back("b", std::move(b));
  } else {
    std::vector<uint8_t> heatmap;
    difference = compare_rgb(frame.rgba_a.data(), frame.rgba_b.data(), frame.width, frame.height, view.diff_scale,
                             &heatmap, 4);
    RGS_ASSIGN_OR_RETURN(auto d, encode_rgb(heatmap.data(), frame.width, frame.height, view.encoding, view.quality));
    images.emplace_back("diff", std::move(d));
  }
  const double encode_ms = ms_since(start);

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

// ---------------------------------------------------------------------------------------------------------

FramePipeline::FramePipeline(const ServerState& state, SendBinary send_frame, SendText send_text)
    : state_(state), send_frame_(std::move(send_frame)), send_text_(std::move(send_text)) {
  render_thread_ = std::thread([this] { render_loop(); });
  encode_thread_ = std::thread([this] { encode_loop(); });
}

FramePipeline::~FramePipeline() {
  stop();
  if (render_thread_.joinable()) render_thread_.join();
  if (encode_thread_.joinable()) encode_thread_.join();
}

void FramePipeline::submit(const ViewRequest& view) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    pending_ = view;
  }
  changed_.notify_all();
}

void FramePipeline::frame_sent() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    frame_in_flight_ = false;
  }
  changed_.notify_all();
}

void FramePipeline::stop() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
}

std::vector<uint8_t> FramePipeline::take_buffer(size_t bytes) {
  std::vector<uint8_t> buffer;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!spare_buffers_.empty()) {
      buffer = std::move(spare_buffers_.back());
      spare_buffers_.pop_back();
    }
  }
  buffer.resize(bytes);  // a buffer of the same size is reused as it is: no allocation, no page faults
  return buffer;
}

void FramePipeline::return_buffers(RenderedFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (std::vector<uint8_t>* buffer : {&frame.rgba_a, &frame.rgba_b}) {
    if (!buffer->empty() && spare_buffers_.size() < kSpareBuffers) spare_buffers_.push_back(std::move(*buffer));
  }
}

Result<RenderedFrame> FramePipeline::render_view(api::Renderer& renderer, const ViewRequest& view, bool refine) {
  RGS_ASSIGN_OR_RETURN(api::Camera camera, camera_from_request(view.camera));
  RenderedFrame frame;
  frame.view = view;
  frame.refine = refine;
  frame.width = camera.width;
  frame.height = camera.height;
  api::RenderSettings settings;
  settings.preset = view.preset;
  settings.background = view.background;
  settings.cpu_threads = state_.options.cpu_threads;
  settings.gpu_scratch_budget = state_.options.gpu_scratch_budget;
  settings.time_stages = state_.device == api::Device::kCuda;
  const size_t pixels = size_t(camera.width) * camera.height;
  const size_t count = view.compare == CompareMode::kOff ? 1 : 2;
  for (size_t i = 0; i < count; ++i) {
    const api::Scene& scene = state_.scenes[i];
    std::optional<api::Image>& image = images_[i];
    const auto start = std::chrono::steady_clock::now();
    api::FrameStats stats;
    if (image && image->width() == camera.width && image->height() == camera.height) {
      api::ImageTarget target = image->target();
      target.write_alpha = false;
      RGS_ASSIGN_OR_RETURN(stats, renderer.render(scene, camera, settings, target));
    } else {
      image.reset();  // frees the old size's memory first
      RGS_ASSIGN_OR_RETURN(api::Image fresh, renderer.render_image(scene, camera, settings, api::PixelFormat::kRgba8));
      stats = fresh.frame_stats();
      image.emplace(std::move(fresh));
    }
    frame.render_call_ms += ms_since(start);
    const auto readback = std::chrono::steady_clock::now();
    std::vector<uint8_t>& rgba = i == 0 ? frame.rgba_a : frame.rgba_b;
    rgba = take_buffer(pixels * 4);
    RGS_RETURN_IF_ERROR(image->copy_to_host(rgba.data(), nullptr));
    frame.readback_ms += ms_since(readback);
    if (i == 0) frame.stats = stats;
  }
  if (state_.device == api::Device::kCuda) {
    auto device = api::query_device(api::Device::kCuda, state_.options.cuda_device);
    if (device.ok()) {
      frame.gpu_memory_total = device->memory_total_bytes;
      frame.gpu_memory_used = device->memory_total_bytes - device->memory_free_bytes;
    }
  }
  return frame;
}

void FramePipeline::render_loop() {
  auto renderer = api::Renderer::create(state_.device, state_.options.cuda_device);
  if (!renderer.ok()) {
    send_text_(error_json("render_failed", renderer.status().message(), false));
    return;
  }
  std::optional<ViewRequest> current;
  int refinements = 0;
  bool refine_wanted = false;
  for (;;) {
    bool refine = false;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || pending_.has_value() || refine_wanted; });
      // A refinement waits for the view to stay still a moment: a newer view (the camera still moving) wins.
      if (!pending_ && refine_wanted) changed_.wait_for(lock, kRefineDelay, [&] { return stopping_ || pending_; });
      if (stopping_) return;
      if (pending_) {
        current = std::move(pending_);
        pending_.reset();
        refinements = 0;
      } else {
        refine = true;
        ++refinements;
      }
      refine_wanted = false;
    }
    auto frame = render_view(*renderer, *current, refine);
    if (!frame.ok()) {
      send_text_(error_json("render_failed", frame.status().message(), false));
      continue;
    }
    const api::LodFrameCounts& lod = frame->stats.lod;
    const bool lod_active = state_.scenes.front().info().lod.active;
    std::unique_lock<std::mutex> lock(mutex_);
    changed_.wait(lock, [&] { return stopping_ || !rendered_.has_value(); });
    if (stopping_) return;
    rendered_ = std::move(*frame);
    refine_wanted = lod_active && refinements < kMaxRefinements &&
                    (lod.chunks_not_resident > 0 || lod.ranges_streamed > 0);
    lock.unlock();
    changed_.notify_all();
  }
}

void FramePipeline::encode_loop() {
  for (;;) {
    RenderedFrame frame;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || rendered_.has_value(); });
      if (stopping_) return;
      frame = std::move(*rendered_);
      rendered_.reset();
    }
    changed_.notify_all();
    auto message = encode_frame(frame);
    return_buffers(frame);
    if (!message.ok()) {
      send_text_(error_json("render_failed", message.status().message(), false));
      continue;
    }
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || !frame_in_flight_; });
      if (stopping_) return;
      frame_in_flight_ = true;
    }
    send_frame_(std::make_shared<std::vector<uint8_t>>(std::move(*message)));
  }
}

}  // namespace rgs::view::detail
