// Fuzz target: an HTTP request to the rgs-view server (view/PROTOCOL.md "Transport and security"): its header
// parsed as the server reads it (Beast's request parser, at most 8 KiB of header, no body), then
// detail::admit_request, the server's decision (token, Host, Origin, route). Input: 1 byte of policy (bit 0: a
// token is required; bit 1: port 80, else 8080; bit 2: bound to 0.0.0.0, else 127.0.0.1), then the request bytes.
// Any input must parse or fail without crashing, and an admitted request must meet the rules independently of
// the code under test: the token in its target when one is required, otherwise a Host of a loopback name with the
// port; an upgrade's Origin, when present and without a token, that name's http origin; an asset only for GET
// or HEAD of an embedded file.
#include <boost/asio/buffer.hpp>
#include <boost/beast/http/empty_body.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/websocket/rfc6455.hpp>
#include <cctype>
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "fuzz_check.h"
#include "internal_routes.h"
#include "view_assets.h"

namespace {

namespace http = boost::beast::http;
using rgs::view::detail::Admission;

const std::string kToken = "0123456789abcdef0123456789abcdef";

std::string lowercase(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// `authority` (lowercase) is a loopback name with `port`, written out or, for port 80, left out.
bool own_authority(const std::string& authority, uint16_t port) {
  for (const char* name : {"127.0.0.1", "localhost", "[::1]"}) {
    const std::string prefix(name);
    if (authority == prefix) return port == 80;
    if (authority.compare(0, prefix.size() + 1, prefix + ":") != 0) continue;
    const std::string digits = authority.substr(prefix.size() + 1);
    if (digits.empty() || digits.size() > 5 || digits.find_first_not_of("0123456789") != std::string::npos) {
      return false;
    }
    return std::stoul(digits) == port;
  }
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size < 1) return 0;
  const bool with_token = (data[0] & 1) != 0;
  const uint16_t port = (data[0] & 2) ? 80 : 8080;
  const std::string bound = (data[0] & 4) ? "0.0.0.0" : "127.0.0.1";
  const rgs::view::detail::AdmissionPolicy policy =
      rgs::view::detail::make_admission_policy(bound, port, with_token ? kToken : "");

  http::request_parser<http::empty_body> parser;
  parser.header_limit(rgs::view::detail::kMaxHeaderBytes);
  parser.body_limit(0);
  parser.eager(true);
  boost::beast::error_code ec;
  parser.put(boost::asio::buffer(data + 1, size - 1), ec);
  if (ec || !parser.is_done()) return 0;  // the server reads a whole request before it decides
  const http::request_header<>& request = parser.get().base();
  const Admission admission = rgs::view::detail::admit_request(request, policy);
  const Admission again = rgs::view::detail::admit_request(request, policy);
  RGS_FUZZ_CHECK(admission.kind == again.kind && admission.asset == again.asset, "the decision is not deterministic");
  if (admission.kind == Admission::Kind::kForbidden || admission.kind == Admission::Kind::kBadRequest) {
    RGS_FUZZ_CHECK(!admission.why.empty(), "a refusal without its reason");
  }
  if (admission.kind != Admission::Kind::kAsset && admission.kind != Admission::Kind::kWebSocket) return 0;

  const std::string_view target(request.target().data(), request.target().size());
  const auto host_field = request[http::field::host];
  const std::string host = lowercase(std::string_view(host_field.data(), host_field.size()));
  if (with_token) {
    RGS_FUZZ_CHECK(target.find("token=" + kToken) != std::string_view::npos, "admitted without the token");
  } else {
    RGS_FUZZ_CHECK(request.count(http::field::host) == 1 && own_authority(host, port),
                   "admitted without a Host of this server: " + host);
  }
  if (admission.kind == Admission::Kind::kWebSocket) {
    RGS_FUZZ_CHECK(target.substr(0, target.find('?')) == "/ws", "a WebSocket elsewhere than /ws");
    RGS_FUZZ_CHECK(boost::beast::websocket::is_upgrade(request), "a WebSocket without an upgrade");
    if (request.count(http::field::origin) != 0) {
      RGS_FUZZ_CHECK(request.count(http::field::origin) == 1, "more than one Origin admitted");
      const auto origin_field = request[http::field::origin];
      const std::string origin = lowercase(std::string_view(origin_field.data(), origin_field.size()));
      if (!with_token) {
        RGS_FUZZ_CHECK(origin.compare(0, 7, "http://") == 0 && own_authority(origin.substr(7), port),
                       "an upgrade from another origin admitted: " + origin);
      } else {
        RGS_FUZZ_CHECK(origin.compare(0, 7, "http://") == 0 || origin.compare(0, 8, "https://") == 0,
                       "an upgrade from another scheme admitted: " + origin);
      }
    }
  } else {
    RGS_FUZZ_CHECK(admission.asset != nullptr, "an asset admission without its file");
    RGS_FUZZ_CHECK(request.method() == http::verb::get || request.method() == http::verb::head,
                   "an asset for another method");
    const std::string_view path = target.substr(0, target.find('?'));
    RGS_FUZZ_CHECK(path == admission.asset->path || (path == "/" && admission.asset->path == "/index.html"),
                   "an asset served at another path");
  }
  return 0;
}
