// POSIX whole-file I/O: read-only memory mapping and atomic replace-by-rename writes.
#include "rgs/format/file_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <new>
#include <string>

namespace rgs::format {
namespace {

std::string os_error(int err) { return std::strerror(err); }

/// Closes a descriptor on scope exit unless released.
class FdGuard {
 public:
  explicit FdGuard(int fd) : fd_(fd) {}
  ~FdGuard() {
    if (fd_ >= 0) ::close(fd_);
  }
  FdGuard(const FdGuard&) = delete;
  FdGuard& operator=(const FdGuard&) = delete;
  int get() const { return fd_; }
  /// Closes now; returns the errno of a failed close, else 0.
  int close_now() {
    const int fd = fd_;
    fd_ = -1;
    return ::close(fd) == 0 ? 0 : errno;
  }

 private:
  int fd_;
};

/// Writes all of [data, data + size) to fd, retrying short writes and EINTR. Returns 0 or an errno.
int write_all(int fd, const uint8_t* data, size_t size) {
  while (size > 0) {
    // Cap each call so the count fits ssize_t on every platform.
    const size_t chunk = size < (size_t{1} << 30) ? size : (size_t{1} << 30);
    const ssize_t n = ::write(fd, data, chunk);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    if (n == 0) return EIO;
    data += n;
    size -= static_cast<size_t>(n);
  }
  return 0;
}

/// Splits "dir/name" into ("dir", "name"); a bare name lives in ".".
void split_path(const std::string& path, std::string* dir, std::string* name) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) {
    *dir = ".";
    *name = path;
  } else {
    *dir = slash == 0 ? "/" : path.substr(0, slash);
    *name = path.substr(slash + 1);
  }
}

std::atomic<uint64_t> g_temp_counter{0};

/// Large writes go to the kernel in pieces of this size, each followed by start_writeback().
constexpr size_t kWritebackPiece = size_t{4} << 20;

/// Asks the kernel to start writing [offset, offset + size) of fd to disk now, without waiting (Linux
/// sync_file_range with SYNC_FILE_RANGE_WRITE), so the disk works while the rest of the file is still
/// being produced and the final fsync() only waits for the tail. A hint: errors are ignored here, and
/// fsync() still decides whether the data is durable.
void start_writeback(int fd, uint64_t offset, size_t size) {
#if defined(__linux__) && defined(SYNC_FILE_RANGE_WRITE)
  if (size >= (size_t{1} << 20)) {
    (void)::sync_file_range(fd, static_cast<off_t>(offset), static_cast<off_t>(size), SYNC_FILE_RANGE_WRITE);
  }
#else
  (void)fd;
  (void)offset;
  (void)size;
#endif
}

}  // namespace

Result<std::shared_ptr<const MappedFile>> MappedFile::open(const std::string& path) {
  int fd;
  do {
    // O_NONBLOCK: opening a FIFO must not wait for a writer before fstat rejects it; regular files
    // ignore the flag.
    fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK);
  } while (fd < 0 && errno == EINTR);
  if (fd < 0) {
    const int err = errno;
    return Status(StatusCode::kIoError, path + ": cannot open for reading: " + os_error(err));
  }
  FdGuard guard(fd);
  struct stat st {};
  if (::fstat(fd, &st) != 0) {
    const int err = errno;
    return Status(StatusCode::kIoError, path + ": cannot stat: " + os_error(err));
  }
  if (S_ISDIR(st.st_mode)) return Status(StatusCode::kIoError, path + ": is a directory, not a file");
  if (!S_ISREG(st.st_mode)) {
    return Status(StatusCode::kIoError, path + ": not a regular file (pipes and devices cannot be mapped)");
  }
  if (st.st_size < 0 || static_cast<uint64_t>(st.st_size) > SIZE_MAX) {
    return Status(StatusCode::kIoError,
                  path + ": size " + std::to_string(st.st_size) + " does not fit this address space");
  }
  const size_t size = static_cast<size_t>(st.st_size);

  std::shared_ptr<MappedFile> file;
  try {
    file.reset(new MappedFile());
    file->path_ = path;
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, path + ": out of memory opening the file");
  }
  if (size > 0) {
    void* p = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE, fd, 0);
    if (p == MAP_FAILED) {
      const int err = errno;
      return Status(StatusCode::kIoError,
                    path + ": cannot map " + std::to_string(size) + " bytes: " + os_error(err));
    }
    file->data_ = static_cast<const uint8_t*>(p);
    file->size_ = size;
  }
  return std::shared_ptr<const MappedFile>(std::move(file));
}

