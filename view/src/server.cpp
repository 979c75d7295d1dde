// The network side of rgs-view: an Asio io_context on a few threads, HTTP sessions that serve the embedded page,
// and WebSocket sessions that feed each client's FramePipeline (view/PROTOCOL.md).
#include "rgs/view/server.h"

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <random>
#include <thread>

#include "internal_pipeline.h"
#include "internal_routes.h"
#include "rgs/api/scene.h"

namespace rgs::view {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace {

constexpr uint32_t kMaxHttpConnections = 64;
constexpr auto kHttpTimeout = std::chrono::seconds(30);
constexpr size_t kMaxHeaderBytes = 8 * 1024;
constexpr size_t kMaxQueuedTexts = 16;  // pongs and errors waiting to be written; more pongs are dropped

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
  for (char c : token) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_')) return false;
  }
  return true;
}

}  // namespace

class WsSession;

struct Server::Impl {
  detail::ServerState state;
  std::unique_ptr<net::io_context> ioc;
  std::unique_ptr<tcp::acceptor> acceptor;
  std::vector<std::thread> threads;
  std::string token, url;
  uint16_t port = 0;
  std::atomic<uint32_t> ws_clients{0};
  std::atomic<uint32_t> http_connections{0};
  std::mutex sessions_mutex;
  std::vector<std::weak_ptr<WsSession>> sessions;
  std::atomic<bool> stopping{false};
  bool stopped = false;
  // Pipelines of closed connections, joined here so that an io thread never waits for a render to finish.
  // Their callbacks hold executors of `ioc`'s strands, so none may outlive `ioc`: stop() drains the reaper
  // before it destroys `ioc`, and the sessions that destruction ends join theirs at once (`retire_inline`).
  std::mutex retired_mutex;
  std::condition_variable retired_changed;
  std::vector<std::unique_ptr<detail::FramePipeline>> retired;
  bool reaper_done = false;
  bool retire_inline = false;
  std::thread reaper;

  void accept();
  void retire(std::unique_ptr<detail::FramePipeline> pipeline) {
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
  void reap() {
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
};

// ---------------------------------------------------------------------------------------------------------
// WebSocket session: reads and validates client messages, writes hello, errors and frames one at a time.

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Server::Impl& server) : ws_(std::move(socket)), server_(server) {}

  ~WsSession() {
    server_.retire(std::move(pipeline_));
    if (counted_) server_.ws_clients.fetch_sub(1);
  }

