// What a running server's parts share (Server::Impl) and how a connection enters it: HTTP sessions
// (http_session.cpp) admit requests and upgrade to WebSocket sessions (ws_session.cpp), which feed each client's
// FramePipeline. The limits are those of view/PROTOCOL.md "Transport and security".
#pragma once

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/message.hpp>
#include <boost/beast/websocket/rfc6455.hpp>
#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "internal_connections.h"
#include "internal_frame_budget.h"
#include "internal_pipeline.h"
#include "internal_routes.h"
#include "rgs/view/server.h"

namespace rgs::view {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace detail {

class WsSession;

/// Connections outside a client slot, in total and from one remote address (ConnectionTable).
inline constexpr uint32_t kMaxConnections = 64;
inline constexpr uint32_t kMaxConnectionsPerPeer = 16;
/// Time a connection has for a complete request header, from its start or from the previous response.
inline constexpr std::chrono::seconds kHeaderTimeout{5};
/// Time a response has to be written, and a closing WebSocket's queued messages.
inline constexpr std::chrono::seconds kWriteTimeout{30};
/// Time a WebSocket handshake has: the opening one, and the client's answer to a close.
inline constexpr std::chrono::seconds kCloseTimeout{5};

}  // namespace detail

struct Server::Impl {
  explicit Impl(uint64_t frame_memory) : budget(frame_memory) {}

  detail::ServerState state;
  detail::AdmissionPolicy admission;
  detail::FrameBudget budget;
  detail::ConnectionTable connections{detail::kMaxConnections, detail::kMaxConnectionsPerPeer};
  std::unique_ptr<net::io_context> ioc;
  std::unique_ptr<tcp::acceptor> acceptor;
  std::unique_ptr<net::steady_timer> accept_retry;
  std::vector<std::thread> threads;
  std::string token, url;
  uint16_t port = 0;
  std::atomic<uint32_t> ws_clients{0};     // client slots taken
  std::atomic<uint32_t> open_sessions{0};  // WebSocket sessions, closing ones included
  std::mutex sessions_mutex;
  std::vector<std::weak_ptr<detail::WsSession>> sessions;
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
  void retire(std::unique_ptr<detail::FramePipeline> pipeline);
  void reap();
  /// Remembers `session` for stop() (and forgets the sessions that are gone).
  void add_session(const std::shared_ptr<detail::WsSession>& session);
};

namespace detail {

/// Serves a new TCP connection: admits it to `server.connections` (evicting an idle one when over a bound, or
/// closing it when none can go) and reads its requests.
void serve_connection(tcp::socket socket, Server::Impl& server);

/// Completes the WebSocket upgrade `request` (admitted by admit_request) on `socket` and serves the client;
/// `ticket` is its place among the connections until it takes a client slot.
void serve_websocket(tcp::socket socket, Server::Impl& server, ConnectionTicket ticket,
                     http::request<http::empty_body> request);

/// Closes `session` with `code` after what it is writing (from any thread).
void close_websocket(const std::shared_ptr<WsSession>& session, websocket::close_code code);

}  // namespace detail

}  // namespace rgs::view
