// HTTP sessions: a connection's place among the server's connections, its requests read under a header
// deadline, admitted by admit_request (token, Host, Origin, route), answered with the embedded page's files or
// handed over as a WebSocket upgrade.
#include <algorithm>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/post.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>

#include "internal_server.h"
#include "view_assets.h"

namespace rgs::view::detail {

namespace {

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, Server::Impl& server) : stream_(std::move(socket)), server_(server) {}

  void run(ConnectionTicket ticket) {
    ticket_ = std::move(ticket);
    net::dispatch(stream_.get_executor(), beast::bind_front_handler(&HttpSession::read, shared_from_this()));
  }

  // Closes the connection from any thread (it was evicted to make room for a newer one).
  void close_from_outside() {
    net::post(stream_.get_executor(), [self = shared_from_this()] { self->stream_.close(); });
  }

 private:
  void read() {
    ticket_.set_waiting(true);
    parser_.emplace();
    parser_->header_limit(kMaxHeaderBytes);
    parser_->body_limit(0);
    stream_.expires_after(kHeaderTimeout);
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t) {
    ticket_.set_waiting(false);
    if (ec == http::error::header_limit) {
      respond_status(http::status::request_header_fields_too_large, false);
      return;
    }
    if (ec) {
      stream_.socket().shutdown(tcp::socket::shutdown_both, ec);
      return;
    }
    http::request<http::empty_body> request = parser_->release();
    const Admission admission = admit_request(request, server_.admission);
    switch (admission.kind) {
      case Admission::Kind::kForbidden:
        respond_status(http::status::forbidden, false, admission.why);
        return;
      case Admission::Kind::kBadRequest:
        respond_status(http::status::bad_request, request.keep_alive(), admission.why);
        return;
      case Admission::Kind::kMethodNotAllowed:
        respond_status(http::status::method_not_allowed, request.keep_alive());
        return;
      case Admission::Kind::kNotFound:
        respond_status(http::status::not_found, request.keep_alive());
        return;
      case Admission::Kind::kWebSocket:
        stream_.expires_never();
        serve_websocket(stream_.release_socket(), server_, std::move(ticket_), std::move(request));
        return;
      case Admission::Kind::kAsset:
        break;
    }
    const Asset& asset = *admission.asset;
    auto response = std::make_shared<http::response<http::string_body>>(http::status::ok, request.version());
    response->set(http::field::server, "rgs-view");
    response->set(http::field::content_type, std::string(asset.content_type.data(), asset.content_type.size()));
    response->set(http::field::cache_control, "no-store");
    response->set("X-Content-Type-Options", "nosniff");
    response->set("Referrer-Policy", "no-referrer");  // the token stays out of other sites' logs
    if (request.method() == http::verb::get) {
      response->body().assign(reinterpret_cast<const char*>(asset.data), asset.size);
    }
    response->prepare_payload();
    if (request.method() == http::verb::head) response->content_length(asset.size);
    response->keep_alive(request.keep_alive());
    send(response);
  }

  void respond_status(http::status status, bool keep_alive, std::string_view why = {}) {
    auto response = std::make_shared<http::response<http::string_body>>(status, 11);
    response->set(http::field::server, "rgs-view");
    response->set(http::field::content_type, "text/plain; charset=utf-8");
    response->body() = std::to_string(static_cast<unsigned>(status)) + " " +
                       std::string(http::obsolete_reason(status)) + (why.empty() ? "" : ": ") + std::string(why) +
                       "\n";
    response->prepare_payload();
    response->keep_alive(keep_alive);
    send(response);
  }

  void send(std::shared_ptr<http::response<http::string_body>> response) {
    const bool keep_alive = response->keep_alive();
    // Until the client reads it, the connection waits for the client, and a newer one may take its place: a client
    // that pipelines requests and never reads would otherwise hold its place until the write timeout.
    ticket_.set_waiting(true);
    stream_.expires_after(kWriteTimeout);
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
  ConnectionTicket ticket_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::empty_body>> parser_;
};

// The key a connection is counted under: its address, or for IPv6 its /64 network (one host usually has all of
// one /64, and can connect from any address in it).
std::string peer_key(const net::ip::address& address) {
  if (!address.is_v6()) return address.to_string();
  const net::ip::address_v6 v6 = address.to_v6();
  if (v6.is_v4_mapped()) return net::ip::make_address_v4(net::ip::v4_mapped, v6).to_string();
  net::ip::address_v6::bytes_type bytes = v6.to_bytes();
  std::fill(bytes.begin() + 8, bytes.end(), 0);
  return net::ip::address_v6(bytes).to_string() + "/64";
}

}  // namespace

void serve_connection(tcp::socket socket, Server::Impl& server) {
  beast::error_code ec;
  const tcp::endpoint peer = socket.remote_endpoint(ec);
  if (ec) return;  // already gone
  // Frames go out as soon as they are written: with Nagle's algorithm a frame's last segment waits for the
  // client's delayed acknowledgement of the one before (about 40 ms on Linux).
  socket.set_option(tcp::no_delay(true), ec);
  auto session = std::make_shared<HttpSession>(std::move(socket), server);
  ConnectionTable::Close evicted;
  const uint64_t id = server.connections.admit(
      peer_key(peer.address()),
      [weak = std::weak_ptr<HttpSession>(session)] {
        if (auto s = weak.lock()) s->close_from_outside();
      },
      &evicted);
  if (evicted) evicted();
  if (id == 0) return;  // every connection over the bound is busy: this one is closed
  session->run(ConnectionTicket(&server.connections, id));
}

}  // namespace rgs::view::detail
