// The server's decisions without a socket: which requests admit_request lets through (token, Host, Origin, route),
// how the connection table evicts and bounds, and how the frame memory budget grants, waits and counts.
#include <atomic>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include <boost/beast/http.hpp>
#include <doctest/doctest.h>

#include "internal_connections.h"
#include "internal_frame_budget.h"
#include "internal_routes.h"
#include "rgs/view/server.h"

namespace {

using namespace rgs::view;
using namespace rgs::view::detail;
namespace http = boost::beast::http;
using Kind = Admission::Kind;

constexpr uint16_t kPort = 8080;

// A GET of `target`; `upgrade` adds the WebSocket upgrade headers; fields with empty values are left out.
http::request_header<> request(const std::string& target, const std::string& host, const std::string& origin = "",
                               bool upgrade = false) {
  http::request_header<> r;
  r.method(http::verb::get);
  r.target(target);
  r.version(11);
  if (!host.empty()) r.set(http::field::host, host);
  if (!origin.empty()) r.set(http::field::origin, origin);
  if (upgrade) {
    r.set(http::field::connection, "Upgrade");
    r.set(http::field::upgrade, "websocket");
    r.set(http::field::sec_websocket_version, "13");
    r.set(http::field::sec_websocket_key, "dGhlIHNhbXBsZSBub25jZQ==");
  }
  return r;
}

Kind upgrade_kind(const AdmissionPolicy& policy, const std::string& target, const std::string& host,
                  const std::string& origin) {
  return admit_request(request(target, host, origin, true), policy).kind;
}

}  // namespace

TEST_CASE("admission: on loopback without a token, only the server's own Host and Origin are admitted") {
  const AdmissionPolicy policy = make_admission_policy("127.0.0.1", kPort, "");
  CHECK(admit_request(request("/", "127.0.0.1:8080"), policy).kind == Kind::kAsset);
  CHECK(admit_request(request("/app.js", "LOCALHOST:8080"), policy).kind == Kind::kAsset);
  CHECK(admit_request(request("/", "[::1]:8080"), policy).kind == Kind::kAsset);
  // DNS rebinding: the attacker's name reaches this address; a missing Host, another port or name are refused.
  for (const char* host : {"evil.example:8080", "evil.example", "127.0.0.1", "127.0.0.1:8081", "localhost.:8080",
                           "127.0.0.1:8080:8080", "127.0.0.1:", "user@127.0.0.1:8080", "127.0.0.2:8080", ""}) {
    CAPTURE(host);
    const Admission admission = admit_request(request("/", host), policy);
    CHECK(admission.kind == Kind::kForbidden);
    CHECK(admission.why.find("Host") != std::string_view::npos);
    CHECK(upgrade_kind(policy, "/ws", host, "http://127.0.0.1:8080") == Kind::kForbidden);
  }
  // The page's own origin, by any of the loopback names; none at all (a non-browser client).
  for (const char* origin : {"http://127.0.0.1:8080", "http://localhost:8080", "http://[::1]:8080",
                             "HTTP://LocalHost:8080", ""}) {
    CAPTURE(origin);
    CHECK(upgrade_kind(policy, "/ws", "127.0.0.1:8080", origin) == Kind::kWebSocket);
  }
  // Any other web page: browsers send its origin with the upgrade.
  for (const char* origin : {"http://evil.example", "http://evil.example:8080", "null", "file://",
                             "https://127.0.0.1:8080", "http://127.0.0.1:8081", "http://127.0.0.1",
                             "http://127.0.0.1:8080/", "http://user@127.0.0.1:8080", "ws://127.0.0.1:8080",
                             "http://127.0.0.1:8080.evil.example", "http://127.0.0.1:08080x"}) {
    CAPTURE(origin);
    const Admission admission = admit_request(request("/ws", "127.0.0.1:8080", origin, true), policy);
    CHECK(admission.kind == Kind::kForbidden);
    CHECK(admission.why.find("Origin") != std::string_view::npos);
  }
  CHECK(admit_request(request("/ws", "127.0.0.1:8080"), policy).kind == Kind::kBadRequest);  // no upgrade
  auto twice = request("/ws", "127.0.0.1:8080", "http://127.0.0.1:8080", true);
  twice.insert(http::field::origin, "http://evil.example");
  CHECK(admit_request(twice, policy).kind == Kind::kBadRequest);
  auto hosts = request("/", "127.0.0.1:8080");
  hosts.insert(http::field::host, "evil.example:8080");
  CHECK(admit_request(hosts, policy).kind == Kind::kBadRequest);
  CHECK(admit_request(request("/nope", "127.0.0.1:8080"), policy).kind == Kind::kNotFound);
  auto post = request("/", "127.0.0.1:8080");
  post.method(http::verb::post);
  CHECK(admit_request(post, policy).kind == Kind::kMethodNotAllowed);
  // Port 80 may be left out, as browsers do.
  const AdmissionPolicy eighty = make_admission_policy("localhost", 80, "");
  CHECK(admit_request(request("/", "localhost"), eighty).kind == Kind::kAsset);
  CHECK(upgrade_kind(eighty, "/ws", "127.0.0.1", "http://localhost") == Kind::kWebSocket);
}

