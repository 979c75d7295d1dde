// The network side of rgs-view: an Asio io_context on a few threads accepting connections for the HTTP and
// WebSocket sessions (http_session.cpp, ws_session.cpp), start and stop (view/PROTOCOL.md).
#include "rgs/view/server.h"

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/error.hpp>
#include <random>

#include "internal_server.h"
#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/view/image_codec.h"

namespace rgs::view {

namespace {

// After an accept error other than the acceptor closing (out of file descriptors), the next try.
constexpr auto kAcceptRetry = std::chrono::milliseconds(100);
constexpr uint64_t kMinFrameMemory = uint64_t(16) << 20;

bool is_loopback_host(const std::string& host) {
  return host == "127.0.0.1" || host == "::1" || host == "localhost";
}

std::string random_token() {
  std::random_device device;
  static const char kHex[] = "0123456789abcdef";
  std::string token;
  for (int i = 0; i < 8; ++i) {
    uint32_t v = device();
    for (int k = 0; k < 4; ++k, v >>= 4) token.push_back(kHex[v & 15]);
  }
  return token;
}

bool valid_token(const std::string& token) {
  if (!token.empty() && token.size() < kMinTokenLength) return false;
  for (char c : token) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) return false;
  }
  return true;
}

}  // namespace

void Server::Impl::accept() {
  acceptor->async_accept(net::make_strand(*ioc), [this](beast::error_code ec, tcp::socket socket) {
    if (stopping.load() || ec == net::error::operation_aborted) return;  // the acceptor was closed
    if (ec) {  // e.g. out of file descriptors: the connection waits in the backlog; accepting goes on
      accept_retry->expires_after(kAcceptRetry);
      accept_retry->async_wait([this](beast::error_code wait) {
        if (!wait && !stopping.load()) accept();
      });
      return;
    }
    detail::serve_connection(std::move(socket), *this);
    accept();
  });
}

void Server::Impl::retire(std::unique_ptr<detail::FramePipeline> pipeline) {
  if (pipeline == nullptr) return;
  pipeline->stop();
  {
    std::lock_guard<std::mutex> lock(retired_mutex);
    if (!retire_inline) {
      retired.push_back(std::move(pipeline));
    }
  }
  pipeline.reset();  // when inline: joins its threads here, while `ioc` still exists
  retired_changed.notify_all();
}

void Server::Impl::reap() {
  std::unique_lock<std::mutex> lock(retired_mutex);
  for (;;) {
    retired_changed.wait(lock, [&] { return reaper_done || !retired.empty(); });
    std::vector<std::unique_ptr<detail::FramePipeline>> batch;
    batch.swap(retired);
    lock.unlock();
    batch.clear();  // joins their threads
    lock.lock();
    if (reaper_done && retired.empty()) return;
  }
}

void Server::Impl::add_session(const std::shared_ptr<detail::WsSession>& session) {
  std::lock_guard<std::mutex> lock(sessions_mutex);
  sessions.erase(std::remove_if(sessions.begin(), sessions.end(), [](const auto& w) { return w.expired(); }),
                 sessions.end());
  sessions.push_back(session);
}

// ---------------------------------------------------------------------------------------------------------

