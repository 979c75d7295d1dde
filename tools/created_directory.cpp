#include "created_directory.h"

#include <filesystem>
#include <system_error>

namespace rgs::tools {

Status CreatedDirectory::create(const std::string& path, const std::string& what) {
  std::error_code ec;
  const bool existed = std::filesystem::exists(path, ec);
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path)) {
    return Status(StatusCode::kIoError,
                  path + ": cannot create " + what + (ec ? ": " + ec.message() : std::string()));
  }
  if (!existed) path_ = path;
  return Status();
}

CreatedDirectory::~CreatedDirectory() {
  std::error_code ec;
  if (!path_.empty()) std::filesystem::remove(path_, ec);  // only removes an empty directory
}

}  // namespace rgs::tools
