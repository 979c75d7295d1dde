// Helpers shared by the command-line tools: error reporting and number formatting.
#pragma once

#include <chrono>
#include <cstdint>
#include <string>

#include "rgs/format/status.h"

namespace rgs::tools {

/// Exit codes of every tool: 0 success, 1 the operation failed (message on stderr), 2 usage error.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;

/// Prints "<tool>: error: <message> [kCode]" to stderr and returns kExitFailure.
int report_error(const char* tool, const Status& status);

/// 1234567 -> "1,234,567".
std::string group_digits(uint64_t value);
/// Fixed-point with `digits` decimals ("%.*f").
std::string fixed(double value, int digits);
/// Scientific with 3 significant decimals ("1.234e-05"), or "0" for zero.
std::string sci(double value);

/// Seconds since `start`.
double seconds_since(std::chrono::steady_clock::time_point start);

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

/// Lower-case file extension including the dot (".ply"), "" when none.
std::string extension_of(const std::string& path);

}  // namespace rgs::tools
