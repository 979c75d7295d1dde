// Beast HTTP and WebSocket clients of an rgs::view server on 127.0.0.1 (CPU backend), shared by the viewer suite's
// server tests: one request and its status, a WebSocket client, the frame message's parts, view messages.
#pragma once

#include <sys/socket.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <doctest/doctest.h>
#include <nlohmann/json.hpp>

#include "rgs/api/scene.h"
#include "rgs/view/server.h"
#include "test_data.h"

namespace rgs::test {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using nlohmann::json;

inline api::Scene cpu_scene(const std::string& path, bool quantize = true) {
  api::LoadOptions cpu;
  cpu.device = api::Device::kCpu;
  cpu.quantize_other_formats = quantize;
  auto scene = view::load_view_scene(path, cpu);
  REQUIRE(scene.ok());
  return *scene;
}

inline const api::Scene& guitar() {
  static const api::Scene scene = cpu_scene(test::repo_path("samples/guitar.ply"));
  return scene;
}

/// A server on 127.0.0.1 and any free port.
inline view::Server start(std::vector<api::Scene> scenes, view::ServerOptions options = {}) {
  options.port = 0;
  auto server = view::Server::start(std::move(scenes), options);
  REQUIRE_MESSAGE(server.ok(), server.status().message());
  return std::move(*server);
}

/// The Host header a browser sends for the server's own page, "127.0.0.1:PORT".
inline std::string own_host(uint16_t port) { return "127.0.0.1:" + std::to_string(port); }

struct Reply {
  unsigned status = 0;
  std::string content_type, body;
};

/// Header fields of a request, by name; Host defaults to own_host(port), an empty value leaves the field out.
using Fields = std::map<std::string, std::string>;

/// One request; `upgrade` adds the WebSocket upgrade headers (Beast's client does not report a declined
/// handshake's status).
inline Reply http_request(uint16_t port, const std::string& target, http::verb verb = http::verb::get,
                          bool upgrade = false, const Fields& fields = {}) {
  net::io_context ioc;
  tcp::socket socket(ioc);
  socket.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  http::request<http::empty_body> request(verb, target, 11);
  request.set(http::field::host, own_host(port));
  if (upgrade) {
    request.set(http::field::connection, "Upgrade");
    request.set(http::field::upgrade, "websocket");
    request.set(http::field::sec_websocket_version, "13");
    request.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
  }
  for (const auto& [name, value] : fields) {
    if (value.empty()) {
      request.erase(name);
    } else {
      request.set(name, value);
    }
  }
  http::write(socket, request);
  beast::flat_buffer buffer;
  http::response_parser<http::string_body> parser;
  parser.skip(verb == http::verb::head);
  http::read_header(socket, buffer, parser);
  if (parser.get().result() != http::status::switching_protocols) http::read(socket, buffer, parser);
  const auto& response = parser.get();
  return {response.result_int(), std::string(response[http::field::content_type]), response.body()};
}

/// A WebSocket client; connect() reports the handshake's HTTP status (101 when upgraded).
struct WsClient {
  net::io_context ioc;
  websocket::stream<tcp::socket> ws{ioc};
  beast::flat_buffer buffer;

  /// `host`: the Host header (empty: own_host(port)); `origin`: an Origin header (empty: none, as non-browser
  /// clients send).
  unsigned connect(uint16_t port, const std::string& target, const std::string& origin = "",
                   const std::string& host = "") {
    ws.next_layer().connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
    if (!origin.empty()) {
      ws.set_option(websocket::stream_base::decorator(
          [origin](websocket::request_type& request) { request.set(http::field::origin, origin); }));
    }
    websocket::response_type response;
    beast::error_code ec;
    ws.handshake(response, host.empty() ? own_host(port) : host, target, ec);
    return response.result_int();
  }
  // The next message: its text or bytes; `binary` says which; false at a close (ws.reason() has the code).
  bool read(std::string* out, bool* binary = nullptr) {
    beast::error_code ec;
    buffer.clear();
    ws.read(buffer, ec);
    if (ec) return false;
    *out = beast::buffers_to_string(buffer.data());
    if (binary) *binary = ws.got_binary();
    return true;
  }
  json read_json() {
    std::string text;
    bool binary = true;
    REQUIRE(read(&text, &binary));
    REQUIRE_FALSE(binary);
    return json::parse(text);
  }
  void send(const std::string& text) {
    ws.text(true);
    ws.write(net::buffer(text));
  }
};

/// Shuts a socket down both ways unless destroyed within `limit`, so that a blocking read that would wait forever
/// (the behaviour under test missing) fails instead.
class Watchdog {
 public:
  Watchdog(int fd, std::chrono::milliseconds limit)
      : thread_([this, fd, limit] {
          std::unique_lock<std::mutex> lock(mutex_);
          if (!changed_.wait_for(lock, limit, [this] { return done_; })) ::shutdown(fd, SHUT_RDWR);
        }) {}
  ~Watchdog() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    changed_.notify_all();
    thread_.join();
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  bool done_ = false;
  std::thread thread_;
};

struct Frame {
  json header;
  std::vector<std::vector<uint8_t>> images;
};

/// The next frame message (text messages before it must not be errors).
inline Frame read_frame(WsClient& client) {
  std::string message;
  bool binary = false;
  for (;;) {  // skip text (pongs)
    REQUIRE(client.read(&message, &binary));
    if (binary) break;
    const json text = json::parse(message);
    REQUIRE_MESSAGE(text["type"] != "error", text.dump());
  }
  REQUIRE(message.size() >= 4);
  const uint32_t n = uint32_t(uint8_t(message[0])) | uint32_t(uint8_t(message[1])) << 8 |
                     uint32_t(uint8_t(message[2])) << 16 | uint32_t(uint8_t(message[3])) << 24;
  REQUIRE(4 + n <= message.size());
  Frame frame;
  frame.header = json::parse(message.substr(4, n));
  size_t at = 4 + n;
  for (const json& image : frame.header["images"]) {
    const size_t bytes = image["bytes"].get<size_t>();
    REQUIRE(at + bytes <= message.size());
    frame.images.emplace_back(message.begin() + long(at), message.begin() + long(at + bytes));
    at += bytes;
  }
  CHECK(at == message.size());
  return frame;
}

inline json view_json(const json& camera, uint64_t seq, const std::string& encoding,
                      const std::string& compare = "off") {
  return {{"type", "view"}, {"seq", seq},          {"camera", camera}, {"encoding", encoding},
          {"compare", compare}, {"background", {0.2, 0.1, 0.0}}};
}

/// hello's home camera at w × h (focal lengths scaled with the width).
inline json small_camera(const json& hello, uint32_t w, uint32_t h) {
  json camera = hello["home_camera"];
  const double scale = double(w) / camera["width"].get<double>();
  camera["fx"] = camera["fx"].get<double>() * scale;
  camera["fy"] = camera["fy"].get<double>() * scale;
  camera["width"] = w;
  camera["height"] = h;
  return camera;
}

}  // namespace rgs::test