  void run(http::request<http::empty_body> request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(server_.state.limits.max_message_bytes);
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& response) { response.set(http::field::server, "rgs-view"); }));
    ws_.async_accept(request, beast::bind_front_handler(&WsSession::on_accept, shared_from_this()));
  }

  // Sends a close with `code` (from any thread).
  void close_from_outside(websocket::close_code code) {
    net::post(ws_.get_executor(), [self = shared_from_this(), code] { self->close_after_writes(code); });
  }

 private:
  struct Outgoing {
    bool binary = false;
    bool frame = false;
    std::shared_ptr<std::vector<uint8_t>> bytes;
  };

  void on_accept(beast::error_code ec) {
    if (ec) return;
    if (server_.stopping.load()) {
      close_after_writes(websocket::close_code::going_away);
      return;
    }
    if (server_.ws_clients.fetch_add(1) >= server_.state.options.max_clients) {
      server_.ws_clients.fetch_sub(1);
      queue_text(detail::error_json("busy",
                                    "the server has " + std::to_string(server_.state.options.max_clients) +
                                        " clients already; try again later",
                                    true));
      close_after_writes(websocket::close_code::try_again_later);
      return;
    }
    counted_ = true;
    {
      std::lock_guard<std::mutex> lock(server_.sessions_mutex);
      auto& list = server_.sessions;
      list.erase(std::remove_if(list.begin(), list.end(), [](const auto& w) { return w.expired(); }), list.end());
      list.push_back(weak_from_this());
    }
    const auto executor = ws_.get_executor();
    std::weak_ptr<WsSession> weak = weak_from_this();
    pipeline_ = std::make_unique<detail::FramePipeline>(
        server_.state,
        [executor, weak](std::shared_ptr<std::vector<uint8_t>> frame) {
          net::post(executor, [weak, frame = std::move(frame)]() mutable {
            if (auto self = weak.lock()) self->queue(Outgoing{true, true, std::move(frame)});
          });
        },
        [executor, weak](std::string text) {
          net::post(executor, [weak, text = std::move(text)]() mutable {
            if (auto self = weak.lock()) self->queue_text(std::move(text));
          });
        });
    queue_text(server_.state.hello_json);
    read();
  }

  void read() {
    ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t bytes) {
    if (ec) {
      // message_too_big: Beast has already failed the connection with close code 1009.
      if (pipeline_) pipeline_->stop();
      return;
    }
    if (closing_) return;
    if (!ws_.got_text()) {
      fail("binary", "binary messages are not part of the protocol");
      return;
    }
    const std::string text = beast::buffers_to_string(buffer_.data());
    buffer_.consume(bytes);
    auto message = parse_client_message(text, server_.state.limits);
    if (!message.ok()) {
      fail(message.status().code() == StatusCode::kLimitExceeded ? "too_big" : "bad_message",
           message.status().message());
      return;
    }
    if (message->type == ClientMessage::Type::kPing) {
      queue_text("{\"type\":\"pong\"}");
    } else if (pipeline_) {
      pipeline_->submit(message->view);
    }
    read();
  }

  void fail(const std::string& code, const std::string& why) {
    queue_text(detail::error_json(code, why, true));
    close_after_writes(websocket::close_code::policy_error);
  }

  void queue_text(std::string text) {
    size_t texts = 0;
    for (const Outgoing& o : queue_) texts += o.binary ? 0 : 1;
    if (texts >= kMaxQueuedTexts) return;  // a client flooding pings gets no more pongs until it reads
    queue(Outgoing{false, false, std::make_shared<std::vector<uint8_t>>(text.begin(), text.end())});
  }

  void queue(Outgoing outgoing) {
    if (closing_ && close_started_) {
      if (outgoing.frame && pipeline_) pipeline_->frame_sent();
      return;
    }
    queue_.push_back(std::move(outgoing));
    if (queue_.size() == 1) write_next();
  }

  void write_next() {
    if (queue_.empty()) {
      if (closing_ && !close_started_) start_close();
      return;
    }
    const Outgoing& next = queue_.front();
    ws_.binary(next.binary);
    ws_.async_write(net::buffer(*next.bytes), beast::bind_front_handler(&WsSession::on_write, shared_from_this()));
  }

  void on_write(beast::error_code ec, size_t) {
    const bool frame = queue_.front().frame;
    queue_.pop_front();
    if (frame && pipeline_) pipeline_->frame_sent();
    if (ec) {
      queue_.clear();
      if (pipeline_) pipeline_->stop();
      return;
    }
    write_next();
  }

  void close_after_writes(websocket::close_code code) {
    if (closing_) return;
    closing_ = true;
    close_code_ = code;
    if (pipeline_) pipeline_->stop();
    if (queue_.empty()) start_close();
  }

  void start_close() {
    close_started_ = true;
    ws_.async_close(websocket::close_reason(close_code_),
                    [self = shared_from_this()](beast::error_code) {});
  }

  websocket::stream<beast::tcp_stream> ws_;
  Server::Impl& server_;
  beast::flat_buffer buffer_;
  std::deque<Outgoing> queue_;
  std::unique_ptr<detail::FramePipeline> pipeline_;
  bool counted_ = false;
  bool closing_ = false, close_started_ = false;
  websocket::close_code close_code_ = websocket::close_code::normal;
};

