#include "cli_common.h"

#include <cctype>
#include <cstdio>
#include <filesystem>

namespace rgs::tools {

int report_error(const char* tool, const Status& status) {
  std::fprintf(stderr, "%s: error: %s\n", tool, status.to_string().c_str());
  return kExitFailure;
}

std::string group_digits(uint64_t value) {
  std::string digits = std::to_string(value);
  std::string out;
  const size_t n = digits.size();
  for (size_t i = 0; i < n; ++i) {
    out.push_back(digits[i]);
    if ((n - 1 - i) % 3 == 0 && i + 1 < n) out.push_back(',');
  }
  return out;
}

std::string fixed(double value, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", digits, value);
  return buf;
}

std::string sci(double value) {
  if (value == 0.0) return "0";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.3e", value);
  return buf;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& ch : ext) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return ext;
}

}  // namespace rgs::tools
