// What a hostile web page or client can do to an rgs::view server on 127.0.0.1 (CPU backend): upgrades from
// another page's origin or by another host name are refused before any message, idle TCP connections and idle
// WebSockets cannot lock other clients out, and clients asking for 7680 x 4320 frames without reading them keep
// the server within its frame memory budget.
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/view/server.h"
#include "test_data.h"
#include "view_server_client.h"

namespace {

using namespace rgs;
using namespace rgs::test;
using namespace std::chrono_literals;

// A TCP connection to the server that sends nothing, from `from` (any address of 127.0.0.0/8).
std::unique_ptr<tcp::socket> idle_connection(net::io_context& ioc, uint16_t port, const char* from = "127.0.0.1") {
  auto socket = std::make_unique<tcp::socket>(ioc);
  socket->open(tcp::v4());
  socket->bind(tcp::endpoint(net::ip::make_address(from), 0));
  socket->connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
  socket->non_blocking(true);
  return socket;
}

// The server has not closed `socket` (nothing to read yet, no end of stream).
bool still_open(tcp::socket& socket) {
  char byte = 0;
  beast::error_code ec;
  socket.read_some(net::buffer(&byte, 1), ec);
  return ec == net::error::would_block;
}

size_t count_open(std::vector<std::unique_ptr<tcp::socket>>& sockets) {
  return size_t(std::count_if(sockets.begin(), sockets.end(), [](auto& s) { return still_open(*s); }));
}

// Resident memory of this process (the server runs in it), in bytes.
uint64_t resident_bytes() {
  std::ifstream statm("/proc/self/statm");
  uint64_t size = 0, resident = 0;
  statm >> size >> resident;
  return resident * uint64_t(sysconf(_SC_PAGESIZE));
}

// The largest resident size seen while it runs, sampled every 10 ms.
class ResidentPeak {
 public:
  ResidentPeak() : thread_([this] {
    while (!done_) {
      peak_ = std::max<uint64_t>(peak_, resident_bytes());
      std::this_thread::sleep_for(10ms);
    }
  }) {}
  ~ResidentPeak() { finish(); }
  uint64_t finish() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
    return peak_;
  }

 private:
  std::atomic<bool> done_{false};
  std::atomic<uint64_t> peak_{0};
  std::thread thread_;
};

}  // namespace

TEST_CASE("server: an upgrade from another page's origin or by another host name gets 403 and no message") {
  view::Server server = start({guitar()});
  const uint16_t port = server.port();
  const std::string own = "http://127.0.0.1:" + std::to_string(port);
  for (const std::string& origin : {own, "http://localhost:" + std::to_string(port), std::string()}) {
    CAPTURE(origin);
    WsClient client;
    REQUIRE(client.connect(port, "/ws", origin) == 101);
    CHECK(client.read_json()["type"] == "hello");
  }
  // Browsers send the page's origin with an upgrade, and apply no same-origin rule to WebSockets.
  for (const std::string& origin : {std::string("http://evil.example"), std::string("null"), std::string("file://"),
                                    "http://evil.example:" + std::to_string(port),
                                    "http://127.0.0.1:" + std::to_string(port + 1), "https://127.0.0.1:" +
                                    std::to_string(port)}) {
    CAPTURE(origin);
    const Reply reply = http_request(port, "/ws", http::verb::get, true, {{"Origin", origin}});
    CHECK(reply.status == 403);
    CHECK(reply.body.find("Origin") != std::string::npos);
    CHECK(reply.body.find("hello") == std::string::npos);
  }
  // DNS rebinding: a page at evil.example whose name now points here is refused by its Host.
  const std::string rebound = "evil.example:" + std::to_string(port);
  CHECK(http_request(port, "/", http::verb::get, false, {{"Host", rebound}}).status == 403);
  CHECK(http_request(port, "/app.js", http::verb::get, false, {{"Host", rebound}}).status == 403);
  CHECK(http_request(port, "/ws", http::verb::get, true, {{"Host", rebound}, {"Origin", "http://" + rebound}})
            .status == 403);
  CHECK(http_request(port, "/", http::verb::get, false, {{"Host", "127.0.0.1"}}).status == 403);  // port 80
  CHECK(http_request(port, "/", http::verb::get, false, {{"Host", ""}}).status == 403);
  CHECK(http_request(port, "/", http::verb::get, false, {{"Host", "localhost:" + std::to_string(port)}}).status ==
        200);
  CHECK(server.clients() == 0);

  // With a token: any Host (the server is reached by name), the token on the upgrade too, the Origin of that Host.
  view::ServerOptions options;
  options.token = "0123456789abcdef-token";
  view::Server named = start({guitar()}, options);
  const std::string host = "viewer.example:" + std::to_string(named.port());
  const std::string ws = "/ws?token=" + options.token;
  CHECK(http_request(named.port(), "/?token=" + options.token, http::verb::get, false, {{"Host", host}}).status ==
        200);
  CHECK(http_request(named.port(), "/ws", http::verb::get, true, {{"Host", host}, {"Origin", "http://" + host}})
            .status == 403);
  CHECK(http_request(named.port(), ws, http::verb::get, true, {{"Host", host}, {"Origin", "http://evil.example"}})
            .status == 403);
  WsClient client;
  REQUIRE(client.connect(named.port(), ws, "http://" + host, host) == 101);
  CHECK(client.read_json()["type"] == "hello");
}

