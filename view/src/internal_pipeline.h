// One client's frames: a render thread (its own api::Renderer) and an encoder thread with one slot between
// them, so that frame k+1 renders while frame k is encoded and sent, every frame drawing its host memory from the
// server's FrameBudget (view/PROTOCOL.md "Flow control and memory").
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <nlohmann/json_fwd.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "internal_bandwidth.h"
#include "internal_frame_budget.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/parallel/worker_pool.h"
#include "rgs/view/protocol.h"
#include "rgs/view/server.h"

namespace rgs::view::detail {

/// What every client of a server shares (immutable while it runs).
struct ServerState {
  std::vector<api::Scene> scenes;  ///< 1 or 2, on `device`
  api::Device device = api::Device::kCpu;
  ServerOptions options;
  ProtocolLimits limits;
  std::string hello_json;  ///< the hello message (build_hello)
  /// JPEG frames of GPU scenes are encoded on the GPU (ServerOptions::gpu_jpeg, and nvJPEG loaded).
  bool gpu_jpeg = false;
  /// How JPEG frames are encoded, for display (hello "encoder").
  std::string jpeg_encoder;
};

/// The hello message of view/PROTOCOL.md for `state` (its hello_json unset). `device_name`: query_device's.
std::string build_hello(const ServerState& state, const std::string& device_name);

/// A camera as the protocol writes it (hello's "cameras" and "home_camera", a view's "camera"): the cameras.json
/// keys width, height, position, rotation (3 rows), fx, fy.
nlohmann::json camera_json(const InriaCamera& camera);

/// Milliseconds from `start` to now.
inline double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

/// The text of an error message (PROTOCOL.md "error"); `message` may hold any bytes (invalid UTF-8 is replaced).
std::string error_json(const std::string& code, const std::string& message, bool fatal);

/// A frame rendered and read back, waiting for the encoder.
struct RenderedFrame {
  ViewRequest view;
  bool refine = false;
  uint32_t width = 0, height = 0;
  std::vector<uint8_t> rgba_a, rgba_b;  ///< [H, W, 4] 8-bit as read back, alpha ignored (rgba_b: compare modes)
  std::vector<uint8_t> jpeg_a;          ///< scene a's JPEG encoded on the GPU (then rgba_a is empty)
  double gpu_encode_ms = 0;             ///< the wall time of jpeg_a's encode
  Charge charge;                       ///< what the frame holds of the budget until it is sent
  api::FrameStats stats;               ///< scene a's
  double render_call_ms = 0, readback_ms = 0;
  std::optional<uint64_t> gpu_memory_used, gpu_memory_total;
  RateChoice rate;      ///< its quality and scale under the bandwidth budget
  double max_mbps = 0;  ///< the bandwidth budget it was rendered under; 0: none
};

/// Workers of each client's JPEG encoder: the CPUs the server may use, at most 8.
inline unsigned encode_workers() { return std::min(parallel::available_cpus(), 8u); }

/// The binary frame message (PROTOCOL.md "frame") of `frame`: its images encoded as the view asks, JPEG on
/// `workers` (encode_rgb); a JPEG encoded on the GPU (jpeg_a) is moved into it.
Result<std::vector<uint8_t>> encode_frame(RenderedFrame& frame, parallel::WorkerPool* workers = nullptr);

/// Renders and encodes one client's views. The callbacks are called from the pipeline's threads and must only
/// hand their message over (e.g. post it to the connection's strand). A frame message holds its part of `budget`
/// until the last copy of its shared pointer is gone. Destroying the pipeline stops and joins its threads;
/// `state` and `budget` must outlive it and every frame message.
class FramePipeline {
 public:
  using SendBinary = std::function<void(std::shared_ptr<std::vector<uint8_t>>)>;
  using SendText = std::function<void(std::string)>;

