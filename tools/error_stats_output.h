// Printing per-attribute error statistics (rgs::converter::ErrorStats), shared by rgs-convert and rgs-audit.
#pragma once

#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "cli_common.h"
#include "rgs/converter/attribute_errors.h"

namespace rgs::tools {

/// {"max": ..., "rms": ..., "samples": ...}
inline nlohmann::json stats_json(const converter::ErrorStats& s) {
  return {{"max", s.max}, {"rms", s.rms}, {"samples", s.samples}};
}

/// One table row: name (left-aligned in `name_width` columns), max, rms, then a free-text unit or note.
inline void print_stats_row(const std::string& name, const converter::ErrorStats& s, const std::string& unit,
                            int name_width = 16) {
  std::printf("  %-*s %12s %12s  %s\n", name_width, name.c_str(), sci(s.max).c_str(), sci(s.rms).c_str(),
              unit.c_str());
}

}  // namespace rgs::tools
