// Whole-file and head-of-file reads for the scene readers (private to rgs_converter).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/status.h"

namespace rgs::converter::detail {

/// Reads the regular file `path` whole into `out`. Errors name `path`: kIoError (missing, a directory,
/// unreadable, changed while reading), kLimitExceeded (larger than max_bytes), kOutOfMemory.
Status read_whole_file(const std::string& path, uint64_t max_bytes, std::vector<uint8_t>* out);

/// Reads up to `max_bytes` from the start of `path` into `out` and its size into `file_size`.
/// Errors as read_whole_file (kIoError only).
Status read_file_head(const std::string& path, size_t max_bytes, std::vector<uint8_t>* out, uint64_t* file_size);

/// Reads bytes [offset, offset + n) of `path` into `out`. Errors as read_whole_file (kIoError when the file
/// is shorter).
Status read_file_range(const std::string& path, uint64_t offset, uint64_t n, std::vector<uint8_t>* out);

/// Text of errno values used in messages ("no such file or directory", ...).
std::string errno_message(int err);

}  // namespace rgs::converter::detail
