// A client's frame pipeline: render (api::Renderer, one per client thread), read back, encode, hand over, each
// frame holding its part of the server's frame memory budget from its render until it is sent.
#include <algorithm>
#include <chrono>

#include "internal_pipeline.h"
#include "rgs/api/camera.h"
#include "rgs/api/scene.h"
#include "rgs/view/image_codec.h"

namespace rgs::view::detail {

namespace {

// Views of a level-of-detail scene rendered again while levels are still arriving (PROTOCOL.md "Refinement").
constexpr int kMaxRefinements = 8;

std::string megabytes(uint64_t bytes) { return std::to_string((bytes + (1 << 20) - 1) >> 20) + " MiB"; }

// A frame message that gives its part of the budget back when its bytes are freed.
struct ChargedMessage {
  std::vector<uint8_t> bytes;
  Charge charge;
};

}  // namespace

FramePipeline::FramePipeline(const ServerState& state, FrameBudget& budget, SendBinary send_frame,
                             SendText send_text)
    : state_(state), budget_(budget), send_frame_(std::move(send_frame)), send_text_(std::move(send_text)) {
  render_thread_ = std::thread([this] { render_loop(); });
  encode_thread_ = std::thread([this] { encode_loop(); });
}

FramePipeline::~FramePipeline() {
  stop();
  if (render_thread_.joinable()) render_thread_.join();
  if (encode_thread_.joinable()) encode_thread_.join();
}

void FramePipeline::update(const std::function<void()>& change) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    change();
  }
  changed_.notify_all();
}

void FramePipeline::submit(const ViewRequest& view) {
  update([&] {
    pending_ = view;
    interrupted_.store(true);
  });
  budget_.wake();
}

void FramePipeline::frame_sent() {
  update([&] {
    frame_in_flight_ = false;
    --unsent_frames_;
  });
}

void FramePipeline::frame_dropped() { update([&] { --unsent_frames_; }); }

void FramePipeline::stop() {
  update([&] {
    stopping_ = true;
    interrupted_.store(true);
  });
  budget_.wake();
}

void FramePipeline::keep_spare(std::vector<uint8_t> buffer, Charge charge) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (buffer.empty() || spares_.size() >= kSpareBuffers) return;  // freed here, with its charge
  spares_.push_back({std::move(buffer), std::move(charge)});
}

FramePipeline::Work FramePipeline::next_work(std::optional<ViewRequest>* current, int* refinements,
                                             bool* refine_wanted) {
  std::unique_lock<std::mutex> lock(mutex_);
  const auto ready = [&] { return (pending_ || *refine_wanted) && unsent_frames_ < kMaxUnsentFrames; };
  while (!stopping_ && !ready()) {
    // Spare buffers are worth keeping while frames follow each other, not while the client is still or stuck.
    if (spares_.empty() && planes_.bytes() == 0) {
      changed_.wait(lock);
    } else if (changed_.wait_for(lock, kSpareHold) == std::cv_status::timeout) {
      spares_.clear();
      if (planes_.bytes() > 0) return Work{false, false, true};
    }
  }
  // A refinement waits for the view to stay still a moment: a newer view (the camera still moving) wins.
  if (!stopping_ && !pending_) changed_.wait_for(lock, kRefineDelay, [&] { return stopping_ || pending_; });
  Work work;
  work.stop = stopping_;
  if (work.stop) return work;
  if (pending_) {
    *current = std::move(pending_);
    pending_.reset();
    *refinements = 0;
  } else {
    work.refine = true;
    ++*refinements;
  }
  *refine_wanted = false;
  interrupted_.store(false);
  return work;
}

