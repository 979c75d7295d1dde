// The output transaction: every file a run or a conversion writes, checked against every file it reads, staged
// next to its destination while the work goes on, and renamed into place together at the end.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "rgs/format/file_io.h"

namespace rgs::format {

/// All the output files of one run, committed together: every output is staged in its own temporary next to
/// it (StagedFile) and commit() renames them all at the end. Before that, no output exists or changes;
/// destroying the transaction without commit() removes the temporaries and the folders it created (an
/// interrupt does the same through remove_pending_temporaries()). A FileSink: library writers given the
/// transaction stage into it.
///
/// Identity rules (add_input, add_output, declare): two paths are the same file when they name the same device
/// and inode after following symbolic links (hard links, "a/../b", symlinked folders, a case variant on a
/// case-insensitive file system), or, for a path that does not exist yet, the same folder and last component.
///
/// Typical use: add_input() for every file read, add_output() for every file known before any work,
/// remove_stale_temporaries(), then write() each output (directly, or through a library writer, which may
/// declare() the files it finds it must write, such as a streamed SOG's chunk files), then commit(). Not
/// thread-safe: one thread drives a transaction.
class OutputTransaction final : public FileSink {
 public:
  OutputTransaction();
  /// Removes every staged temporary that was not committed, then the folders created for the outputs (those
  /// left empty).
  ~OutputTransaction() override;
  OutputTransaction(const OutputTransaction&) = delete;
  OutputTransaction& operator=(const OutputTransaction&) = delete;

  /// Declares a file the run reads, so that no output may be it. A path that does not exist is ignored (its
  /// reader reports it); declaring an input twice is harmless.
  /// @return kInvalidArgument when `path` is a declared output.
  Status add_input(const std::string& path);

  /// Declares a file the run writes. Creates nothing.
  /// @return kInvalidArgument when `path` is empty, is a declared input or output, or exists and is neither a
  ///         regular file nor a directory (a device or pipe: its content would be replaced by a rename);
  ///         kIoError when it is an existing directory.
  Status add_output(const std::string& path);

  /// FileSink::declare: add_output() for each of `paths` that is not a declared output yet (a writer may
  /// declare what the run declared already).
  Status declare(const std::vector<std::string>& paths) override;

  /// Removes temporaries of the declared outputs that an earlier run left behind ("<name>.<pid>.rgs-partial"
  /// whose process no longer exists). A temporary whose process is alive, or that is not a regular file, is
  /// left in place. Call after the last add_input/add_output: a declared input is never removed.
  /// @return One sentence per temporary found: what was removed, or what was left in place and why.
  std::vector<std::string> remove_stale_temporaries();

  /// Stages the content of the declared output `path`. Writing an output twice replaces the staged content.
  /// @return kInvalidArgument when `path` was not declared or the transaction was committed; kIoError naming
  ///         `path` and the OS cause; or what `produce` returns. On failure the output's temporary is removed
  ///         (the others stay staged).
  Status write(const std::string& path, const ChunkProducer& produce) override;
  /// Stages `path` through a writer that opens a file by name.
  Status write_by_name(const std::string& path, const ByNameWriter& write_to) override;
  using FileSink::write;

  /// Creates the folder `path` (and its parents) when missing. A folder created here is removed again when the
  /// transaction ends without a successful commit() (destroyed, or the process interrupted) and the folder is
  /// empty; a folder that existed before is never removed.
  /// @return kIoError "<path>: cannot create folder[: <OS cause>]".
  Status create_folder(const std::string& path) override;

  /// Renames every staged temporary over its output (outputs never written are left alone). SIGINT, SIGTERM
  /// and SIGHUP are held off in the calling thread meanwhile. After commit() the transaction is closed.
  /// @return kIoError naming the output whose rename failed; outputs renamed before it stay committed (the
  ///         checks of add_output make this a rare race with another process).
  Status commit();

  /// The outputs that existed when they were declared and were replaced by commit(), in declaration order.
  std::vector<std::string> replaced() const;

  /// True when `path` is a declared output of this transaction (same identity rules).
  bool has_output(const std::string& path) const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace rgs::format
