// rgs-view's server: serves the viewer page (view/web/, embedded in the library at build time) and renders each
// client's views through the front door (api::Renderer) into JPEG/WebP frames over a WebSocket
// (view/PROTOCOL.md). The library prints nothing and installs no signal handler: the caller starts it, shows
// its url() and stops it.
//
// Threads: start() runs an Asio io_context on `io_threads` threads; each client gets a render thread (with its
// own api::Renderer) and an encoder thread, so rendering frame k+1 overlaps encoding and sending frame k. The
// scenes are shared by every client (api::Scene is immutable; level-of-detail GPU scenes take turns), and so is
// one host memory budget for their frames.
//
// Who may connect, and the limits that keep idle or hostile clients from exhausting the server: view/PROTOCOL.md
// "Transport and security", docs/VIEWER.md "Security model".
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "rgs/api/camera.h"
#include "rgs/api/preset.h"
#include "rgs/api/scene.h"
#include "rgs/format/status.h"
#include "rgs/view/protocol.h"

namespace rgs::view {

/// The shortest token ServerOptions::token may be (a random one has 32 hex digits).
inline constexpr size_t kMinTokenLength = 16;

/// How the server listens and renders.
struct ServerOptions {
  /// Address to bind: "127.0.0.1" (default, this machine only), "::1", "localhost", or any other address, which
  /// makes a token required (below).
  std::string host = "127.0.0.1";
  /// TCP port; 0 picks a free one (Server::port() says which).
  uint16_t port = 8080;
  /// Token every HTTP request and WebSocket upgrade must carry as ?token=...; empty: none on a loopback host,
  /// a random one (32 hex digits from std::random_device) on any other host. At least kMinTokenLength letters,
  /// digits, '-' and '_'. With a token, requests may name the server by any Host (it is reached by name from
  /// other machines); without one, Host must be 127.0.0.1, localhost, [::1] or `host`, with the port.
  std::string token;
  /// Most WebSocket clients at once (1..64); another one is told "busy" and closed (code 1013).
  uint32_t max_clients = 8;
  /// A WebSocket client that sends no message for this long is closed (code 1000), freeing its slot; the page
  /// sends a ping every 20 s. Seconds, 0.05..86400.
  double idle_timeout_s = 120;
  /// Host memory that every client's frames draw from together, in bytes (at least 16 MiB): a frame's buffers,
  /// its encoder's memory and its encoded message (estimated per pixel, view/PROTOCOL.md "Flow control and
  /// memory") are held from its render until it is sent. A client whose frame does not fit, or that does not
  /// read, is not rendered for meanwhile; a frame that needs more than the whole budget fails (render_failed).
  /// The default holds the largest frame (7680 × 4320, lossless, split compare, CPU backend: 2.3 GB).
  uint64_t frame_memory = uint64_t(2560) << 20;
  /// Bandwidth budget of each client, Mbit/s in [0, kMaxMbps] (0: none); a view may ask for less. While the
  /// camera moves, frames are encoded at a lower quality and rendered smaller to keep within it
  /// (view/PROTOCOL.md "Bandwidth budget").
  double max_mbps = 0;
  /// Threads of the network io_context (1..16).
  uint32_t io_threads = 2;
  /// The preset the page starts with; the scenes must be loaded for it.
  api::Preset preset = api::Preset::kFastest;
  /// The scene's own cameras, offered to the page (hello "cameras") with their numbers as given, e.g.
  /// api::read_inria_cameras of a cameras.json.
  std::vector<api::NamedInriaCamera> cameras;
  /// The page's starting size (0: 1920 × 1080 on the GPU, 640 × 360 on the CPU).
  uint32_t default_width = 0, default_height = 0;
  /// Largest frame a client may ask for.
  uint32_t max_width = 7680, max_height = 4320;
  /// Passed to every frame's api::RenderSettings.
  unsigned cpu_threads = 0;
  uint64_t gpu_scratch_budget = 0;
  /// CUDA device of GPU scenes.
  int cuda_device = 0;
  /// GPU scenes: encode JPEG frames on the GPU with nvJPEG (api::GpuJpegEncoder) where it loads; false, or where
  /// it does not, on the CPU (encode_rgb). The hello message says which.
  bool gpu_jpeg = true;
};

/// A running server. Move-only; destroying it stops it.
class Server {
 public:
  /// Starts serving `scenes` (one, or two for the compare mode: "a" and "b"; all on one device) with
  /// `options`. Returns once the port is bound and accepting.
  /// @return kInvalidArgument (no scene or more than two, scenes on different devices, a token shorter than
  /// kMinTokenLength or with other characters, max_clients, max_mbps, io_threads, idle_timeout_s or frame_memory out of
  /// range, the preset not loaded), kIoError (the address cannot be resolved or bound: the message names it and
  /// the OS's reason).
  static Result<Server> start(std::vector<api::Scene> scenes, const ServerOptions& options);

  Server(Server&&) noexcept;
  Server& operator=(Server&&) noexcept;
  ~Server();

  /// The page's address, e.g. "http://127.0.0.1:8080/" or "http://0.0.0.0:8080/?token=..." (with the token
  /// when one is required). For a wildcard host (0.0.0.0, ::) the URL names that host as given.
  std::string url() const;
  uint16_t port() const;
  /// The token requests must carry; empty when none is required.
  const std::string& token() const;
  /// How JPEG frames are encoded (the hello message's "encoder"), e.g. "JPEG: nvJPEG 13.0.1 (libnvjpeg.so.13) on
  /// the GPU".
  const std::string& jpeg_encoder() const;
  /// WebSocket clients holding a client slot now (one that is closing has given its slot back).
  uint32_t clients() const;
  /// Bytes of ServerOptions::frame_memory the clients' frames hold now, and the most they held at once.
  uint64_t frame_memory_held() const;
  uint64_t frame_memory_peak() const;

  /// Closes the listening socket and every connection (WebSocket close 1001), stops and joins every thread.
  /// Idempotent; the destructor calls it.
  void stop();

  struct Impl;

 private:
  explicit Server(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Loads `path` for the viewer: api::load with `options`, listing every preset the device can render it with
/// (all three; on the GPU a level-of-detail scene cannot read FP32, so it is loaded without kFaithful).
/// @return api::load's errors.
Result<api::Scene> load_view_scene(const std::string& path, api::LoadOptions options);

/// The presets every one of `scenes` can render (in the order fastest, faithful, paper).
std::vector<api::Preset> renderable_presets(const std::vector<api::Scene>& scenes);

}  // namespace rgs::view
