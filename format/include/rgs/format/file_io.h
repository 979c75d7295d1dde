// Whole-file I/O helpers with the project's failure guarantees: bounded reads, atomic writes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "rgs/format/status.h"

namespace rgs::format {

/// A read-only view of a whole file: memory-mapped when possible, owned by the object (RAII).
/// As with any mapping, the file must not be truncated by another process while mapped (SIGBUS).
class MappedFile {
 public:
  /// Maps `path` read-only. Errors: kIoError naming the path and the OS cause (missing, directory,
  /// unreadable). An empty file maps to size() == 0.
  static Result<std::shared_ptr<const MappedFile>> open(const std::string& path);

  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  const uint8_t* data() const { return data_; }
  size_t size() const { return size_; }
  const std::string& path() const { return path_; }

 private:
  MappedFile() = default;
  const uint8_t* data_ = nullptr;
  size_t size_ = 0;
  std::string path_;
};

/// Receives successive chunks of a file being written; returns kIoError on a failed write.
using ChunkSink = std::function<Status(const void* data, size_t size)>;

/// Writes `path` atomically: `produce` streams the content into a temporary file in the same directory,
/// which is flushed, fsync'ed and renamed over `path` only when `produce` and every write succeeded.
/// On any failure the temporary is removed and an existing `path` is left untouched.
/// Errors: kIoError naming the path and the OS cause, or whatever `produce` returns.
Status write_file_atomic(const std::string& path, const std::function<Status(const ChunkSink&)>& produce);

/// Convenience form of write_file_atomic for one in-memory buffer.
Status write_file_atomic(const std::string& path, const void* data, size_t size);

}  // namespace rgs::format
