// The output transaction of a command-line run: every output declared before any work, staged next to its
// destination while the run works, and renamed into place together at its end.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "rgs/format/file_io.h"

namespace rgs::tools {

/// All the output files of one run, committed together: every output is staged in its own temporary next to
/// it (format::StagedFile) and commit() renames them all at the end. Before that, no output exists or
/// changes; destroying the set without commit() removes the temporaries. A format::FileSink: library
/// writers given the set stage into it.
///
/// Identity rules (add_input, add_output): two paths are the same file when they name the same device and
/// inode after following symbolic links (hard links, "a/../b", symlinked directories), or, for a path that
/// does not exist yet, the same directory and last component.
///
/// Typical use: add_input() for every file read, add_output() for every file written (both before any
/// work), remove_stale_temporaries(), then write() each output (directly, or by passing the set to a library
/// writer), then commit(). Not thread-safe: one thread drives a set.
class OutputSet final : public format::FileSink {
 public:
  OutputSet();
  /// Removes every staged temporary that was not committed.
  ~OutputSet() override;
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

  /// Stages the content of the declared output `path`. Writing an output twice replaces the staged content.
  /// @return kInvalidArgument when `path` was not declared or the set was committed; kIoError naming `path`
  ///         and the OS cause; or what `produce` returns. On failure the output's temporary is removed (the
  ///         others stay staged).
  Status write(const std::string& path, const format::ChunkProducer& produce) override;
  /// Stages `path` through a writer that opens a file by name.
  Status write_by_name(const std::string& path, const format::ByNameWriter& write_to) override;
  using format::FileSink::write;

  /// Renames every staged temporary over its output (outputs never written are left alone). SIGINT, SIGTERM
  /// and SIGHUP are held off in the calling thread meanwhile. After commit() the set is closed.
  /// @return kIoError naming the output whose rename failed; outputs renamed before it stay committed (the
  ///         checks of add_output make this a rare race with another process).
  Status commit();

  /// True when `path` is a declared output of this set (same identity rules).
  bool has_output(const std::string& path) const;

  /// Creates the output folder `path` (and its parents) when missing; `what` names it in the error ("output
  /// directory"). A folder created here is removed again when the set is destroyed without a successful
  /// commit() and the folder is empty (a failed run); a folder that existed before is never removed.
  /// @return kIoError "<path>: cannot create <what>[: <OS cause>]".
  Status create_directory(const std::string& path, const std::string& what);

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace rgs::tools
