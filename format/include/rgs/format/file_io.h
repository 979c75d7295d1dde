// Whole-file I/O with the project's failure guarantees: read-only mapping, atomic writes through staged
// temporaries, and FileSink, the explicit destination every library writer takes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

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

/// Streams a file's content into a sink; returns the first error of the sink or its own.
using ChunkProducer = std::function<Status(const ChunkSink&)>;

/// Suffix of the temporary an output is written to before it is renamed into place: "out.rgs" is staged as
/// "out.rgs.<pid>.rgs-partial" in the same directory, <pid> being the writing process. A run killed before
/// its rename (SIGKILL, power loss) leaves this one file per output; the command-line tools remove it in a
/// later run once that process is gone.
inline constexpr const char kPartialSuffix[] = ".rgs-partial";

/// Writes a file by name: given the path of the file to create, writes all of it there (image libraries).
using ByNameWriter = std::function<Status(const std::string& temp_path)>;

/// Where a writer puts the files it writes. Every library writer (write_scene_file, converter::write_ply,
/// write_spz, write_glb, write_sog, write_sog_lod, audit::write_report_images) takes one explicitly:
/// atomic_files() writes each file atomically in place; an OutputTransaction (output_transaction.h) stages
/// every output, refuses any that is an input, and renames them all at its end.
///
/// A writer of several files calls declare() with all of them before it writes the first, and creates the
/// folders it needs with create_folder(), so that a transaction can refuse the set (and remove the folders
/// again) before anything is written.
class FileSink {
 public:
  virtual ~FileSink() = default;
  /// Writes the whole content of `path`, streamed by `produce`.
  /// @return kIoError naming `path` and the OS cause, or what `produce` returns; `path` unchanged on failure.
  virtual Status write(const std::string& path, const ChunkProducer& produce) = 0;
  /// The same for a writer that can only open a file by name: `write_to` is given a temporary path.
  virtual Status write_by_name(const std::string& path, const ByNameWriter& write_to) = 0;
  /// Says that `paths` will be written, before any of them is.
  /// @return kInvalidArgument for a path that may not be written (an input of the transaction, a device or
  ///         pipe), kIoError for an existing directory; nothing is created either way.
  virtual Status declare(const std::vector<std::string>& paths) = 0;
  /// Creates the folder `path` (and its parents) for files still to be written; an existing folder is kept.
  /// A transaction removes the folders it created (when empty) if it is not committed, on an interrupt too.
  /// @return kIoError "<path>: cannot create folder: <OS cause>".
  virtual Status create_folder(const std::string& path) = 0;
  /// One in-memory buffer.
  Status write(const std::string& path, const void* data, size_t size);
};

/// The sink that writes each file atomically in place: StagedFile::write or write_by_name, then commit().
FileSink& atomic_files();

/// The new content of one file, complete in a temporary next to it ("<name>.<pid>.rgs-partial", flushed and
/// fsync'ed) until commit() renames it over the destination. Destroyed before that, the temporary is removed;
/// an interrupt removes it through remove_pending_temporaries(). Move-only.
class StagedFile {
 public:
  /// Streams `produce` into a new temporary next to `path`.
  /// @return kInvalidArgument for an empty path; kIoError naming `path` and the OS cause ("." or "..", a
  ///         missing or read-only folder); kLimitExceeded past 65,536 temporaries at once; what `produce`
  ///         returns. Nothing is left behind on failure.
  static Result<StagedFile> write(const std::string& path, const ChunkProducer& produce);
  /// The same through a writer that opens the temporary by name.
  static Result<StagedFile> write_by_name(const std::string& path, const ByNameWriter& write_to);

  StagedFile(StagedFile&& other) noexcept;
  StagedFile& operator=(StagedFile&& other) noexcept;
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;
  ~StagedFile();

  /// Renames the temporary over the destination and persists the rename in its folder; the object is then
  /// empty. @return kIoError naming the destination (the temporary is removed); kInvalidArgument when empty.
  Status commit();

 private:
  StagedFile() = default;
  void discard() noexcept;
  std::string path_, temporary_;
  size_t slot_ = 0;
};

/// Writes `path` atomically: StagedFile::write, then commit(). On any failure the temporary is removed and an
/// existing `path` is left untouched. Errors: kIoError naming the path and the OS cause, or whatever
/// `produce` returns.
Status write_file_atomic(const std::string& path, const ChunkProducer& produce);

/// Convenience form of write_file_atomic for one in-memory buffer.
Status write_file_atomic(const std::string& path, const void* data, size_t size);

/// Identity of an existing file: device and inode after following symbolic links.
struct FileId {
  uint64_t device = 0, inode = 0;
  bool operator==(const FileId& o) const { return device == o.device && inode == o.inode; }
};

/// The identity of what `path` names (hard links, "a/../b" and symbolic links give one identity); nullopt
/// when it does not exist or cannot be examined.
std::optional<FileId> file_id(const std::string& path);

/// Checks, before any work, that `output` may be replaced by a file: it does not exist, or is a regular file
/// that is none of `inputs` (by file_id()).
/// @return kIoError for an existing directory; kInvalidArgument for a device or pipe (a rename would replace
///         it, not write it) and for an output that is one of `inputs`, naming both.
Status check_output_file(const std::string& output, const std::vector<std::string>& inputs);

/// True when `path` is a temporary this process is writing now (a StagedFile not yet committed or removed).
bool is_pending_temporary(const std::string& path);

/// Removes every temporary this process is writing (StagedFile, write_file_atomic), for a signal handler
/// that ends the process next. Async-signal-safe: it only reads a fixed table and calls unlink(2).
void remove_pending_temporaries() noexcept;

}  // namespace rgs::format
