// Options of the benchmark tools (rgs/lab/bench_options.h).
#include "rgs/lab/bench_options.h"

#include <cctype>
#include <ctime>

namespace rgs::lab {
namespace {

/// Digits only, at most 5 of them, value in [1, 32768]; 0 otherwise.
uint32_t parse_side(const std::string& text) {
  if (text.empty() || text.size() > 5) return 0;
  uint32_t v = 0;
  for (char ch : text) {
    if (!std::isdigit(static_cast<unsigned char>(ch))) return 0;
    v = v * 10 + static_cast<uint32_t>(ch - '0');
  }
  return (v >= 1 && v <= 32768) ? v : 0;
}

}  // namespace

Result<Resolution> parse_resolution(const std::string& text) {
  std::string lower = text;
  for (char& ch : lower) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  if (lower == "720p") return Resolution{1280, 720};
  if (lower == "1080p") return Resolution{1920, 1080};
  if (lower == "1440p") return Resolution{2560, 1440};
  if (lower == "4k" || lower == "2160p") return Resolution{3840, 2160};
  const size_t x = lower.find('x');
  if (x != std::string::npos) {
    const uint32_t w = parse_side(lower.substr(0, x));
    const uint32_t h = parse_side(lower.substr(x + 1));
    if (w != 0 && h != 0) return Resolution{w, h};
  }
  return Status(StatusCode::kInvalidArgument,
                "resolution '" + text + "' is not WIDTHxHEIGHT with sides in [1, 32768] (e.g. 1920x1080) or one "
                "of 720p, 1080p, 1440p, 4k");
}

std::string resolution_string(const Resolution& resolution) {
  return std::to_string(resolution.width) + "x" + std::to_string(resolution.height);
}

std::string format_time(const char* pattern, bool utc) {
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  utc ? gmtime_r(&now, &tm) : localtime_r(&now, &tm);
  char buf[64];
  std::strftime(buf, sizeof(buf), pattern, &tm);
  return buf;
}

}  // namespace rgs::lab
