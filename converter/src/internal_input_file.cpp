#include "internal_input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <new>

namespace rgs::converter::detail {

namespace {

/// Opens `path` read-only as a regular file; returns the descriptor and size.
Status open_regular(const std::string& path, int* fd, uint64_t* size) {
  *fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (*fd < 0) return Status(StatusCode::kIoError, path + ": cannot open: " + errno_message(errno));
  struct stat st;
  if (::fstat(*fd, &st) != 0) {
    const int err = errno;
    ::close(*fd);
    return Status(StatusCode::kIoError, path + ": cannot stat: " + errno_message(err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(*fd);
    return Status(StatusCode::kIoError, path + (S_ISDIR(st.st_mode) ? ": is a directory" : ": not a regular file"));
  }
  *size = static_cast<uint64_t>(st.st_size);
  return Status();
}

Status read_exact(int fd, const std::string& path, uint8_t* dst, size_t n, uint64_t offset = 0) {
  size_t done = 0;
  while (done < n) {
    const ssize_t got = ::pread(fd, dst + done, n - done, static_cast<off_t>(offset + done));
    if (got < 0) {
      if (errno == EINTR) continue;
      return Status(StatusCode::kIoError, path + ": read failed: " + errno_message(errno));
    }
    if (got == 0) {
      return Status(StatusCode::kIoError, path + ": file ends at byte " + std::to_string(offset + done) +
                                              ", expected " + std::to_string(offset + n) +
                                              " (file changed while reading?)");
    }
    done += static_cast<size_t>(got);
  }
  return Status();
}

}  // namespace

std::string errno_message(int err) {
  if (err == ENOENT) return "no such file or directory";
  if (err == EACCES) return "permission denied";
  if (err == ENOTDIR) return "a path component is not a directory";
  if (err == EISDIR) return "is a directory";
  return std::strerror(err);
}

Status read_whole_file(const std::string& path, uint64_t max_bytes, std::vector<uint8_t>* out) {
  int fd = -1;
  uint64_t size = 0;
  RGS_RETURN_IF_ERROR(open_regular(path, &fd, &size));
  Status s;
  if (size > max_bytes) {
    s = Status(StatusCode::kLimitExceeded,
               path + ": file is " + std::to_string(size) + " bytes, above the limit of " + std::to_string(max_bytes));
  } else {
    try {
      out->resize(static_cast<size_t>(size));
      s = read_exact(fd, path, out->data(), out->size());
    } catch (const std::bad_alloc&) {
      s = Status(StatusCode::kOutOfMemory, path + ": cannot allocate " + std::to_string(size) + " bytes");
    }
  }
  ::close(fd);
  return s;
}

Status read_file_head(const std::string& path, size_t max_bytes, std::vector<uint8_t>* out, uint64_t* file_size) {
  int fd = -1;
  RGS_RETURN_IF_ERROR(open_regular(path, &fd, file_size));
  out->resize(static_cast<size_t>(std::min<uint64_t>(*file_size, max_bytes)));
  Status s = read_exact(fd, path, out->data(), out->size());
  ::close(fd);
  return s;
}

Status read_file_range(const std::string& path, uint64_t offset, uint64_t n, std::vector<uint8_t>* out) {
  int fd = -1;
  uint64_t size = 0;
  RGS_RETURN_IF_ERROR(open_regular(path, &fd, &size));
  Status s;
  if (offset > size || n > size - offset) {
    s = Status(StatusCode::kIoError, path + ": bytes [" + std::to_string(offset) + ", " + std::to_string(offset + n) +
                                         ") lie past the end of the " + std::to_string(size) + "-byte file");
  } else {
    out->resize(static_cast<size_t>(n));
    s = read_exact(fd, path, out->data(), out->size(), offset);
  }
  ::close(fd);
  return s;
}

}  // namespace rgs::converter::detail