Server::Server(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
Server::Server(Server&&) noexcept = default;
Server& Server::operator=(Server&& other) noexcept {
  if (this != &other) {
    stop();
    impl_ = std::move(other.impl_);
  }
  return *this;
}
Server::~Server() { stop(); }

std::string Server::url() const { return impl_ ? impl_->url : std::string(); }
uint16_t Server::port() const { return impl_ ? impl_->port : 0; }
const std::string& Server::token() const {
  static const std::string kNone;
  return impl_ ? impl_->token : kNone;
}
const std::string& Server::jpeg_encoder() const {
  static const std::string kNone;
  return impl_ ? impl_->state.jpeg_encoder : kNone;
}
uint32_t Server::clients() const { return impl_ ? impl_->ws_clients.load() : 0; }
uint64_t Server::frame_memory_held() const { return impl_ ? impl_->budget.held() : 0; }
uint64_t Server::frame_memory_peak() const { return impl_ ? impl_->budget.peak() : 0; }

Result<Server> Server::start(std::vector<api::Scene> scenes, const ServerOptions& options) {
  RGS_RETURN_ERROR_IF(scenes.empty() || scenes.size() > 2, StatusCode::kInvalidArgument,
                      "view server: " + std::to_string(scenes.size()) + " scenes given; it shows one, or two to compare");
  RGS_RETURN_ERROR_IF(scenes.size() == 2 && scenes[0].device() != scenes[1].device(), StatusCode::kInvalidArgument,
                      "view server: the two scenes are on different devices");
  RGS_RETURN_ERROR_IF(options.max_clients < 1 || options.max_clients > 64, StatusCode::kInvalidArgument,
                      "view server: max_clients " + std::to_string(options.max_clients) + " is outside 1..64");
  RGS_RETURN_ERROR_IF(options.io_threads < 1 || options.io_threads > 16, StatusCode::kInvalidArgument,
                      "view server: io_threads " + std::to_string(options.io_threads) + " is outside 1..16");
  RGS_RETURN_ERROR_IF(!valid_token(options.token), StatusCode::kInvalidArgument,
                      "view server: a token must have at least " + std::to_string(kMinTokenLength) +
                          " characters, only letters, digits, '-' and '_' (it has " +
                          std::to_string(options.token.size()) + ")");
  RGS_RETURN_ERROR_IF(!(options.idle_timeout_s >= 0.05 && options.idle_timeout_s <= 86400),
                      StatusCode::kInvalidArgument,
                      "view server: idle_timeout_s " + std::to_string(options.idle_timeout_s) +
                          " is outside 0.05..86400 seconds");
  RGS_RETURN_ERROR_IF(options.frame_memory < kMinFrameMemory, StatusCode::kInvalidArgument,
                      "view server: frame_memory " + std::to_string(options.frame_memory) +
                          " bytes is below the least, 16 MiB");
  RGS_RETURN_ERROR_IF(!(options.max_mbps >= 0 && options.max_mbps <= kMaxMbps), StatusCode::kInvalidArgument,
                      "view server: max_mbps " + std::to_string(options.max_mbps) + " is outside 0..100000");
  RGS_RETURN_ERROR_IF(options.max_width < 1 || options.max_width > 7680 || options.max_height < 1 ||
                          options.max_height > 4320,
                      StatusCode::kInvalidArgument, "view server: the largest frame must be within 7680 x 4320");
  auto impl = std::make_unique<Impl>(options.frame_memory);
  detail::ServerState& state = impl->state;
  state.device = scenes.front().device();
  state.scenes = std::move(scenes);
  state.options = options;
  if (state.options.default_width == 0 || state.options.default_height == 0) {
    state.options.default_width = state.device == api::Device::kCuda ? 1920 : 640;
    state.options.default_height = state.device == api::Device::kCuda ? 1080 : 360;
  }
  state.options.default_width = std::min(state.options.default_width, options.max_width);
  state.options.default_height = std::min(state.options.default_height, options.max_height);
  state.limits.max_width = options.max_width;
  state.limits.max_height = options.max_height;
  state.limits.presets = renderable_presets(state.scenes);
  state.limits.default_preset = options.preset;
  state.limits.compare_available = state.scenes.size() == 2;
  RGS_RETURN_ERROR_IF(std::find(state.limits.presets.begin(), state.limits.presets.end(), options.preset) ==
                          state.limits.presets.end(),
                      StatusCode::kInvalidArgument,
                      std::string("view server: the scenes were not loaded for preset ") +
                          api::preset_name(options.preset) + " (load_view_scene lists every preset they can render)");
  RGS_ASSIGN_OR_RETURN(api::DeviceInfo device, api::query_device(state.device, options.cuda_device));
  state.jpeg_encoder = jpeg_encoder_name(detail::encode_workers());
  if (state.device == api::Device::kCuda && options.gpu_jpeg) {
    auto gpu_jpeg = api::GpuJpegEncoder::create(options.cuda_device);
    state.gpu_jpeg = gpu_jpeg.ok();
    state.jpeg_encoder = gpu_jpeg.ok() ? "JPEG: " + gpu_jpeg->name() + " on the GPU"
                                       : state.jpeg_encoder + " (" + gpu_jpeg.status().message() + ")";
  }
  state.hello_json = detail::build_hello(state, device.name);

  impl->token = options.token;
  if (impl->token.empty() && !is_loopback_host(options.host)) impl->token = random_token();

  impl->ioc = std::make_unique<net::io_context>(int(options.io_threads));
  beast::error_code ec;
  tcp::resolver resolver(*impl->ioc);
  const auto endpoints = resolver.resolve(options.host, std::to_string(options.port),
                                          tcp::resolver::passive | tcp::resolver::numeric_service, ec);
  RGS_RETURN_ERROR_IF(ec || endpoints.empty(), StatusCode::kIoError,
                      "view server: cannot resolve host " + options.host + ": " + ec.message());
  const tcp::endpoint endpoint = endpoints.begin()->endpoint();
  impl->acceptor = std::make_unique<tcp::acceptor>(net::make_strand(*impl->ioc));
  const auto fail = [&](const char* what) {
    return Status(StatusCode::kIoError, "view server: " + std::string(what) + " " + options.host + ":" +
                                            std::to_string(options.port) + ": " + ec.message());
  };
  impl->acceptor->open(endpoint.protocol(), ec);
  if (ec) return fail("cannot open a socket for");
  impl->acceptor->set_option(net::socket_base::reuse_address(true), ec);
  impl->acceptor->bind(endpoint, ec);
  if (ec == net::error::address_in_use) {
    return Status(StatusCode::kIoError, "view server: port " + std::to_string(options.port) + " of " + options.host +
                                            " is in use (another server, or another rgs-view); choose another with "
                                            "port (--port), or 0 for a free one");
  }
  if (ec) return fail("cannot bind to");
  impl->acceptor->listen(net::socket_base::max_listen_connections, ec);
  if (ec) return fail("cannot listen on");
  impl->port = impl->acceptor->local_endpoint().port();
  const std::string host_text = endpoint.address().is_v6() ? "[" + options.host + "]" : options.host;
  impl->url = "http://" + host_text + ":" + std::to_string(impl->port) + "/";
  if (!impl->token.empty()) impl->url += "?token=" + impl->token;
  impl->admission = detail::make_admission_policy(options.host, impl->port, impl->token);
  impl->accept_retry = std::make_unique<net::steady_timer>(impl->acceptor->get_executor());

  Impl* raw = impl.get();
  raw->reaper = std::thread([raw] { raw->reap(); });
  raw->accept();
  for (uint32_t i = 0; i < options.io_threads; ++i) raw->threads.emplace_back([raw] { raw->ioc->run(); });
  return Server(std::move(impl));
}

void Server::stop() {
  if (impl_ == nullptr || impl_->stopped) return;
  Impl& s = *impl_;
  s.stopped = true;
  s.stopping.store(true);
  net::post(s.acceptor->get_executor(), [&s] {
    beast::error_code ec;
    s.acceptor->close(ec);
    s.accept_retry->cancel();
  });
  {
    std::lock_guard<std::mutex> lock(s.sessions_mutex);
    for (const auto& weak : s.sessions) {
      if (auto session = weak.lock()) detail::close_websocket(session, websocket::close_code::going_away);
    }
  }
  // Let the close handshakes finish (a client that does not answer is cut off after this).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (s.open_sessions.load() > 0 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  s.ioc->stop();
  for (std::thread& t : s.threads) t.join();
  s.threads.clear();
  {
    std::lock_guard<std::mutex> lock(s.retired_mutex);
    s.reaper_done = true;
  }
  s.retired_changed.notify_all();
  s.reaper.join();  // every pipeline retired so far is destroyed, `ioc` still alive
  {
    std::lock_guard<std::mutex> lock(s.retired_mutex);
    s.retire_inline = true;
  }
  s.accept_retry.reset();
  s.acceptor.reset();
  s.ioc.reset();  // destroys the handlers still queued, and with them the sessions they held (and their pipelines)
}

// ---------------------------------------------------------------------------------------------------------

std::vector<api::Preset> renderable_presets(const std::vector<api::Scene>& scenes) {
  std::vector<api::Preset> out;
  for (api::Preset preset : {api::Preset::kFastest, api::Preset::kFaithful, api::Preset::kPaper}) {
    bool ok = true;
    for (const api::Scene& scene : scenes) {
      const api::SceneInfo& info = scene.info();
      if (info.device != api::Device::kCuda) continue;
      if (api::preset_reads_fp32(preset) ? (!info.has_fp32 || info.lod.active) : !(info.has_compact || info.has_fp32)) {
        ok = false;
      }
    }
    if (ok) out.push_back(preset);
  }
  return out;
}

Result<api::Scene> load_view_scene(const std::string& path, api::LoadOptions options) {
  options.presets = {api::Preset::kFastest, api::Preset::kFaithful, api::Preset::kPaper};
  options.skip_unrenderable_presets = true;  // a level-of-detail scene on CUDA: not faithful
  return api::load(path, options);
}

}  // namespace rgs::view