MappedFile::~MappedFile() {
  if (data_ != nullptr && size_ > 0) ::munmap(const_cast<uint8_t*>(data_), size_);
}

Status write_file_atomic(const std::string& path, const std::function<Status(const ChunkSink&)>& produce) {
  if (path.empty()) return Status(StatusCode::kInvalidArgument, "output path is empty");
  std::string dir, name;
  split_path(path, &dir, &name);
  if (name.empty() || name == "." || name == "..") {
    return Status(StatusCode::kIoError, "cannot write " + path + ": not a file name");
  }

  // O_EXCL on a name unique to this process and call: never opens (or truncates) anyone else's file.
  std::string temp;
  int fd = -1;
  for (int attempt = 0; attempt < 16 && fd < 0; ++attempt) {
    const uint64_t counter = g_temp_counter.fetch_add(1);
    temp = (dir == "/" ? std::string("/") : dir + "/") + "." + name + ".tmp." +
           std::to_string(static_cast<long long>(::getpid())) + "." + std::to_string(counter);
    do {
      fd = ::open(temp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    } while (fd < 0 && errno == EINTR);
    if (fd < 0 && errno != EEXIST) break;
  }
  if (fd < 0) {
    const int err = errno;
    return Status(StatusCode::kIoError, "cannot create " + path + ": cannot create a temporary file in directory " +
                                            dir + ": " + os_error(err));
  }
  FdGuard guard(fd);
  auto fail = [&](Status status) {
    if (guard.get() >= 0) (void)guard.close_now();
    ::unlink(temp.c_str());
    return status;
  };

  int write_errno = 0;
  uint64_t written = 0;
  const ChunkSink sink = [&](const void* data, size_t size) -> Status {
    if (write_errno != 0) return Status(StatusCode::kIoError, "cannot write " + path + ": " + os_error(write_errno));
    const uint8_t* bytes = static_cast<const uint8_t*>(data);
    while (size > 0 && write_errno == 0) {
      const size_t piece = size < kWritebackPiece ? size : kWritebackPiece;
      write_errno = write_all(fd, bytes, piece);
      start_writeback(fd, written, piece);
      bytes += piece;
      size -= piece;
      written += piece;
    }
    if (write_errno != 0) return Status(StatusCode::kIoError, "cannot write " + path + ": " + os_error(write_errno));
    return Status();
  };
  Status produced = produce(sink);
  if (!produced.ok()) return fail(std::move(produced));
  if (write_errno != 0) {
    return fail(Status(StatusCode::kIoError, "cannot write " + path + ": " + os_error(write_errno)));
  }
  if (::fsync(fd) != 0) {
    const int err = errno;
    return fail(Status(StatusCode::kIoError, "cannot flush " + path + " to disk: " + os_error(err)));
  }
  if (const int err = guard.close_now(); err != 0) {
    return fail(Status(StatusCode::kIoError, "cannot close " + path + ": " + os_error(err)));
  }
  if (::rename(temp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    return fail(Status(StatusCode::kIoError, "cannot replace " + path + ": " + os_error(err)));
  }
  // Best effort: persist the rename itself. The content is already durable; some file systems refuse
  // fsync on a directory, which is not a failure of this write.
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
  return Status();
}

Status write_file_atomic(const std::string& path, const void* data, size_t size) {
  return write_file_atomic(path, [data, size](const ChunkSink& sink) { return sink(data, size); });
}

}  // namespace rgs::format
