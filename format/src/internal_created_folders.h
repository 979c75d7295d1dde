// Folders an output transaction created, in the table that remove_pending_temporaries() walks on an interrupt
// (file_io.cpp): each is removed there when empty.
#pragma once

#include <cstddef>
#include <string>

namespace rgs::format::detail {

/// Registers the folder `path`, created for an output; returns its slot (a full table gives a slot that
/// unregistering ignores: the folder is then left on an interrupt, never a file).
size_t register_created_folder(const std::string& path);

/// Unregisters the folder of `slot` (committed, or removed by the transaction itself).
void unregister_created_folder(size_t slot);

}  // namespace rgs::format::detail