// ---------------------------------------------------------------------------------------------------------
// HTTP session: GET of the embedded files, the token check, the WebSocket upgrade.

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Server::Impl& server) : stream_(std::move(socket)), server_(server) {
    server_.http_connections.fetch_add(1);
  }
  ~HttpSession() { server_.http_connections.fetch_sub(1); }

  void run() {
    net::dispatch(stream_.get_executor(), beast::bind_front_handler(&HttpSession::read, shared_from_this()));
  }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(kMaxHeaderBytes);
    parser_->body_limit(0);
    stream_.expires_after(kHttpTimeout);
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t) {
    if (ec == http::error::header_limit) {
      respond_status(http::status::request_header_fields_too_large, false);
      return;
    }
    if (ec) {
      stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
      return;
    }
    http::request<http::empty_body> request = parser_->release();
    const detail::Route route = detail::route_target(
        std::string_view(request.target().data(), request.target().size()), server_.token);
    if (route.kind == detail::Route::Kind::kForbidden) {
      respond_status(http::status::forbidden, false);
      return;
    }
    if (route.kind == detail::Route::Kind::kWebSocket) {
      if (!websocket::is_upgrade(request)) {
        respond_status(http::status::bad_request, request.keep_alive());
        return;
      }
      stream_.expires_never();
      std::make_shared<WsSession>(stream_.release_socket(), server_)->run(std::move(request));
      return;
    }
    if (request.method() != http::verb::get && request.method() != http::verb::head) {
      respond_status(http::status::method_not_allowed, request.keep_alive());
      return;
    }
    if (route.kind == detail::Route::Kind::kNotFound) {
      respond_status(http::status::not_found, request.keep_alive());
      return;
    }
    auto response = std::make_shared<http::response<http::string_body>>(http::status::ok, request.version());
    response->set(http::field::server, "rgs-view");
    response->set(http::field::content_type,
                  std::string(route.asset->content_type.data(), route.asset->content_type.size()));
    response->set(http::field::cache_control, "no-store");
    response->set("X-Content-Type-Options", "nosniff");
    response->set("Referrer-Policy", "no-referrer");  // the token stays out of other sites' logs
    if (request.method() == http::verb::get) {
      response->body().assign(reinterpret_cast<const char*>(route.asset->data), route.asset->size);
    }
    response->prepare_payload();
    if (request.method() == http::verb::head) response->content_length(route.asset->size);
    response->keep_alive(request.keep_alive());
    send(response);
  }

  void respond_status(http::status status, bool keep_alive) {
    auto response = std::make_shared<http::response<http::string_body>>(status, 11);
    response->set(http::field::server, "rgs-view");
    response->set(http::field::content_type, "text/plain; charset=utf-8");
    response->body() = std::to_string(static_cast<unsigned>(status)) + " " +
                       std::string(http::obsolete_reason(status)) + "\n";
    response->prepare_payload();
    response->keep_alive(keep_alive);
    send(response);
  }

  void send(std::shared_ptr<http::response<http::string_body>> response) {
    const bool keep_alive = response->keep_alive();
    http::async_write(stream_, *response,
                      [self = shared_from_this(), response, keep_alive](beast::error_code ec, size_t) {
                        if (!ec && keep_alive && !self->server_.stopping.load()) {
                          self->read();
                          return;
                        }
                        self->stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
                      });
  }

  beast::tcp_stream stream_;
  Server::Impl& server_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> parser_;
};

void Server::Impl::accept() {
  acceptor->async_accept(net::make_strand(*ioc), [this](beast::error_code ec, tcp::socket socket) {
    if (ec || stopping.load()) return;  // the acceptor was closed
    if (http_connections.load() >= kMaxHttpConnections) {
      socket.close(ec);
    } else {
      // Frames go out as soon as they are written: with Nagle's algorithm a frame's last segment waits for the
      // client's delayed acknowledgement of the one before (about 40 ms on Linux).
      socket.set_option(tcp::no_delay(true), ec);
      std::make_shared<HttpSession>(std::move(socket), *this)->run();
    }
    accept();
  });
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
uint32_t Server::clients() const { return impl_ ? impl_->ws_clients.load() : 0; }

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
                      "view server: a token may hold only letters, digits, '-' and '_'");
  RGS_RETURN_ERROR_IF(options.max_width < 1 || options.max_width > 7680 || options.max_height < 1 ||
                          options.max_height > 4320,
                      StatusCode::kInvalidArgument, "view server: the largest frame must be within 7680 x 4320");
  auto impl = std::make_unique<Impl>();
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
  if (ec) return fail("cannot bind to");
  impl->acceptor->listen(net::socket_base::max_listen_connections, ec);
  if (ec) return fail("cannot listen on");
  impl->port = impl->acceptor->local_endpoint().port();
  const std::string host_text = endpoint.address().is_v6() ? "[" + options.host + "]" : options.host;
  impl->url = "http://" + host_text + ":" + std::to_string(impl->port) + "/";
  if (!impl->token.empty()) impl->url += "?token=" + impl->token;

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
  });
  {
    std::lock_guard<std::mutex> lock(s.sessions_mutex);
    for (const auto& weak : s.sessions) {
      if (auto session = weak.lock()) session->close_from_outside(websocket::close_code::going_away);
    }
  }
  // Let the close handshakes finish (a client that does not answer is cut off after this).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(2);
  while (s.ws_clients.load() > 0 && std::chrono::steady_clock::now() < deadline) {
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
  auto scene = api::load(path, options);
  if (scene.ok() || options.device != api::Device::kCuda || scene.status().code() != StatusCode::kInvalidArgument) {
    return scene;
  }
  // A level-of-detail scene streams the compact attributes only: load it without the preset that reads FP32.
  options.presets = {api::Preset::kFastest, api::Preset::kPaper};
  return api::load(path, options);
}

}  // namespace rgs::view
