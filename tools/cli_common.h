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

/// Lower-case file extension including the dot (".ply"), "" when none.
std::string extension_of(const std::string& path);

}  // namespace rgs::tools
