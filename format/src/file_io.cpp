// POSIX whole-file I/O: read-only memory mapping, and atomic replace-by-rename writes through staged
// temporaries that an interrupt can remove.
#include "rgs/format/file_io.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <new>
#include <optional>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "internal_file_io.h"

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
    const ssize_t n = ::write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return n < 0 ? errno : EIO;
    data += n;
    size -= static_cast<size_t>(n);
  }
  return 0;
}

/// Validates the last component of `path` and splits it; kIoError for "", ".", ".." or a trailing slash.
Status split_output_path(const std::string& path, std::string* dir, std::string* name) {
  if (path.empty()) return Status(StatusCode::kInvalidArgument, "output path is empty");
  std::tie(*dir, *name) = detail::split_path(path);
  if (name->empty() || *name == "." || *name == "..") {
    return Status(StatusCode::kIoError, "cannot write " + path + ": not a file name");
  }
  return Status();
}

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

// --- Paths an interrupt must remove -------------------------------------------------------------------------
//
// A fixed table of C strings that a signal handler can walk without locks or allocation. A slot holds a path
// from strdup() while it is registered. A path is freed on removal from the table only while no handler is
// walking the table (walkers_): a handler on another thread may still be reading it otherwise. A walker counts
// itself in before it loads any slot, and a removal empties its slot before it looks at the count, so a walker
// that starts after the check can no longer see the path (sequentially consistent atomics).

class SignalPathTable {
 public:
  static constexpr size_t kCapacity = size_t{1} << 16;

  /// Registers `path`; returns its slot, or kCapacity when the table is full (or out of memory).
  size_t add(const std::string& path) {
    char* copy = ::strdup(path.c_str());
    if (copy == nullptr) return kCapacity;
    std::lock_guard<std::mutex> lock(mutex_);
    const size_t used = used_.load();
    for (size_t i = 0; i < kCapacity; ++i) {
      if (i < used && slots_[i].load() != nullptr) continue;
      slots_[i].store(copy);
      if (i >= used) used_.store(i + 1);
      return i;
    }
    std::free(copy);
    return kCapacity;
  }

  void remove(size_t slot) {
    if (slot >= kCapacity) return;
    char* path = slots_[slot].exchange(nullptr);
    if (path != nullptr && walkers_.load() == 0) std::free(path);
  }

  bool contains(const std::string& path) {
    std::lock_guard<std::mutex> lock(mutex_);
    const size_t used = used_.load();
    for (size_t i = 0; i < used; ++i) {
      const char* p = slots_[i].load();
      if (p != nullptr && path == p) return true;
    }
    return false;
  }

  /// Calls `remove_path` on every registered path, newest slot last. Async-signal-safe when `remove_path` is.
  /// Returns how many calls returned 0.
  template <typename RemovePath>
  size_t for_each_path(RemovePath remove_path) noexcept {
    walkers_.fetch_add(1);
    size_t removed = 0;
    const size_t used = used_.load();
    for (size_t i = 0; i < used && i < kCapacity; ++i) {
      const char* path = slots_[i].load();
      if (path != nullptr && remove_path(path) == 0) ++removed;
    }
    walkers_.fetch_sub(1);
    return removed;
  }

 private:
  std::atomic<char*> slots_[kCapacity];
  std::atomic<size_t> used_{0};  ///< slots at or above this index were never used
  std::atomic<int> walkers_{0};
  std::mutex mutex_;
  static_assert(std::atomic<int>::is_always_lock_free && std::atomic<char*>::is_always_lock_free,
                "signal handlers may only touch lock-free atomics");
};

SignalPathTable g_temporaries;  ///< StagedFile temporaries: unlinked
SignalPathTable g_folders;      ///< folders created for outputs: removed when empty

constexpr size_t kMaxTemporaries = SignalPathTable::kCapacity;
size_t register_temporary(const std::string& path) { return g_temporaries.add(path); }
void unregister_temporary(size_t slot) { g_temporaries.remove(slot); }

