// What the output transaction shares with file_io.cpp: paths split and joined as the staged temporaries are
// named, and the folders it created, in the table that remove_pending_temporaries() walks on an interrupt: each
// is removed there when empty.
#pragma once

#include <cstddef>
#include <string>
#include <utility>

namespace rgs::format::detail {

/// Splits "dir/name" into ("dir", "name"); a bare name lives in ".", "/name" in "/".
inline std::pair<std::string, std::string> split_path(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return {".", path};
  return {slash == 0 ? "/" : path.substr(0, slash), path.substr(slash + 1)};
}

/// `name` in the folder `dir`, the inverse of split_path().
inline std::string join_path(const std::string& dir, const std::string& name) {
  return (dir == "/" ? std::string("/") : dir + "/") + name;
}

/// Registers the folder `path`, created for an output; returns its slot (a full table gives a slot that
/// unregistering ignores: the folder is then left on an interrupt, never a file).
size_t register_created_folder(const std::string& path);

/// Unregisters the folder of `slot` (committed, or removed by the transaction itself).
void unregister_created_folder(size_t slot);

}  // namespace rgs::format::detail
