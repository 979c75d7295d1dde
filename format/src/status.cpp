#include "rgs/format/status.h"

namespace rgs {

const char* status_code_name(StatusCode code) noexcept {
  switch (code) {
    case StatusCode::kOk: return "kOk";
    case StatusCode::kIoError: return "kIoError";
    case StatusCode::kInvalidArgument: return "kInvalidArgument";
    case StatusCode::kNotRgsFile: return "kNotRgsFile";
    case StatusCode::kUnsupportedVersion: return "kUnsupportedVersion";
    case StatusCode::kUnsupportedFeature: return "kUnsupportedFeature";
    case StatusCode::kCorruptData: return "kCorruptData";
    case StatusCode::kChecksumMismatch: return "kChecksumMismatch";
    case StatusCode::kLimitExceeded: return "kLimitExceeded";
    case StatusCode::kOutOfMemory: return "kOutOfMemory";
    case StatusCode::kCudaError: return "kCudaError";
  }
  return "kUnknown";
}

std::string Status::to_string() const {
  if (ok()) return "ok";
  return message_ + " [" + status_code_name(code_) + "]";
}

Status& Status::prepend(const std::string& context) {
  if (!ok()) message_ = context + ": " + message_;
  return *this;
}

}  // namespace rgs