TEST_CASE("server: a token is at least 16 characters") {
  view::ServerOptions options;
  options.token = "fifteen-chars-x";
  CHECK(view::Server::start({guitar()}, options).status().code() == StatusCode::kInvalidArgument);
  options.token = "sixteen-chars-xy";
  CHECK(view::Server::start({guitar()}, options).ok());
}

TEST_CASE("server: a port in use is named, with the option that chooses another") {
  view::Server first = start({guitar()});
  view::ServerOptions options;
  options.port = first.port();
  const auto second = view::Server::start({guitar()}, options);
  REQUIRE_FALSE(second.ok());
  CHECK(second.status().code() == StatusCode::kIoError);
  const std::string message = second.status().message();
  CHECK_MESSAGE(message.find("port " + std::to_string(first.port()) + " of 127.0.0.1 is in use") != std::string::npos,
                message);
  CHECK_MESSAGE(message.find("(--port)") != std::string::npos, message);
}

TEST_CASE("server: idle TCP connections cannot lock clients out, and are closed 5 s after their last request") {
  view::Server server = start({guitar()});
  const uint16_t port = server.port();
  net::io_context ioc;
  std::vector<std::unique_ptr<tcp::socket>> other_peer, flood;
  for (int i = 0; i < 10; ++i) other_peer.push_back(idle_connection(ioc, port, "127.0.0.3"));
  for (int i = 0; i < 100; ++i) flood.push_back(idle_connection(ioc, port));
  // A real client still gets in, by HTTP and WebSocket, and gets frames.
  CHECK(http_request(port, "/").status == 200);
  WsClient client;
  REQUIRE(client.connect(port, "/ws") == 101);
  const json hello = client.read_json();
  client.send(view_json(small_camera(hello, 64, 36), 1, "jpeg").dump());
  CHECK(read_frame(client).header["seq"] == 1);
  // One address holds at most 16 connections outside a client slot; the other peer's stayed.
  std::this_thread::sleep_for(200ms);
  CHECK(count_open(flood) <= 16);
  CHECK(count_open(other_peer) == 10);
  // A connection that sends no request header is closed after the header deadline (5 s), not held.
  const auto begin = std::chrono::steady_clock::now();
  while (still_open(*flood.back()) && std::chrono::steady_clock::now() - begin < 10s) std::this_thread::sleep_for(50ms);
  CHECK_FALSE(still_open(*flood.back()));
  CHECK(std::chrono::steady_clock::now() - begin < 7s);
  CHECK(count_open(other_peer) == 0);
  // The WebSocket client, upgraded, is not subject to it.
  client.send(view_json(small_camera(hello, 64, 36), 2, "jpeg").dump());
  CHECK(read_frame(client).header["seq"] == 2);
}