TEST_CASE("admission: with a token, every request and upgrade needs it, any Host, the Origin of that Host") {
  const std::string token = "0123456789abcdef0123456789abcdef";
  const AdmissionPolicy policy = make_admission_policy("0.0.0.0", kPort, token);
  const std::string ws = "/ws?token=" + token;
  CHECK(admit_request(request("/?token=" + token, "myhost.lan:8080"), policy).kind == Kind::kAsset);
  CHECK(admit_request(request("/", "127.0.0.1:8080"), policy).kind == Kind::kForbidden);
  CHECK(admit_request(request("/?token=" + token.substr(1), "127.0.0.1:8080"), policy).kind == Kind::kForbidden);
  CHECK(upgrade_kind(policy, "/ws", "127.0.0.1:8080", "") == Kind::kForbidden);
  CHECK(upgrade_kind(policy, "/ws", "127.0.0.1:8080", "http://127.0.0.1:8080") == Kind::kForbidden);
  CHECK(upgrade_kind(policy, "/ws?token=x", "127.0.0.1:8080", "") == Kind::kForbidden);
  // The page reached by a name of this machine: its origin is that name.
  CHECK(upgrade_kind(policy, ws, "myhost.lan:8080", "http://myhost.lan:8080") == Kind::kWebSocket);
  CHECK(upgrade_kind(policy, ws, "myhost.lan", "https://myhost.lan") == Kind::kWebSocket);  // behind a TLS proxy
  CHECK(upgrade_kind(policy, ws, "0.0.0.0:8080", "http://0.0.0.0:8080") == Kind::kWebSocket);
  CHECK(upgrade_kind(policy, ws, "127.0.0.1:8080", "http://localhost:8080") == Kind::kWebSocket);
  CHECK(upgrade_kind(policy, ws, "myhost.lan:8080", "") == Kind::kWebSocket);
  // Another page, even one that learned the token, is not this server's page.
  CHECK(upgrade_kind(policy, ws, "myhost.lan:8080", "http://evil.example") == Kind::kForbidden);
  CHECK(upgrade_kind(policy, ws, "myhost.lan:8080", "http://myhost.lan:8081") == Kind::kForbidden);
  CHECK(upgrade_kind(policy, ws, "myhost.lan:8080", "null") == Kind::kForbidden);
  CHECK(upgrade_kind(policy, ws, "myhost.lan:8080", "ftp://myhost.lan:8080") == Kind::kForbidden);
}

TEST_CASE("admission: authorities parse names, bracketed IPv6 and ports, nothing else") {
  const auto parse = [](const char* text) { return parse_authority(text, 80); };
  CHECK(parse("Example.COM:8080") == Authority{"example.com", 8080});
  CHECK(parse("example.com") == Authority{"example.com", 80});
  CHECK(parse("[::1]:9") == Authority{"[::1]", 9});
  CHECK(parse("[::1]") == Authority{"[::1]", 80});
  for (const char* bad : {"", ":80", "a:", "a:0", "a:65536", "a:123456", "a:8o", "::1:80", "[::1", "[::1]x",
                          "[::1]:", "[]:80", "a b:80", "a\x7f:80", "a:+80"}) {
    CAPTURE(bad);
    CHECK_FALSE(parse(bad).has_value());
  }
  const AdmissionPolicy v6 = make_admission_policy("::1", 7000, "");
  CHECK(v6.own_names == std::vector<std::string>{"127.0.0.1", "localhost", "[::1]"});
  const AdmissionPolicy named = make_admission_policy("MyHost", 7000, "0123456789abcdef");
  CHECK(named.own_names.back() == "myhost");
}