/// Creates "<dir>/<name>.<pid>[-<n>].rgs-partial" next to `path` exclusively (never opens anyone else's file)
/// and registers it in `*slot`. Returns the descriptor.
Result<int> create_temporary(const std::string& path, std::string* temporary, size_t* slot) {
  std::string dir, name;
  RGS_RETURN_IF_ERROR(split_output_path(path, &dir, &name));
  const std::string pid = std::to_string(static_cast<long long>(::getpid()));
  int fd = -1;
  int open_errno = 0;
  for (int attempt = 0; attempt < 16 && fd < 0; ++attempt) {
    // A second temporary of the same output in this process (two threads) gets a "-<n>" tail.
    *temporary = detail::join_path(dir, name + "." + pid + (attempt ? "-" + std::to_string(attempt) : "") + kPartialSuffix);
    // Registered before it exists, so that an interrupt between the two cannot miss it.
    *slot = register_temporary(*temporary);
    if (*slot == kMaxTemporaries) {
      temporary->clear();
      return Status(StatusCode::kLimitExceeded, "cannot create " + path + ": more than " +
                                                    std::to_string(kMaxTemporaries) + " temporaries at once");
    }
    do {
      fd = ::open(temporary->c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0666);
    } while (fd < 0 && errno == EINTR);
    if (fd >= 0) break;
    open_errno = errno;
    unregister_temporary(*slot);
    if (open_errno != EEXIST) break;
    // Same pid but not another thread's: left by an earlier process that had this pid and was killed.
    if (!is_pending_temporary(*temporary)) {
      struct stat st {};
      if (::lstat(temporary->c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::unlink(temporary->c_str()) == 0) {
        --attempt;  // retry the same name once it is gone
        continue;
      }
    }
  }
  if (fd < 0) {
    temporary->clear();
    return Status(StatusCode::kIoError, "cannot create " + path + ": cannot create a temporary file in directory " +
                                            dir + ": " + os_error(open_errno));
  }
  return fd;
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
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&] { file.reset(new MappedFile()); file->path_ = path; return Status(); },
                                      [&] { return path + ": out of memory opening the file"; }));
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

Status FileSink::write(const std::string& path, const void* data, size_t size) {
  return write(path, [data, size](const ChunkSink& sink) { return sink(data, size); });
}

namespace {

/// atomic_files(): each file staged and committed on its own.
class AtomicFiles final : public FileSink {
 public:
  Status write(const std::string& path, const ChunkProducer& produce) override {
    return write_file_atomic(path, produce);
  }
  Status write_by_name(const std::string& path, const ByNameWriter& write_to) override {
    RGS_ASSIGN_OR_RETURN(StagedFile staged, StagedFile::write_by_name(path, write_to));
    return staged.commit();
  }
  Status declare(const std::vector<std::string>& paths) override {
    for (const std::string& path : paths) RGS_RETURN_IF_ERROR(check_output_file(path, {}));
    return Status();
  }
  Status create_folder(const std::string& path) override {
    std::error_code ec;
    std::filesystem::create_directories(path, ec);
    if (ec || !std::filesystem::is_directory(path)) {
      return Status(StatusCode::kIoError, path + ": cannot create folder" + (ec ? ": " + ec.message() : std::string()));
    }
    return Status();
  }
};

}  // namespace

FileSink& atomic_files() {
  static AtomicFiles files;
  return files;
}

Result<StagedFile> StagedFile::write(const std::string& path, const ChunkProducer& produce) {
  StagedFile staged;  // removes the temporary unless it is returned
  staged.path_ = path;
  RGS_ASSIGN_OR_RETURN(const int fd, create_temporary(path, &staged.temporary_, &staged.slot_));
  FdGuard guard(fd);
  int write_errno = 0;
  uint64_t written = 0;
  const auto write_error = [&] {
    return Status(StatusCode::kIoError, "cannot write " + path + ": " + os_error(write_errno));
  };
  const ChunkSink sink = [&](const void* data, size_t size) -> Status {
    const uint8_t* bytes = static_cast<const uint8_t*>(data);
    while (size > 0 && write_errno == 0) {
      const size_t piece = size < kWritebackPiece ? size : kWritebackPiece;
      write_errno = write_all(fd, bytes, piece);
      start_writeback(fd, written, piece);
      bytes += piece;
      size -= piece;
      written += piece;
    }
    return write_errno != 0 ? write_error() : Status();
  };
  RGS_RETURN_IF_ERROR(produce(sink));
  if (write_errno != 0) return write_error();
  if (::fsync(fd) != 0) {
    const int err = errno;
    return Status(StatusCode::kIoError, "cannot flush " + path + " to disk: " + os_error(err));
  }
  if (const int err = guard.close_now(); err != 0) {
    return Status(StatusCode::kIoError, "cannot close " + path + ": " + os_error(err));
  }
  return Result<StagedFile>(std::move(staged));
}