Result<Charge> FramePipeline::reserve(const ViewRequest& view, std::vector<std::vector<uint8_t>>* buffers,
                                      const std::function<void()>& free_planes) {
  const uint64_t need = frame_memory_bytes(view, state_.device);
  RGS_RETURN_ERROR_IF(need > budget_.capacity(), StatusCode::kLimitExceeded,
                      "a " + std::to_string(view.camera.width) + " x " + std::to_string(view.camera.height) + " " +
                          encoding_name(view.encoding) + " frame" +
                          (view.compare == CompareMode::kOff ? "" : std::string(" (compare ") +
                                                                       compare_mode_name(view.compare) + ")") +
                          " needs " + megabytes(need) + " of frame memory, more than the server's " +
                          megabytes(budget_.capacity()) + " (rgs-view --frame-memory)");
  const size_t rgba_bytes = size_t(view.camera.width) * view.camera.height * 4;
  const size_t images = view.compare == CompareMode::kOff ? 1 : 2;
  if (planes_.bytes() > 0 && planes_.bytes() != render_scratch_bytes(view, state_.device)) free_planes();
  const bool kept_planes = planes_.bytes() > 0;
  Charge charge = std::move(planes_);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    for (SpareBuffer& spare : spares_) {
      if (buffers->size() < images && spare.bytes.size() == rgba_bytes) {
        buffers->push_back(std::move(spare.bytes));
        charge.absorb(std::move(spare.charge));
      }
    }
    spares_.clear();  // the rest are of another size
  }
  const uint64_t more = need - std::min<uint64_t>(need, charge.bytes());
  if (std::optional<Charge> rest = budget_.try_acquire(more)) {
    charge.absorb(std::move(*rest));
    return charge;
  }
  // A wait holds nothing: waiters holding bytes could keep each other waiting for good.
  buffers->clear();
  if (kept_planes) free_planes();
  charge.reset();
  std::optional<Charge> all = budget_.acquire(need, interrupted_);
  return all ? std::move(*all) : Charge();  // empty when a newer view or stop() came first
}

