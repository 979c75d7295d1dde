// An output folder a tool creates for its files, removed again when the run fails before filling it.
#pragma once

#include <string>

#include "rgs/format/status.h"

namespace rgs::tools {

/// An output folder created when missing, and removed again at scope exit when this run created it and left
/// it empty (a failed run); a folder that existed before is never removed. Declare it before the run's
/// tools::OutputSet, so that it is destroyed after the set has removed its temporaries.
class CreatedDirectory {
 public:
  CreatedDirectory() = default;
  CreatedDirectory(const CreatedDirectory&) = delete;
  CreatedDirectory& operator=(const CreatedDirectory&) = delete;
  ~CreatedDirectory();

  /// Creates `path` (and its parents) when missing. `what` names the folder in the error ("output
  /// directory"). @return kIoError "<path>: cannot create <what>[: <OS cause>]".
  Status create(const std::string& path, const std::string& what);

  /// Keeps the folder at scope exit (the run succeeded).
  void keep() { path_.clear(); }

 private:
  std::string path_;  ///< the folder this run created; empty when there is nothing to remove
};

}  // namespace rgs::tools
