// The HTTP route table: embedded page files, the WebSocket endpoint and the token check.
#include "internal_routes.h"

namespace rgs::view::detail {

bool same_token(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  unsigned char diff = 0;
  for (size_t i = 0; i < a.size(); ++i) diff |= static_cast<unsigned char>(a[i] ^ b[i]);
  return diff == 0;
}

Route route_target(std::string_view target, const std::string& token) {
  Route route;
  const size_t question = target.find('?');
  const std::string_view path = target.substr(0, question);
  if (!token.empty()) {
    bool found = false;
    if (question != std::string_view::npos) {
      std::string_view query = target.substr(question + 1);
      while (!query.empty()) {
        const size_t amp = query.find('&');
        const std::string_view pair = query.substr(0, amp);
        if (pair.substr(0, 6) == "token=" && same_token(pair.substr(6), token)) found = true;
        if (amp == std::string_view::npos) break;
        query.remove_prefix(amp + 1);
      }
    }
    if (!found) {
      route.kind = Route::Kind::kForbidden;
      return route;
    }
  }
  if (path == "/ws") {
    route.kind = Route::Kind::kWebSocket;
    return route;
  }
  route.asset = find_asset(path == "/" ? std::string_view("/index.html") : path);
  route.kind = route.asset != nullptr ? Route::Kind::kAsset : Route::Kind::kNotFound;
  return route;
}

}  // namespace rgs::view::detail
