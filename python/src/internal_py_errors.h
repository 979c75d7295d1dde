// Errors of the roofgs module: a failed Status travels as a StatusError to pybind11, whose translator
// (roofgs_module.cpp) raises it as roofgs.Error.
#pragma once

#include <utility>

#include "rgs/format/status.h"

namespace rgs::python {

struct StatusError {
  Status status;
};

[[noreturn]] inline void raise(const Status& status) { throw StatusError{status}; }

template <typename T>
T unwrap(Result<T> result) {
  if (!result.ok()) raise(result.status());
  return std::move(result).value();
}

inline void check(const Status& status) {
  if (!status.ok()) raise(status);
}

}  // namespace rgs::python
