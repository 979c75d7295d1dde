// The page's files (view/web/), embedded at build time by view/embed_assets.cmake into a generated source.
#pragma once

#include <cstddef>
#include <string_view>

namespace rgs::view::detail {

/// One embedded file, served at `path` ("/index.html").
struct Asset {
  std::string_view path;
  std::string_view content_type;
  const unsigned char* data;
  size_t size;
};

/// The embedded file served at exactly `path`, or null: no other path exists (nothing reaches the file system).
const Asset* find_asset(std::string_view path);

}  // namespace rgs::view::detail
