// The memory check convert() runs before it reads a file whole (convert_memory.cpp).
#pragma once

#include <cstdint>
#include <string>

#include "rgs/api/convert.h"

namespace rgs::api::detail {

/// kLimitExceeded naming `src`, `what` needs the estimate ("converting it": estimate_convert_memory of its inputs
/// together; or a merged scene's) and the limit when `estimate` is above convert_memory_limit(options); no check when
/// the limit is 0 (unknown physical memory).
Status check_convert_memory(const std::string& src, uint64_t estimate, const ConvertOptions& options,
                            const std::string& what = "converting it");

}  // namespace rgs::api::detail
