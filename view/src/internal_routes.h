// What an HTTP request target asks for: the token check and the route table of view/PROTOCOL.md.
#pragma once

#include <string>
#include <string_view>

#include "internal_assets.h"

namespace rgs::view::detail {

/// Where a request goes.
struct Route {
  enum class Kind { kAsset, kWebSocket, kForbidden, kNotFound };
  Kind kind = Kind::kNotFound;
  const Asset* asset = nullptr;  ///< kAsset
};

/// Routes `target` (the request line's path and query): without the required `token` (empty: none required) in
/// its query as token=..., kForbidden; "/" is /index.html; "/ws" the WebSocket; an embedded file's exact path
/// that file; anything else kNotFound.
Route route_target(std::string_view target, const std::string& token);

/// Compares in time independent of where the strings first differ.
bool same_token(std::string_view a, std::string_view b);

}  // namespace rgs::view::detail