Result<StagedFile> StagedFile::write_by_name(const std::string& path, const ByNameWriter& write_to) {
  StagedFile staged;
  staged.path_ = path;
  RGS_ASSIGN_OR_RETURN(const int fd, create_temporary(path, &staged.temporary_, &staged.slot_));
  ::close(fd);
  RGS_RETURN_IF_ERROR(write_to(staged.temporary_));
  // The writer may have replaced the file it was given: flush what the name holds now.
  int sync_fd;
  do {
    sync_fd = ::open(staged.temporary_.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  } while (sync_fd < 0 && errno == EINTR);
  FdGuard guard(sync_fd);
  if (sync_fd < 0 || ::fsync(sync_fd) != 0) {
    return Status(StatusCode::kIoError, "cannot flush " + path + " to disk: " + os_error(errno));
  }
  return Result<StagedFile>(std::move(staged));
}

StagedFile::StagedFile(StagedFile&& other) noexcept { *this = std::move(other); }

StagedFile& StagedFile::operator=(StagedFile&& other) noexcept {
  if (this != &other) {
    discard();
    path_ = std::move(other.path_);
    temporary_ = std::exchange(other.temporary_, std::string());
    slot_ = other.slot_;
  }
  return *this;
}

StagedFile::~StagedFile() { discard(); }

void StagedFile::discard() noexcept {
  if (temporary_.empty()) return;
  ::unlink(temporary_.c_str());
  unregister_temporary(slot_);
  temporary_.clear();
}

Status StagedFile::commit() {
  RGS_RETURN_ERROR_IF(temporary_.empty(), StatusCode::kInvalidArgument,
                      "cannot commit " + path_ + ": nothing staged");
  if (::rename(temporary_.c_str(), path_.c_str()) != 0) {
    const int err = errno;
    discard();
    return Status(StatusCode::kIoError, "cannot replace " + path_ + ": " + os_error(err));
  }
  unregister_temporary(slot_);
  temporary_.clear();
  // Best effort: persist the rename. The content is already durable; some file systems refuse fsync on a
  // directory, which is not a failure of the write.
  const std::string dir = detail::split_path(path_).first;
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
  return Status();
}

Status write_file_atomic(const std::string& path, const ChunkProducer& produce) {
  RGS_ASSIGN_OR_RETURN(StagedFile staged, StagedFile::write(path, produce));
  return staged.commit();
}

Status write_file_atomic(const std::string& path, const void* data, size_t size) {
  return atomic_files().write(path, data, size);
}

std::optional<FileId> file_id(const std::string& path) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return std::nullopt;
  return FileId{static_cast<uint64_t>(st.st_dev), static_cast<uint64_t>(st.st_ino)};
}

Status check_output_file(const std::string& output, const std::vector<std::string>& inputs) {
  std::string dir, name;
  RGS_RETURN_IF_ERROR(split_output_path(output, &dir, &name));
  struct stat st {};
  if (::stat(output.c_str(), &st) != 0) return Status();  // a new file (its folder is checked by the write)
  if (S_ISDIR(st.st_mode)) return Status(StatusCode::kIoError, "cannot write " + output + ": is a directory");
  if (!S_ISREG(st.st_mode)) {
    return Status(StatusCode::kInvalidArgument,
                  "cannot write " + output + ": not a regular file (a device or pipe would be replaced, not "
                  "written; use - for standard output where the option allows it)");
  }
  const FileId id{static_cast<uint64_t>(st.st_dev), static_cast<uint64_t>(st.st_ino)};
  for (const std::string& input : inputs) {
    if (file_id(input) == id) {
      return Status(StatusCode::kInvalidArgument, output + ": this output is the input file " + input + " (same file)");
    }
  }
  return Status();
}

bool is_pending_temporary(const std::string& path) { return g_temporaries.contains(path); }

void remove_pending_temporaries() noexcept {
  g_temporaries.for_each_path([](const char* path) { return ::unlink(path); });
  // A folder created inside another created folder is empty only once the inner one is gone: a few passes.
  for (int pass = 0; pass < 8; ++pass) {
    if (g_folders.for_each_path([](const char* path) { return ::rmdir(path); }) == 0) break;
  }
}

size_t detail::register_created_folder(const std::string& path) { return g_folders.add(path); }
void detail::unregister_created_folder(size_t slot) { g_folders.remove(slot); }

}  // namespace rgs::format
