// WebSocket sessions: a client slot, its messages read and validated, hello, errors and frames written one at a
// time, and the idle timeout that frees the slot of a client that stopped talking.
#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <deque>

#include "internal_server.h"

namespace rgs::view::detail {

namespace {

constexpr size_t kMaxQueuedTexts = 16;  // pongs and errors waiting to be written; more pongs are dropped

}  // namespace

class WsSession : public std::enable_shared_from_this<WsSession> {
 public:
  WsSession(tcp::socket&& socket, Server::Impl& server, ConnectionTicket ticket)
      : ws_(std::move(socket)), server_(server), ticket_(std::move(ticket)), timer_(ws_.get_executor()) {
    idle_timeout_ = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
        std::chrono::duration<double>(server.state.options.idle_timeout_s));
    server_.open_sessions.fetch_add(1);
  }

  ~WsSession() {
    server_.retire(std::move(pipeline_));
    release_slot();
    server_.open_sessions.fetch_sub(1);
  }

  void run(http::request<http::empty_body> request) {
    websocket::stream_base::timeout timeouts = websocket::stream_base::timeout::suggested(beast::role_type::server);
    timeouts.handshake_timeout = kCloseTimeout;  // the opening and the closing handshake
    ws_.set_option(timeouts);
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
      queue_text(error_json("busy",
                            "the server has " + std::to_string(server_.state.options.max_clients) +
                                " clients already; try again later",
                            true));
      close_after_writes(websocket::close_code::try_again_later);
      return;
    }
    holds_slot_ = true;
    ticket_.release();  // a client slot bounds it now
    server_.add_session(shared_from_this());
    const auto executor = ws_.get_executor();
    std::weak_ptr<WsSession> weak = weak_from_this();
    pipeline_ = std::make_unique<FramePipeline>(
        server_.state, server_.budget,
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
    last_message_ = std::chrono::steady_clock::now();
    wait_idle(idle_timeout_);
    read();
  }

  // The idle timeout: no message from the client for idle_timeout_ closes the connection.
  void wait_idle(std::chrono::steady_clock::duration delay) {
    timer_.expires_after(delay);
    timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (ec || self->closing_) return;
      const auto idle = std::chrono::steady_clock::now() - self->last_message_;
      if (idle < self->idle_timeout_) {
        self->wait_idle(self->idle_timeout_ - idle);
        return;
      }
      self->close_after_writes(websocket::close_code::normal);
    });
  }

  void release_slot() {
    if (holds_slot_) server_.ws_clients.fetch_sub(1);
    holds_slot_ = false;
  }

  void read() {
    ws_.async_read(buffer_, beast::bind_front_handler(&WsSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t bytes) {
    if (ec) {
      // message_too_big: Beast has already failed the connection with close code 1009.
      if (pipeline_) pipeline_->stop();
      timer_.cancel();
      return;
    }
    if (closing_) return;
    last_message_ = std::chrono::steady_clock::now();
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
    queue_text(error_json(code, why, true));
    close_after_writes(websocket::close_code::policy_error, why);
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
      timer_.cancel();
      return;
    }
    write_next();
  }

  // Closes once what is queued has been written; a client that does not read it within kWriteTimeout (or does
  // not answer the close within kCloseTimeout) is cut off.
  // `why` is also the close frame's reason, cut to the 123 bytes a close frame holds and to whole UTF-8 characters.
  void close_after_writes(websocket::close_code code, const std::string& why = {}) {
    if (closing_) return;
    closing_ = true;
    size_t n = std::min<size_t>(why.size(), 123);
    while (n < why.size() && n > 0 && (static_cast<unsigned char>(why[n]) & 0xC0) == 0x80) --n;
    close_reason_ = websocket::close_reason(code, beast::string_view(why.data(), n));
    release_slot();  // the next client need not wait for this one's close handshake
    if (pipeline_) pipeline_->stop();
    queue_.erase(std::remove_if(queue_.begin() + (queue_.empty() ? 0 : 1), queue_.end(),
                                [](const Outgoing& o) { return o.frame; }),
                 queue_.end());
    timer_.expires_after(kWriteTimeout);
    timer_.async_wait([self = shared_from_this()](beast::error_code ec) {
      if (!ec) beast::get_lowest_layer(self->ws_).close();
    });
    if (queue_.empty()) start_close();
  }

  void start_close() {
    close_started_ = true;
    ws_.async_close(close_reason_, [self = shared_from_this()](beast::error_code) {
      self->timer_.cancel();
    });
  }

  websocket::stream<beast::tcp_stream> ws_;
  Server::Impl& server_;
  ConnectionTicket ticket_;
  net::steady_timer timer_;
  std::chrono::steady_clock::duration idle_timeout_{};
  std::chrono::steady_clock::time_point last_message_;
  beast::flat_buffer buffer_;
  std::deque<Outgoing> queue_;
  std::unique_ptr<FramePipeline> pipeline_;
  bool holds_slot_ = false;
  bool closing_ = false, close_started_ = false;
  websocket::close_reason close_reason_;
};

void serve_websocket(tcp::socket socket, Server::Impl& server, ConnectionTicket ticket,
                     http::request<http::empty_body> request) {
  std::make_shared<WsSession>(std::move(socket), server, std::move(ticket))->run(std::move(request));
}

void close_websocket(const std::shared_ptr<WsSession>& session, websocket::close_code code) {
  session->close_from_outside(code);
}

}  // namespace rgs::view::detail
