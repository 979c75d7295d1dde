// Request admission: the token, Host and Origin checks and the route table (embedded page files, the WebSocket
// endpoint) of view/PROTOCOL.md.
#include <boost/beast/websocket/rfc6455.hpp>
#include <cctype>

#include "internal_routes.h"
#include "view_assets.h"

namespace rgs::view::detail {

namespace http = boost::beast::http;

namespace {

std::string lowercase(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

// The target's query holds token=`token` (one of its &-separated pairs).
bool carries_token(std::string_view target, const std::string& token) {
  const size_t question = target.find('?');
  if (question == std::string_view::npos) return false;
  std::string_view query = target.substr(question + 1);
  bool found = false;
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    if (pair.substr(0, 6) == "token=" && same_token(pair.substr(6), token)) found = true;
    if (amp == std::string_view::npos) break;
    query.remove_prefix(amp + 1);
  }
  return found;
}

bool is_own(const std::optional<Authority>& authority, const AdmissionPolicy& policy) {
  if (!authority || authority->port != policy.port) return false;
  for (const std::string& name : policy.own_names) {
    if (authority->name == name) return true;
  }
  return false;
}

// "scheme://authority" exactly (an Origin header: no path, no user info); `scheme` comes back lowercase.
std::optional<Authority> parse_origin(std::string_view origin, std::string* scheme) {
  const size_t colon = origin.find("://");
  if (colon == std::string_view::npos) return std::nullopt;
  *scheme = lowercase(origin.substr(0, colon));
  const std::string_view rest = origin.substr(colon + 3);
  if (rest.find_first_of("/@?#") != std::string_view::npos) return std::nullopt;
  const uint16_t default_port = *scheme == "https" ? 443 : 80;
  return parse_authority(rest, default_port);
}

// The Origin of an upgrade is the server's own page: one of its own names with its port over http, or, with a
// token (any Host admitted), the authority the browser reached this server by.
bool origin_admitted(std::string_view origin, std::string_view host, const AdmissionPolicy& policy) {
  std::string scheme;
  const std::optional<Authority> from = parse_origin(origin, &scheme);
  if (!from) return false;
  if (scheme == "http" && is_own(from, policy)) return true;
  if (policy.token.empty() || (scheme != "http" && scheme != "https")) return false;
  const std::optional<Authority> reached = parse_authority(host, scheme == "https" ? 443 : 80);
  return reached && *reached == *from;
}

Admission refuse(Admission::Kind kind, std::string_view why) {
  Admission admission;
  admission.kind = kind;
  admission.why = why;
  return admission;
}

}  // namespace

bool same_token(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

std::optional<Authority> parse_authority(std::string_view text, uint16_t default_port) {
  for (char c : text) {
    if (static_cast<unsigned char>(c) <= 0x20 || static_cast<unsigned char>(c) >= 0x7f) return std::nullopt;
  }
  std::string_view name = text, port;
  if (!text.empty() && text.front() == '[') {
    const size_t close = text.find(']');
    if (close == std::string_view::npos) return std::nullopt;
    name = text.substr(0, close + 1);
    const std::string_view rest = text.substr(close + 1);
    if (!rest.empty()) {
      if (rest.front() != ':' || rest.size() == 1) return std::nullopt;
      port = rest.substr(1);
    }
  } else if (const size_t colon = text.rfind(':'); colon != std::string_view::npos) {
    name = text.substr(0, colon);
    port = text.substr(colon + 1);
    if (port.empty()) return std::nullopt;
  }
  if (name.empty() || name == "[]" || (name.front() != '[' && name.find(':') != std::string_view::npos)) {
    return std::nullopt;
  }
  Authority authority;
  authority.name = lowercase(name);
  authority.port = default_port;
  if (!port.empty()) {
    if (port.size() > 5) return std::nullopt;
    uint32_t value = 0;
    for (char c : port) {
      if (c < '0' || c > '9') return std::nullopt;
      value = value * 10 + uint32_t(c - '0');
    }
    if (value < 1 || value > 65535) return std::nullopt;
    authority.port = static_cast<uint16_t>(value);
  }
  return authority;
}

AdmissionPolicy make_admission_policy(const std::string& bound_host, uint16_t port, const std::string& token) {
  AdmissionPolicy policy;
  policy.token = token;
  policy.port = port;
  policy.own_names = {"127.0.0.1", "localhost", "[::1]"};
  const bool v6 = bound_host.find(':') != std::string::npos && bound_host.front() != '[';
  const std::string bound = lowercase(v6 ? "[" + bound_host + "]" : bound_host);
  if (!bound.empty() && bound != "127.0.0.1" && bound != "localhost" && bound != "[::1]") {
    policy.own_names.push_back(bound);
  }
  return policy;
}

Admission admit_request(const http::request_header<>& request, const AdmissionPolicy& policy) {
  if (request.count(http::field::host) > 1 || request.count(http::field::origin) > 1) {
    return refuse(Admission::Kind::kBadRequest, "more than one Host or Origin header");
  }
  const std::string_view target(request.target().data(), request.target().size());
  const auto host_field = request[http::field::host];
  const std::string_view host(host_field.data(), host_field.size());
  if (!policy.token.empty()) {
    if (!carries_token(target, policy.token)) {
      return refuse(Admission::Kind::kForbidden, "the token is missing or wrong");
    }
  } else if (!is_own(parse_authority(host, 80), policy)) {
    return refuse(Admission::Kind::kForbidden, "the Host header does not name this server");
  }
  const std::string_view path = target.substr(0, target.find('?'));
  if (path == "/ws") {
    if (!boost::beast::websocket::is_upgrade(request)) {
      return refuse(Admission::Kind::kBadRequest, "/ws takes a WebSocket upgrade only");
    }
    if (request.count(http::field::origin) == 1) {
      const auto origin = request[http::field::origin];
      if (!origin_admitted(std::string_view(origin.data(), origin.size()), host, policy)) {
        return refuse(Admission::Kind::kForbidden, "the Origin is not this server's page");
      }
    }
    Admission admission;
    admission.kind = Admission::Kind::kWebSocket;
    return admission;
  }
  if (request.method() != http::verb::get && request.method() != http::verb::head) {
    return refuse(Admission::Kind::kMethodNotAllowed, "");
  }
  Admission admission;
  admission.asset = find_asset(path == "/" ? std::string_view("/index.html") : path);
  admission.kind = admission.asset != nullptr ? Admission::Kind::kAsset : Admission::Kind::kNotFound;
  return admission;
}

}  // namespace rgs::view::detail