  FramePipeline(const ServerState& state, FrameBudget& budget, SendBinary send_frame, SendText send_text);
  ~FramePipeline();
  FramePipeline(const FramePipeline&) = delete;
  FramePipeline& operator=(const FramePipeline&) = delete;

  /// Makes `view` the next view to render, replacing one not yet started (also one waiting for the budget).
  void submit(const ViewRequest& view);
  /// The frame last handed to SendBinary has been written: the encoder may hand over the next.
  void frame_sent();
  /// Asks the threads to finish (what they are doing is dropped); the destructor joins them.
  void stop();

 private:
  /// A host image buffer kept between frames with its part of the budget.
  struct SpareBuffer {
    std::vector<uint8_t> bytes;
    Charge charge;
  };
  /// What the render thread does next.
  struct Work {
    bool stop = false, refine = false, free_planes = false;
  };

  void render_loop();
  void encode_loop();
  /// Waits until there is a view to render (or render again) and room for another unsent frame; takes it into
  /// `current`. Drops the spare buffers after kSpareHold without work.
  Work next_work(std::optional<ViewRequest>* current, int* refinements, bool* refine_wanted);
  /// The budget for a frame of `view`, with spare buffers of its size in `buffers` and the kept planes (planes_)
  /// when the rest fits at once (else it calls `free_planes` and waits holding nothing); kLimitExceeded when the
  /// frame needs more than the whole budget; an empty Charge when a newer view (or stop) came first.
  Result<Charge> reserve(const ViewRequest& view, std::vector<std::vector<uint8_t>>* buffers,
                         const std::function<void()>& free_planes);
  /// Renders `view`; with `gpu_jpeg` (GPU scenes) a JPEG view without compare is encoded on the GPU, else the
  /// images are read back into `buffers`.
  Result<RenderedFrame> render_view(api::Renderer& renderer, api::GpuJpegEncoder* gpu_jpeg, const ViewRequest& view,
                                    bool refine, std::vector<std::vector<uint8_t>> buffers);
  /// `buffer` back to the spares with `bytes` of `charge`; beyond kSpareBuffers it is freed.
  void keep_spare(std::vector<uint8_t> buffer, Charge charge);
  void frame_dropped();
  /// Runs `change` under mutex_, then wakes every thread waiting on changed_.
  void update(const std::function<void()>& change);

  /// Host image buffers kept between frames: two frames (one rendering, one encoding) of two images each.
  static constexpr size_t kSpareBuffers = 4;
  /// The CPU renderer's planes (render_scratch_bytes) it keeps for its next frame, charged while it keeps them;
  /// used by the render thread only.
  Charge planes_;
  /// Frames rendered (or being rendered) and not yet sent, at most: one being sent while the next renders.
  static constexpr int kMaxUnsentFrames = 2;
  /// How long spare buffers are kept while the client asks for nothing.
  static constexpr std::chrono::milliseconds kSpareHold{1000};
  /// How long a level-of-detail view must stay the newest before it is rendered again as its levels arrive.
  static constexpr std::chrono::milliseconds kRefineDelay{40};

  const ServerState& state_;
  FrameBudget& budget_;
  SendBinary send_frame_;
  SendText send_text_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::optional<ViewRequest> pending_;
  std::optional<RenderedFrame> rendered_;
  int unsent_frames_ = 0;
  bool frame_in_flight_ = false;
  bool stopping_ = false;
  std::atomic<bool> interrupted_{false};  // a newer view or stop(): a wait for the budget gives up
  std::vector<SpareBuffer> spares_;
  RateControl rate_;  // the bandwidth budget's quality and scale (under mutex_)
  std::optional<api::Image> images_[2];  // render thread only, GPU: reused while the size stays
  /// The JPEG encoder's workers (the encode thread and encode_workers() − 1 more), encode thread only.
  parallel::WorkerPool encoders_{encode_workers()};
  std::thread render_thread_, encode_thread_;
};

}  // namespace rgs::view::detail
