// Options of the benchmark tools: image sizes by name or WIDTHxHEIGHT, and the date stamps of their reports.
#pragma once

#include <cstdint>
#include <string>

#include "rgs/format/status.h"

namespace rgs::lab {

/// An image size in pixels.
struct Resolution {
  uint32_t width = 0, height = 0;
};

/// Parses "WIDTHxHEIGHT" ("1920x1080", 'X' also accepted) or a name: 720p (1280x720), 1080p (1920x1080),
/// 1440p (2560x1440), 4k or 2160p (3840x2160). Each side must be in [1, 32768].
/// @return kInvalidArgument naming `text` and the accepted forms.
Result<Resolution> parse_resolution(const std::string& text);

/// "1920x1080".
std::string resolution_string(const Resolution& resolution);

/// The local (or, with `utc`, UTC) time now, as strftime's `pattern` writes it (e.g. "%Y-%m-%d").
std::string format_time(const char* pattern, bool utc);

}  // namespace rgs::lab