TEST_CASE("server: connections that pipeline requests and never read the responses cannot lock clients out") {
  view::Server server = start({guitar()});
  const uint16_t port = server.port();
  std::string requests;
  for (int i = 0; i < 64; ++i) requests += "GET /app.js HTTP/1.1\r\nHost: " + own_host(port) + "\r\n\r\n";
  // 16 connections from the client's own address (the bound of one address), each sending requests as fast as the
  // server reads them and never reading a response; a closed one is opened again at once.
  std::atomic<bool> done{false};
  std::atomic<int> blocked{0}, reopened{0};
  std::thread attackers([&] {
    net::io_context ioc;
    std::vector<std::unique_ptr<tcp::socket>> sockets(16);
    while (!done) {
      int full = 0;
      for (auto& socket : sockets) {
        beast::error_code ec;
        if (socket == nullptr) {
          socket = idle_connection(ioc, port);
        } else {
          socket->write_some(net::buffer(requests), ec);
        }
        if (ec == net::error::would_block) {
          ++full;
        } else if (ec) {
          socket.reset();
          ++reopened;
        }
      }
      blocked = full;
      std::this_thread::sleep_for(1ms);
    }
  });
  // A client asking for the page is answered within a few seconds, well before the 30 s write timeout would free a
  // place, each time the 16 have filled their sockets with responses again (the server stopped reading them).
  int answered = 0, attacked = 0;
  for (int request = 0; request < 5; ++request) {
    const auto begin = std::chrono::steady_clock::now();
    while (blocked < 16 && std::chrono::steady_clock::now() - begin < 30s) std::this_thread::sleep_for(10ms);
    attacked += blocked == 16 ? 1 : 0;
    const auto asked = std::chrono::steady_clock::now();
    bool ok = false;
    while (!ok && std::chrono::steady_clock::now() - asked < 5s) {
      net::io_context ioc;
      tcp::socket socket(ioc);
      socket.connect(tcp::endpoint(net::ip::make_address("127.0.0.1"), port));
      Watchdog watchdog(socket.native_handle(), 2000ms);
      http::request<http::empty_body> get(http::verb::get, "/", 11);
      get.set(http::field::host, own_host(port));
      beast::error_code ec;
      http::write(socket, get, ec);
      beast::flat_buffer buffer;
      http::response<http::string_body> response;
      if (!ec) http::read(socket, buffer, response, ec);
      ok = !ec && response.result_int() == 200;
      if (!ok) std::this_thread::sleep_for(50ms);
    }
    answered += ok ? 1 : 0;
  }
  done = true;
  attackers.join();
  MESSAGE(answered << " of 5 requests answered; the attackers opened " << reopened.load() << " connections again");
  CHECK(attacked == 5);
  CHECK(answered == 5);
}

TEST_CASE("server: idle WebSocket clients lose their slot after the idle timeout, a client that pings keeps it") {
  view::ServerOptions options;
  options.idle_timeout_s = 1.0;
  CHECK(view::ServerOptions().idle_timeout_s == 120);
  view::Server server = start({guitar()}, options);
  const uint16_t port = server.port();
  std::vector<std::unique_ptr<WsClient>> idle;
  for (int i = 0; i < 7; ++i) {
    idle.push_back(std::make_unique<WsClient>());
    REQUIRE(idle.back()->connect(port, "/ws") == 101);
    REQUIRE(idle.back()->read_json()["type"] == "hello");
  }
  WsClient pinging;
  REQUIRE(pinging.connect(port, "/ws") == 101);
  const json hello = pinging.read_json();
  CHECK(server.clients() == 8);
  {
    WsClient ninth;
    REQUIRE(ninth.connect(port, "/ws") == 101);
    CHECK(ninth.read_json()["code"] == "busy");
  }
  const auto begin = std::chrono::steady_clock::now();
  while (std::chrono::steady_clock::now() - begin < 2500ms) {
    pinging.send(R"({"type":"ping"})");
    CHECK(pinging.read_json()["type"] == "pong");
    std::this_thread::sleep_for(300ms);
  }
  for (auto& client : idle) {
    Watchdog watchdog(client->ws.next_layer().native_handle(), 5000ms);
    std::string rest;
    CHECK_FALSE(client->read(&rest));
    CHECK(client->ws.reason().code == websocket::close_code::normal);
  }
  CHECK(server.clients() == 1);
  WsClient fresh;
  REQUIRE(fresh.connect(port, "/ws") == 101);
  CHECK(fresh.read_json()["type"] == "hello");
  fresh.send(view_json(small_camera(hello, 64, 36), 3, "jpeg").dump());
  CHECK(read_frame(fresh).header["seq"] == 3);
  pinging.send(view_json(small_camera(hello, 64, 36), 4, "jpeg").dump());
  CHECK(read_frame(pinging).header["seq"] == 4);
}

