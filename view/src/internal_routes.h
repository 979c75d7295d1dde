// Whether and where an HTTP request goes: the route table of view/PROTOCOL.md and the admission checks (token,
// Host, Origin) the server applies to every request header before it answers or upgrades. Pure functions of the
// header, so that the tests and the fuzz target reach them without a socket.
#pragma once

#include <boost/beast/http/message.hpp>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace rgs::view::detail {

struct Asset;  // an embedded file of the page (the generated view_assets.h)

/// Request line and headers, at most: a longer header is answered 431 and the connection closed; a request with
/// a body is closed (the server's request parser takes no body).
inline constexpr size_t kMaxHeaderBytes = 8 * 1024;

/// How requests must name the server and what they must carry (view/PROTOCOL.md "Transport and security").
struct AdmissionPolicy {
  /// Required as ?token=... in every request target; empty: none.
  std::string token;
  /// Host names a Host header or an Origin may give when there is no token: lowercase, IPv6 in brackets.
  std::vector<std::string> own_names;
  /// The port those names must come with (a Host or Origin without one means 80).
  uint16_t port = 0;
};

/// The policy of a server bound to `bound_host` (as ServerOptions::host gives it) and `port` with `token`: its
/// own names are 127.0.0.1, localhost, [::1] and `bound_host`.
AdmissionPolicy make_admission_policy(const std::string& bound_host, uint16_t port, const std::string& token);

/// What the server does with a request.
struct Admission {
  enum class Kind { kAsset, kWebSocket, kBadRequest, kForbidden, kNotFound, kMethodNotAllowed };
  Kind kind = Kind::kNotFound;
  const Asset* asset = nullptr;  ///< kAsset: the file to send
  std::string_view why;          ///< kBadRequest, kForbidden: the check that failed, for the response body
};

/// Decides a request from its header alone, in this order: without `policy.token` in the target's query, 403;
/// with no token, a Host header other than one of `policy.own_names` with `policy.port`, 403; "/ws" without a
/// WebSocket upgrade, 400; an upgrade whose Origin is not the server's own (http:// + an own name and the port,
/// or with a token, the Host header's authority over http or https), 403, and one without Origin is admitted
/// (browsers always send it: docs/VIEWER.md "Security model"); other methods than GET and HEAD, 405; "/" is
/// /index.html, an embedded file's exact path that file, anything else 404. Repeated Host or Origin headers: 400.
Admission admit_request(const boost::beast::http::request_header<>& request, const AdmissionPolicy& policy);

/// A URL authority: a lowercase host name (IPv6 in brackets) and a port.
struct Authority {
  std::string name;
  uint16_t port = 0;
  bool operator==(const Authority& other) const { return name == other.name && port == other.port; }
};

/// Parses "name", "name:port" or "[v6]:port" (`default_port` when the port is left out); nullopt for an empty
/// name, a port that is not 1..65535 in decimal, or bytes outside printable ASCII.
std::optional<Authority> parse_authority(std::string_view text, uint16_t default_port);

/// Compares in time independent of where the strings first differ.
bool same_token(std::string_view a, std::string_view b);

}  // namespace rgs::view::detail
