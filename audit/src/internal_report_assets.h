// The report page's style sheet and script (audit/report/), embedded at build time by view/embed_assets.cmake
// into a generated source.
#pragma once

#include <cstddef>
#include <string_view>

namespace rgs::audit::detail {

/// One embedded file, named "/<file name>" ("/report.css").
struct Asset {
  std::string_view path;
  std::string_view content_type;
  const unsigned char* data;
  size_t size;
};

/// The embedded file named exactly `path`, or null.
const Asset* find_asset(std::string_view path);

}  // namespace rgs::audit::detail
