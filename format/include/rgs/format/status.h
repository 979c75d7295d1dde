// Error model shared by every RoofGS library: numbered codes, Status and Result<T>.
// Libraries never throw across their API and never print (CONTRIBUTING.md#errors).
#pragma once

#include <cstdint>
#include <new>
#include <optional>
#include <string>
#include <utility>

namespace rgs {

/// Error codes of every public RoofGS call. Numbered and append-only: a value, once released, keeps its
/// meaning, and tools may print it.
enum class StatusCode : int {
  kOk = 0,
  kIoError = 1,             ///< open/read/write/rename failed, or a file ends early
  kInvalidArgument = 2,     ///< the caller passed something out of range
  kNotRgsFile = 3,          ///< wrong magic, or not the expected container at all
  kUnsupportedVersion = 4,  ///< a newer major format version
  kUnsupportedFeature = 5,  ///< a required flag, codec or layout this build does not know
  kCorruptData = 6,         ///< structurally invalid content (bad header, offsets, values)
  kChecksumMismatch = 7,    ///< an XXH64 or zstd content checksum does not match
  kLimitExceeded = 8,       ///< a ReadLimits bound (count, size, degree) is exceeded
  kOutOfMemory = 9,         ///< host or device allocation failed
  kCudaError = 10,          ///< a CUDA runtime call or kernel launch failed
};

/// Stable identifier of a code, e.g. "kCorruptData". Never null.
const char* status_code_name(StatusCode code) noexcept;

/// `value` in decimal with a comma between groups of three digits, as messages and reports print counts:
/// 4250000 -> "4,250,000", -1234 -> "-1,234".
std::string group_digits(int64_t value);

/// Outcome of an operation: kOk, or an error code with a message naming the cause and its numbers.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status ok_status() { return Status(); }

  bool ok() const noexcept { return code_ == StatusCode::kOk; }
  StatusCode code() const noexcept { return code_; }
  const std::string& message() const noexcept { return message_; }
  /// "message [kCode]", or "ok".
  std::string to_string() const;

  /// Prefixes the message with context ("file.ply: "), keeping the code. Returns *this for chaining.
  Status& prepend(const std::string& context);

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

/// `status` with `path` in front ("path: ...") unless its message names the file already.
Status naming(Status status, const std::string& path);

/// fn() (a Status or Result), or kOutOfMemory with the message what() when it throws std::bad_alloc: an allocation
/// that fails (a size a file declares, an image asked for) becomes an error. Work that must also undo what it did
/// when an allocation fails keeps its own try/catch.
template <typename Fn, typename What>
auto catch_bad_alloc(Fn&& fn, What&& what) -> decltype(fn()) {
  try {
    return fn();
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, what());
  }
}

/// A value of type T, or the Status explaining why there is none.
template <typename T>
class [[nodiscard]] Result {
 public:
  Result(T value) : value_(std::move(value)) {}  // NOLINT(google-explicit-constructor)
  Result(Status status) : status_(std::move(status)) {}  // NOLINT(google-explicit-constructor)

  bool ok() const noexcept { return status_.ok(); }
  const Status& status() const& noexcept { return status_; }
  Status status() && { return std::move(status_); }

  /// The value; only valid when ok().
  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  T& operator*() & { return *value_; }
  const T& operator*() const& { return *value_; }

 private:
  Status status_;
  std::optional<T> value_;
};

namespace detail {
inline Status to_status(Status s) { return s; }
template <typename T>
Status to_status(const Result<T>& r) { return r.status(); }
}  // namespace detail

}  // namespace rgs

#define RGS_CONCAT_INNER_(a, b) a##b
#define RGS_CONCAT_(a, b) RGS_CONCAT_INNER_(a, b)

/// Returns the Status of `expr` (a Status or Result) from the enclosing function when it is not ok.
#define RGS_RETURN_IF_ERROR(expr)                                   \
  do {                                                              \
    ::rgs::Status rgs_status_ = ::rgs::detail::to_status((expr));   \
    if (!rgs_status_.ok()) return rgs_status_;                      \
  } while (0)

/// `RGS_ASSIGN_OR_RETURN(auto x, make_x());` declares x from a Result, or returns its Status.
#define RGS_ASSIGN_OR_RETURN(lhs, expr) \
  RGS_ASSIGN_OR_RETURN_IMPL_(RGS_CONCAT_(rgs_result_, __LINE__), lhs, expr)
#define RGS_ASSIGN_OR_RETURN_IMPL_(tmp, lhs, expr) \
  auto tmp = (expr);                               \
  if (!tmp.ok()) return std::move(tmp).status();   \
  lhs = std::move(tmp).value()

/// Returns Status(code, msg) when `cond` holds. `msg` is any expression convertible to std::string.
#define RGS_RETURN_ERROR_IF(cond, code, msg)                 \
  do {                                                       \
    if (cond) return ::rgs::Status((code), (msg));           \
  } while (0)