Result<RenderedFrame> FramePipeline::render_view(api::Renderer& renderer, api::GpuJpegEncoder* gpu_jpeg,
                                                 const ViewRequest& view, bool refine,
                                                 std::vector<std::vector<uint8_t>> buffers) {
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
  const bool encode_on_gpu = gpu_jpeg != nullptr && count == 1 && view.encoding == Encoding::kJpeg;
  buffers.resize(count);
  for (size_t i = 0; i < count; ++i) {
    const api::Scene& scene = state_.scenes[i];
    std::vector<uint8_t>& rgba = i == 0 ? frame.rgba_a : frame.rgba_b;
    rgba = std::move(buffers[i]);
    // A spare buffer has this size already: no allocation, no page faults.
    if (!encode_on_gpu) rgba.resize(pixels * 4);
    api::FrameStats stats;
    const auto start = std::chrono::steady_clock::now();
    if (state_.device == api::Device::kCpu) {
      // The CPU renderer writes the host buffer itself.
      api::ImageTarget target;
      target.width = camera.width;
      target.height = camera.height;
      target.color = rgba.data();
      target.color_pitch = size_t(camera.width) * 4;
      target.format = api::PixelFormat::kRgba8;
      target.write_alpha = false;
      RGS_ASSIGN_OR_RETURN(stats, renderer.render(scene, camera, settings, target));
      frame.render_call_ms += ms_since(start);
    } else {
      std::optional<api::Image>& image = images_[i];
      if (image && image->width() == camera.width && image->height() == camera.height) {
        api::ImageTarget target = image->target();
        target.write_alpha = false;
        RGS_ASSIGN_OR_RETURN(stats, renderer.render(scene, camera, settings, target));
      } else {
        image.reset();  // frees the old size's memory first
        RGS_ASSIGN_OR_RETURN(api::Image fresh,
                             renderer.render_image(scene, camera, settings, api::PixelFormat::kRgba8));
        stats = fresh.frame_stats();
        image.emplace(std::move(fresh));
      }
      frame.render_call_ms += ms_since(start);
      const auto readback = std::chrono::steady_clock::now();
      if (encode_on_gpu) {
        RGS_RETURN_IF_ERROR(gpu_jpeg->encode(*image, view.quality, jpeg_subsamples_chroma(view.quality), &frame.jpeg_a));
        frame.gpu_encode_ms = ms_since(readback);
      } else {
        RGS_RETURN_IF_ERROR(image->copy_to_host(rgba.data(), nullptr));
        frame.readback_ms += ms_since(readback);
      }
    }
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
  std::optional<api::GpuJpegEncoder> gpu_jpeg;
  if (state_.gpu_jpeg) {
    auto encoder = api::GpuJpegEncoder::create(state_.options.cuda_device);
    if (!encoder.ok()) {
      send_text_(error_json("render_failed", encoder.status().message(), false));
      return;
    }
    gpu_jpeg.emplace(std::move(*encoder));
  }
  // The planes a CPU renderer keeps stay charged to it (planes_) until a frame of their size reuses them; they
  // are freed, with the renderer, before a frame of another size, a wait for the budget, or kSpareHold idle.
  const auto free_planes = [&] {
    if (auto fresh = api::Renderer::create(state_.device, state_.options.cuda_device); fresh.ok()) {
      renderer = std::move(fresh);
    }
    planes_.reset();
  };
  std::optional<ViewRequest> current;
  int refinements = 0;
  bool refine_wanted = false;
  for (;;) {
    const Work work = next_work(&current, &refinements, &refine_wanted);
    if (work.stop) return;
    if (work.free_planes) {
      free_planes();
      continue;
    }
    const double mbps = effective_mbps(state_.options.max_mbps, current->max_mbps);
    RateChoice rate;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      rate = rate_.choose(mbps, *current, current->still || work.refine);
    }
    const ViewRequest view = apply_rate(*current, rate);
    std::vector<std::vector<uint8_t>> buffers;
    auto charge = reserve(view, &buffers, free_planes);
    if (!charge.ok()) {
      send_text_(error_json("render_failed", charge.status().message(), false));
      continue;
    }
    if (charge->bytes() == 0) continue;  // a newer view, or stop
    {
      std::lock_guard<std::mutex> lock(mutex_);
      ++unsent_frames_;
    }
    auto frame = render_view(*renderer, gpu_jpeg ? &*gpu_jpeg : nullptr, view, work.refine, std::move(buffers));
    if (!frame.ok()) {
      frame_dropped();
      send_text_(error_json("render_failed", frame.status().message(), false));
      continue;
    }
    planes_ = charge->split(render_scratch_bytes(view, state_.device));
    frame->charge = std::move(*charge);
    frame->rate = rate;
    frame->max_mbps = mbps;
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
    auto message = encode_frame(frame, &encoders_);
    for (std::vector<uint8_t>* rgba : {&frame.rgba_a, &frame.rgba_b}) {
      Charge charge = frame.charge.split(rgba->size());
      keep_spare(std::move(*rgba), std::move(charge));
    }
    if (!message.ok()) {
      frame_dropped();
      send_text_(error_json("render_failed", message.status().message(), false));
      continue;
    }
    auto charged = std::make_shared<ChargedMessage>();
    charged->bytes = std::move(*message);
    charged->charge = frame.charge.split(charged->bytes.size());
    frame.charge.reset();  // the encoder's working memory
    {
      std::unique_lock<std::mutex> lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || !frame_in_flight_; });
      const auto seconds = [] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
      };
      changed_.wait_for(lock, std::chrono::duration<double>(rate_.wait_s(seconds())), [&] { return stopping_; });
      if (stopping_) return;
      frame_in_flight_ = true;
      rate_.record(charged->bytes.size(), uint64_t(frame.width) * frame.height, frame.view.quality,
                   frame.view.encoding != Encoding::kLossless, frame.rate.limited ? frame.max_mbps : 0, seconds());
    }
    send_frame_(std::shared_ptr<std::vector<uint8_t>>(charged, &charged->bytes));
  }
}

}  // namespace rgs::view::detail
