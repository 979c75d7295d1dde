// The memory check convert() runs before it reads a file whole (convert_memory.cpp).
#pragma once

#include <cstdint>
#include <string>

#include "rgs/api/convert.h"

namespace rgs::api::detail {

/// kLimitExceeded naming `src`, the estimate and the limit when `estimate` (estimate_convert_memory of its inputs,
/// summed) is above convert_memory_limit(options); no check when the limit is 0 (unknown physical memory).
Status check_convert_memory(const std::string& src, uint64_t estimate, const ConvertOptions& options);

}  // namespace rgs::api::detail