TEST_CASE("server: 8 clients asking for 7680 x 4320 frames and never reading stay within the frame memory budget") {
  // 256 Gaussians: an 8K frame renders in seconds on the CPU, with its full per-pixel memory. All clients' views
  // arrive at once, so without a shared bound their renders would hold their memory at the same time.
  const api::Scene scene = cpu_scene(test::repo_path("tests/data/interop/guitar_256.ply"));
  view::ServerOptions options;
  options.frame_memory = uint64_t(1536) << 20;  // one 8K CPU JPEG frame (1.24 GB) at a time
  options.max_clients = 9;
  CHECK(view::ServerOptions().frame_memory == uint64_t(2560) << 20);
  view::Server server = start({scene}, options);
  const uint64_t before = resident_bytes();
  ResidentPeak resident;
  std::vector<std::unique_ptr<WsClient>> stuck;
  json hello;
  for (int i = 0; i < 8; ++i) {
    stuck.push_back(std::make_unique<WsClient>());
    REQUIRE(stuck.back()->connect(server.port(), "/ws") == 101);
    hello = stuck.back()->read_json();
    for (uint64_t seq = 0; seq < 3; ++seq) {
      json view = view_json(small_camera(hello, 7680, 4320), seq, "jpeg");
      view["quality"] = 100;
      stuck.back()->send(view.dump());
    }
  }
  // Another client is still served meanwhile.
  WsClient reader;
  REQUIRE(reader.connect(server.port(), "/ws") == 101);
  REQUIRE(reader.read_json()["type"] == "hello");
  reader.send(view_json(small_camera(hello, 320, 180), 7, "jpeg").dump());
  {
    Watchdog watchdog(reader.ws.next_layer().native_handle(), 30000ms);
    CHECK(read_frame(reader).header["seq"] == 7);
  }
  // Until four 8K frames have been sent (they wait, unread, in the clients' sockets). Each client's CPU renderer
  // keeps its 660 MB of planes after its frame: they count in the budget until freed, or four would hold 2.6 GB.
  const auto sent = [&] {
    return std::count_if(stuck.begin(), stuck.end(), [](auto& c) { return c->ws.next_layer().available() > 10000; });
  };
  const auto begin = std::chrono::steady_clock::now();
  while (sent() < 4 && std::chrono::steady_clock::now() - begin < 300s) std::this_thread::sleep_for(50ms);
  CHECK(sent() >= 4);
  const uint64_t peak = resident.finish();
  const uint64_t grown = peak > before ? peak - before : 0;
  MESSAGE("resident memory grew by " << (grown >> 20) << " MiB; frames held at most "
                                     << (server.frame_memory_peak() >> 20) << " MiB of "
                                     << (options.frame_memory >> 20) << " MiB");
  CHECK(server.frame_memory_peak() <= options.frame_memory);
  CHECK(server.frame_memory_peak() > uint64_t(1) << 30);  // an 8K frame was rendered
  CHECK(grown < options.frame_memory + (uint64_t(384) << 20));
}

TEST_CASE("server: a frame that needs more than the whole frame memory fails alone, smaller views go on") {
  view::ServerOptions options;
  options.frame_memory = uint64_t(64) << 20;
  view::Server server = start({guitar()}, options);
  WsClient client;
  REQUIRE(client.connect(server.port(), "/ws") == 101);
  const json hello = client.read_json();
  client.send(view_json(small_camera(hello, 7680, 4320), 1, "lossless").dump());
  const json error = client.read_json();
  CHECK(error["type"] == "error");
  CHECK(error["code"] == "render_failed");
  CHECK(error["fatal"] == false);
  CHECK(error["message"].get<std::string>().find("frame memory") != std::string::npos);
  client.send(view_json(small_camera(hello, 64, 36), 2, "jpeg").dump());
  CHECK(read_frame(client).header["seq"] == 2);
  CHECK(server.frame_memory_held() < options.frame_memory);
  view::ServerOptions tiny;
  tiny.frame_memory = uint64_t(8) << 20;
  CHECK(view::Server::start({guitar()}, tiny).status().code() == StatusCode::kInvalidArgument);
}