TEST_CASE("connection table: a new connection over a bound evicts the longest waiting one, of its own peer first") {
  ConnectionTable table(4, 2);
  std::vector<std::string> closed;
  const auto closer = [&](const std::string& name) { return [&closed, name] { closed.push_back(name); }; };
  ConnectionTable::Close evicted;
  const uint64_t a1 = table.admit("a", closer("a1"), &evicted);
  const uint64_t a2 = table.admit("a", closer("a2"), &evicted);
  CHECK(!evicted);
  // Peer a is at its bound: its longest waiting connection makes room.
  const uint64_t a3 = table.admit("a", closer("a3"), &evicted);
  REQUIRE(evicted);
  evicted();
  evicted = nullptr;
  CHECK(closed == std::vector<std::string>{"a1"});
  CHECK(table.count("a") == 2);
  table.remove(a1);  // gone already: ignored
  CHECK(table.size() == 2);
  // A connection answering a request (not waiting) is not evicted; the total bound evicts across peers.
  table.set_waiting(a2, false);
  const uint64_t b1 = table.admit("b", closer("b1"), &evicted);
  const uint64_t b2 = table.admit("b", closer("b2"), &evicted);
  CHECK(!evicted);
  CHECK(table.size() == 4);
  const uint64_t c1 = table.admit("c", closer("c1"), &evicted);
  REQUIRE(evicted);
  evicted();
  evicted = nullptr;
  CHECK(closed.back() == "a3");  // a2 is busy; a3 has waited longest
  table.set_waiting(b1, false);
  table.set_waiting(b2, false);
  table.set_waiting(c1, false);
  // Every connection busy: the new one is refused.
  CHECK(table.admit("d", closer("d1"), &evicted) == 0);
  CHECK(!evicted);
  // Waiting again restarts the wait: b1 has now waited less than b2.
  table.set_waiting(b2, true);
  table.set_waiting(b1, true);
  CHECK(table.admit("d", closer("d1"), &evicted) != 0);
  REQUIRE(evicted);
  evicted();
  CHECK(closed.back() == "b2");
  {
    ConnectionTicket ticket(&table, a2);
    ConnectionTicket moved = std::move(ticket);
    CHECK(table.count("a") == 1);
  }
  CHECK(table.count("a") == 0);
  CHECK(a3 != 0);
}

TEST_CASE("frame budget: grants up to its capacity, waits for released bytes, gives up when interrupted") {
  FrameBudget budget(100);
  std::atomic<bool> interrupted{false};
  CHECK_FALSE(budget.acquire(101, interrupted).has_value());  // more than the whole budget
  std::optional<Charge> a = budget.acquire(60, interrupted);
  REQUIRE(a.has_value());
  CHECK(budget.held() == 60);
  CHECK_FALSE(budget.try_acquire(41).has_value());
  Charge part = a->split(20);
  CHECK(part.bytes() == 20);
  CHECK(a->bytes() == 40);
  part.reset();
  CHECK(budget.held() == 40);
  // A waiter gets its bytes once they are given back.
  std::atomic<bool> granted{false};
  std::thread waiter([&] {
    std::optional<Charge> b = budget.acquire(70, interrupted);
    granted = b.has_value() && b->bytes() == 70;
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  CHECK_FALSE(granted.load());
  a.reset();
  waiter.join();
  CHECK(granted.load());
  CHECK(budget.held() == 0);
  CHECK(budget.peak() == 70);
  // An interrupted waiter returns with nothing.
  std::optional<Charge> most = budget.try_acquire(90);
  REQUIRE(most.has_value());
  std::optional<Charge> empty;
  std::thread stuck([&] { empty = budget.acquire(20, interrupted); });
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  interrupted = true;
  budget.wake();
  stuck.join();
  REQUIRE(empty.has_value());
  CHECK(empty->bytes() == 0);
  CHECK(budget.held() == 90);
  Charge merged;
  merged.absorb(std::move(*most));
  CHECK(merged.bytes() == 90);
  merged.reset();
  CHECK(budget.held() == 0);
}

TEST_CASE("frame budget: a frame's bytes grow with its pixels, images, encoding and the CPU renderer's planes") {
  ViewRequest view;
  view.camera.width = 7680;
  view.camera.height = 4320;
  view.encoding = Encoding::kJpeg;
  const double pixels = 7680.0 * 4320.0;
  // RGBA 4 + JPEG 9.2 working (strips and their copies) + 2 x 4.2 output; the CPU renderer adds 20.
  const auto near = [](uint64_t bytes, double expected) { return std::abs(double(bytes) - expected) <= 1.0; };
  CHECK(near(frame_memory_bytes(view, rgs::api::Device::kCuda), pixels * 21.6));
  CHECK(frame_memory_bytes(view, rgs::api::Device::kCpu) ==
        frame_memory_bytes(view, rgs::api::Device::kCuda) + uint64_t(pixels * 20));
  CHECK(render_scratch_bytes(view, rgs::api::Device::kCpu) == uint64_t(pixels * 20));
  CHECK(render_scratch_bytes(view, rgs::api::Device::kCuda) == 0);
  view.encoding = Encoding::kLossless;
  view.compare = CompareMode::kSplit;
  const uint64_t split = frame_memory_bytes(view, rgs::api::Device::kCuda);
  CHECK(near(split, pixels * (8 + 29 + 4 * 3.1)));
  // The largest frame, a split compare, lossless, at 7680 x 4320 on the CPU (2.3 GB), fits the default budget.
  CHECK(frame_memory_bytes(view, rgs::api::Device::kCpu) < ServerOptions().frame_memory);
  view.compare = CompareMode::kDiff;
  CHECK(near(frame_memory_bytes(view, rgs::api::Device::kCuda), pixels * (8 + 3 + 29 + 2 * 3.1)));
}
