// Whole-file I/O helpers with the project's failure guarantees: bounded reads, atomic writes, and
// transactions over the several outputs of one run.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
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
/// its rename (SIGKILL, power loss) leaves this one file per output; OutputSet::remove_stale_temporaries()
/// of a later run removes it once that process is gone.
inline constexpr const char kPartialSuffix[] = ".rgs-partial";

/// Writes `path` atomically: `produce` streams the content into a temporary file in the same directory
/// ("<name>.<pid>.rgs-partial"), which is flushed, fsync'ed and renamed over `path` only when `produce` and
/// every write succeeded. On any failure the temporary is removed and an existing `path` is left untouched;
/// remove_pending_temporaries() removes it when the process is interrupted.
/// While an OutputSet that declared `path` is open, the content is staged in that set instead and the rename
/// happens at OutputSet::commit(): library writers (write_scene_file, write_ply) join a tool's transaction
/// without knowing about it.
/// Errors: kIoError naming the path and the OS cause, or whatever `produce` returns.
Status write_file_atomic(const std::string& path, const ChunkProducer& produce);

/// Convenience form of write_file_atomic for one in-memory buffer.
Status write_file_atomic(const std::string& path, const void* data, size_t size);

/// Like write_file_atomic, for writers that can only open a file by name (image libraries): `write_to` is
/// given the temporary's path, writes the whole file there and returns its status; the file is then fsync'ed
/// and renamed over `path` (or staged in the OutputSet that declared `path`).
Status write_file_atomic_by_name(const std::string& path,
                                 const std::function<Status(const std::string& temp_path)>& write_to);

/// All the output files of one run, committed together: every output is staged in its own temporary next to
/// it (see kPartialSuffix) and fsync'ed, and commit() renames them all at the end. Before that, no output
/// exists or changes; destroying the set without commit() removes the temporaries.
///
/// Identity rules (add_input, add_output): two paths are the same file when they name the same device and
/// inode after following symbolic links (hard links, "a/../b", symlinked directories), or, for a path that
/// does not exist yet, the same directory and last component.
///
/// Typical use: add_input() for every file read, add_output() for every file written (both before any
/// work), remove_stale_temporaries(), then write() each output (directly, or through write_file_atomic from
/// a library writer), then commit(). Not thread-safe: one thread drives a set.
class OutputSet {
 public:
  OutputSet();
  /// Removes every staged temporary that was not committed.
  ~OutputSet();
  OutputSet(const OutputSet&) = delete;
  OutputSet& operator=(const OutputSet&) = delete;

  /// Declares a file the run reads, so that no output may be it. A path that does not exist is ignored (its
  /// reader reports it).
  /// @return kInvalidArgument when `path` is a declared output.
  Status add_input(const std::string& path);

  /// Declares a file the run writes. Creates nothing.
  /// @return kInvalidArgument when `path` is empty, is a declared input or output, or exists and is neither a
  ///         regular file nor a directory (a device or pipe: its content would be replaced by a rename);
  ///         kIoError when it is an existing directory.
  Status add_output(const std::string& path);

  /// Removes temporaries of the declared outputs that an earlier run left behind ("<name>.<pid>.rgs-partial"
  /// whose process no longer exists). A temporary whose process is alive, or that is not a regular file, is
  /// left in place. Call after the last add_input/add_output: a declared input is never removed.
  /// @return One sentence per temporary found: what was removed, or what was left in place and why.
  std::vector<std::string> remove_stale_temporaries();

  /// Stages the content of the declared output `path` (produce streams it; see write_file_atomic).
  /// Writing an output twice replaces the staged content.
  /// @return kInvalidArgument when `path` was not declared; kIoError naming `path` and the OS cause; or what
  ///         `produce` returns. On failure the output's temporary is removed (the others stay staged).
  Status write(const std::string& path, const ChunkProducer& produce);
  /// Stages one in-memory buffer as the content of `path`.
  Status write(const std::string& path, const void* data, size_t size);
  /// Stages `path` through a writer that opens a file by name (see write_file_atomic_by_name).
  Status write_by_name(const std::string& path, const std::function<Status(const std::string& temp_path)>& write_to);

  /// Renames every staged temporary over its output (outputs never written are left alone) and syncs their
  /// directories. SIGINT, SIGTERM and SIGHUP are held off in the calling thread meanwhile. After commit() the
  /// set is closed: write() fails.
  /// @return kIoError naming the output whose rename failed; outputs renamed before it stay committed (the
  ///         checks of add_output make this a rare race with another process).
  Status commit();

  /// True when `path` is a declared output of this set (same identity rules).
  bool has_output(const std::string& path) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// Removes every temporary this process is writing (write_file_atomic, OutputSet), for a signal handler that
/// ends the process next. Async-signal-safe: it only reads a fixed table and calls unlink(2).
void remove_pending_temporaries() noexcept;

}  // namespace rgs::format
