#include "rgs/format/status.h"

#include <iterator>

namespace rgs {

const char* status_code_name(StatusCode code) noexcept {
  static const char* const kNames[] = {"kOk", "kIoError", "kInvalidArgument", "kNotRgsFile", "kUnsupportedVersion",
                                       "kUnsupportedFeature", "kCorruptData", "kChecksumMismatch", "kLimitExceeded",
                                       "kOutOfMemory", "kCudaError"};
  static_assert(std::size(kNames) == static_cast<size_t>(StatusCode::kCudaError) + 1, "a name for every code");
  const auto index = static_cast<size_t>(code);
  return index < std::size(kNames) ? kNames[index] : "kUnknown";
}

std::string group_digits(int64_t value) {
  const std::string digits = std::to_string(value < 0 ? -uint64_t(value) : uint64_t(value));
  std::string out = value < 0 ? "-" : "";
  for (size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += ',';
    out += digits[i];
  }
  return out;
}

std::string Status::to_string() const {
  if (ok()) return "ok";
  return message_ + " [" + status_code_name(code_) + "]";
}

Status& Status::prepend(const std::string& context) {
  if (!ok()) message_ = context + ": " + message_;
  return *this;
}

Status naming(Status status, const std::string& path) {
  if (status.message().find(path) == std::string::npos) status.prepend(path);
  return status;
}

}  // namespace rgs
