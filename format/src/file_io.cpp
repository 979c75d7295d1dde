// POSIX whole-file I/O: read-only memory mapping, atomic replace-by-rename writes, and OutputSet, which
// commits the outputs of one run together.
#include "rgs/format/file_io.h"

#include <dirent.h>
#include <fcntl.h>
#include <signal.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <new>
#include <optional>
#include <string>
#include <utility>
#include <vector>

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


// --- Temporaries an interrupt must remove ------------------------------------------------------------------
//
// A fixed table of C strings that a signal handler can walk without locks or allocation. A slot holds a path
// from strdup() while its temporary exists. A path is freed on removal from the table only while no handler is
// walking the table (g_walkers): a handler on another thread may still be reading it otherwise. A walker counts
// itself in before it loads any slot, and a removal empties its slot before it looks at the count, so a walker
// that starts after the check can no longer see the path (sequentially consistent atomics).

constexpr size_t kMaxTemporaries = size_t{1} << 16;
std::atomic<char*> g_temporaries[kMaxTemporaries];
std::atomic<size_t> g_temporaries_used{0};  ///< slots at or above this index were never used
std::atomic<int> g_walkers{0};
static_assert(std::atomic<int>::is_always_lock_free && std::atomic<char*>::is_always_lock_free,
              "signal handlers may only touch lock-free atomics");
std::mutex g_temporaries_mutex;

/// Registers `path`; returns its slot, or kMaxTemporaries when the table is full (or out of memory).
size_t register_temporary(const std::string& path) {
  char* copy = ::strdup(path.c_str());
  if (copy == nullptr) return kMaxTemporaries;
  std::lock_guard<std::mutex> lock(g_temporaries_mutex);
  const size_t used = g_temporaries_used.load();
  for (size_t i = 0; i < kMaxTemporaries; ++i) {
    if (i < used && g_temporaries[i].load() != nullptr) continue;
    g_temporaries[i].store(copy);
    if (i >= used) g_temporaries_used.store(i + 1);
    return i;
  }
  std::free(copy);
  return kMaxTemporaries;
}

void unregister_temporary(size_t slot) {
  if (slot >= kMaxTemporaries) return;
  char* path = g_temporaries[slot].exchange(nullptr);
  if (path != nullptr && g_walkers.load() == 0) std::free(path);
}

bool is_registered_temporary(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_temporaries_mutex);
  const size_t used = g_temporaries_used.load();
  for (size_t i = 0; i < used; ++i) {
    const char* p = g_temporaries[i].load();
    if (p != nullptr && path == p) return true;
  }
  return false;
}

/// A complete temporary next to its output: its path and its slot in the table above.
struct Temporary {
  std::string path;
  size_t slot = kMaxTemporaries;
};

/// Unlinks and unregisters `temp` (no-op when empty).
void discard(Temporary* temp) {
  if (temp->path.empty()) return;
  ::unlink(temp->path.c_str());
  unregister_temporary(temp->slot);
  *temp = Temporary{};
}

/// Validates the last component of `path` and splits it; kIoError for "", ".", ".." or a trailing slash.
Status split_output_path(const std::string& path, std::string* dir, std::string* name) {
  if (path.empty()) return Status(StatusCode::kInvalidArgument, "output path is empty");
  split_path(path, dir, name);
  if (name->empty() || *name == "." || *name == "..") {
    return Status(StatusCode::kIoError, "cannot write " + path + ": not a file name");
  }
  return Status();
}

std::string join_path(const std::string& dir, const std::string& name) {
  return (dir == "/" ? std::string("/") : dir + "/") + name;
}

/// Creates "<dir>/<name>.<pid>[-<n>].rgs-partial" exclusively (never opens anyone else's file) and registers
/// it. Returns the descriptor, or -1 with `*err` set.
int create_temporary(const std::string& path, const std::string& dir, const std::string& name, Temporary* temp,
                     Status* err) {
  const std::string pid = std::to_string(static_cast<long long>(::getpid()));
  int fd = -1;
  int open_errno = 0;
  for (int attempt = 0; attempt < 16 && fd < 0; ++attempt) {
    // A second temporary of the same output in this process (two threads) gets a "-<n>" tail.
    temp->path = join_path(dir, name + "." + pid + (attempt ? "-" + std::to_string(attempt) : "") + kPartialSuffix);
    do {
      fd = ::open(temp->path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0666);
    } while (fd < 0 && errno == EINTR);
    open_errno = fd < 0 ? errno : 0;
    if (fd < 0 && open_errno != EEXIST) break;
    // Same pid but not ours: left by an earlier process that had this pid and was killed.
    if (fd < 0 && !is_registered_temporary(temp->path)) {
      struct stat st {};
      if (::lstat(temp->path.c_str(), &st) == 0 && S_ISREG(st.st_mode) && ::unlink(temp->path.c_str()) == 0) {
        --attempt;  // retry the same name once it is gone
        continue;
      }
    }
  }
  if (fd < 0) {
    *err = Status(StatusCode::kIoError, "cannot create " + path + ": cannot create a temporary file in directory " +
                                            dir + ": " + os_error(open_errno));
    temp->path.clear();
    return -1;
  }
  temp->slot = register_temporary(temp->path);
  if (temp->slot == kMaxTemporaries) {
    ::close(fd);
    ::unlink(temp->path.c_str());
    temp->path.clear();
    *err = Status(StatusCode::kLimitExceeded, "cannot create " + path + ": more than " +
                                                  std::to_string(kMaxTemporaries) + " temporaries at once");
    return -1;
  }
  return fd;
}

/// Writes the complete content of `path` into a new temporary next to it, fsync'ed and closed. On failure
/// nothing is left behind.
Status write_temporary(const std::string& path, const ChunkProducer& produce, Temporary* temp) {
  std::string dir, name;
  RGS_RETURN_IF_ERROR(split_output_path(path, &dir, &name));
  Status created;
  const int fd = create_temporary(path, dir, name, temp, &created);
  if (fd < 0) return created;
  FdGuard guard(fd);
  auto fail = [&](Status status) {
    if (guard.get() >= 0) (void)guard.close_now();
    discard(temp);
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
  return Status();
}

/// write_temporary for a writer that opens the file by name: the temporary is created empty, written by
/// `write_to`, then fsync'ed.
Status write_temporary_by_name(const std::string& path,
                               const std::function<Status(const std::string& temp_path)>& write_to,
                               Temporary* temp) {
  std::string dir, name;
  RGS_RETURN_IF_ERROR(split_output_path(path, &dir, &name));
  Status created;
  const int fd = create_temporary(path, dir, name, temp, &created);
  if (fd < 0) return created;
  ::close(fd);
  Status written = write_to(temp->path);
  if (!written.ok()) {
    discard(temp);
    return written;
  }
  int sync_fd;
  do {
    sync_fd = ::open(temp->path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  } while (sync_fd < 0 && errno == EINTR);
  if (sync_fd < 0 || ::fsync(sync_fd) != 0) {
    const int err = errno;
    if (sync_fd >= 0) ::close(sync_fd);
    discard(temp);
    return Status(StatusCode::kIoError, "cannot flush " + path + " to disk: " + os_error(err));
  }
  ::close(sync_fd);
  return Status();
}

/// Best effort: persist a rename. The content is already durable; some file systems refuse fsync on a
/// directory, which is not a failure of the write.
void sync_directory(const std::string& dir) {
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir_fd >= 0) {
    (void)::fsync(dir_fd);
    ::close(dir_fd);
  }
}

/// Renames a complete temporary over `path` and unregisters it; on failure it is removed.
Status rename_into_place(Temporary* temp, const std::string& path) {
  if (::rename(temp->path.c_str(), path.c_str()) != 0) {
    const int err = errno;
    discard(temp);
    return Status(StatusCode::kIoError, "cannot replace " + path + ": " + os_error(err));
  }
  unregister_temporary(temp->slot);
  *temp = Temporary{};
  return Status();
}

/// The last step of a single-file atomic write: rename_into_place, then persist the rename in its folder.
Status commit_temporary(Temporary* temp, const std::string& path) {
  RGS_RETURN_IF_ERROR(rename_into_place(temp, path));
  std::string dir, name;
  split_path(path, &dir, &name);
  sync_directory(dir);
  return Status();
}

// --- Identities ----------------------------------------------------------------------------------------------

/// Device and inode of what `path` names after following symbolic links; nullopt when it does not exist.
std::optional<std::pair<dev_t, ino_t>> file_identity(const std::string& path, struct stat* st_out = nullptr) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) return std::nullopt;
  if (st_out != nullptr) *st_out = st;
  return std::make_pair(st.st_dev, st.st_ino);
}

/// Where an output goes: its directory's identity and its last component, or the path as written when the
/// directory cannot be examined (the write reports why).
struct OutputKey {
  std::optional<std::pair<dev_t, ino_t>> dir;
  std::string name;
  std::string lexical;
  bool operator==(const OutputKey& o) const {
    if (dir.has_value() != o.dir.has_value()) return false;
    return dir ? (*dir == *o.dir && name == o.name) : lexical == o.lexical;
  }
};

OutputKey output_key(const std::string& path) {
  OutputKey key;
  std::string dir;
  split_path(path, &dir, &key.name);
  key.dir = file_identity(dir);
  key.lexical = path;
  return key;
}

/// True for "<pid>" or "<pid>-<n>" (the middle of a temporary's name); sets `*pid`.
bool parse_temporary_owner(const std::string& middle, long long* pid) {
  const size_t dash = middle.find('-');
  const std::string digits = middle.substr(0, dash);
  if (digits.empty() || digits.size() > 18) return false;
  for (char ch : digits) {
    if (ch < '0' || ch > '9') return false;
  }
  if (dash != std::string::npos) {
    const std::string tail = middle.substr(dash + 1);
    if (tail.empty() || tail.size() > 4) return false;
    for (char ch : tail) {
      if (ch < '0' || ch > '9') return false;
    }
  }
  *pid = std::stoll(digits);
  return *pid > 0;
}

// --- Outputs captured by an open OutputSet ---------------------------------------------------------------------

std::mutex g_sets_mutex;
std::vector<OutputSet*> g_open_sets;

OutputSet* capturing_set(const std::string& path) {
  std::lock_guard<std::mutex> lock(g_sets_mutex);
  for (OutputSet* set : g_open_sets) {
    if (set->has_output(path)) return set;
  }
  return nullptr;
}

void close_set(OutputSet* set) {
  std::lock_guard<std::mutex> lock(g_sets_mutex);
  g_open_sets.erase(std::remove(g_open_sets.begin(), g_open_sets.end(), set), g_open_sets.end());
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


Status write_file_atomic(const std::string& path, const ChunkProducer& produce) {
  if (OutputSet* set = capturing_set(path)) return set->write(path, produce);
  Temporary temp;
  RGS_RETURN_IF_ERROR(write_temporary(path, produce, &temp));
  return commit_temporary(&temp, path);
}

Status write_file_atomic(const std::string& path, const void* data, size_t size) {
  return write_file_atomic(path, [data, size](const ChunkSink& sink) { return sink(data, size); });
}

Status write_file_atomic_by_name(const std::string& path,
                                 const std::function<Status(const std::string& temp_path)>& write_to) {
  if (OutputSet* set = capturing_set(path)) return set->write_by_name(path, write_to);
  Temporary temp;
  RGS_RETURN_IF_ERROR(write_temporary_by_name(path, write_to, &temp));
  return commit_temporary(&temp, path);
}

struct OutputSet::State {
  struct Input {
    std::string path;
    std::pair<dev_t, ino_t> id;
  };
  struct Output {
    std::string path;
    std::string dir, name;
    OutputKey key;
    std::optional<std::pair<dev_t, ino_t>> id;  ///< when it exists
    Temporary temp;                              ///< staged content, if written
  };
  std::vector<Input> inputs;
  std::vector<Output> outputs;
  bool closed = false;

  Output* find(const std::string& path) {
    const OutputKey key = output_key(path);
    for (Output& o : outputs) {
      if (o.path == path || o.key == key) return &o;
    }
    return nullptr;
  }

  /// The declared output `path`, its earlier staged content dropped, ready to be written again.
  Result<Output*> restage(const std::string& path) {
    Output* out = find(path);
    RGS_RETURN_ERROR_IF(out == nullptr, StatusCode::kInvalidArgument,
                        "cannot write " + path + ": not a declared output of this run");
    RGS_RETURN_ERROR_IF(closed, StatusCode::kInvalidArgument,
                        "cannot write " + path + ": the outputs of this run were already committed");
    discard(&out->temp);
    return out;
  }
};

OutputSet::OutputSet() : state_(std::make_unique<State>()) {
  std::lock_guard<std::mutex> lock(g_sets_mutex);
  g_open_sets.push_back(this);
}

OutputSet::~OutputSet() {
  close_set(this);
  for (State::Output& o : state_->outputs) discard(&o.temp);
}

Status OutputSet::add_input(const std::string& path) {
  const auto id = file_identity(path);
  if (!id) return Status();
  for (const State::Output& o : state_->outputs) {
    if (o.id == id) {
      return Status(StatusCode::kInvalidArgument, o.path + ": this output is the input file " + path);
    }
  }
  state_->inputs.push_back({path, *id});
  return Status();
}

Status OutputSet::add_output(const std::string& path) {
  State::Output out;
  out.path = path;
  RGS_RETURN_IF_ERROR(split_output_path(path, &out.dir, &out.name));
  out.key = output_key(path);
  struct stat st {};
  out.id = file_identity(path, &st);
  if (out.id) {
    if (S_ISDIR(st.st_mode)) return Status(StatusCode::kIoError, "cannot write " + path + ": is a directory");
    if (!S_ISREG(st.st_mode)) {
      return Status(StatusCode::kInvalidArgument,
                    "cannot write " + path + ": not a regular file (a device or pipe would be replaced, not "
                    "written; use - for standard output where the option allows it)");
    }
    for (const State::Input& in : state_->inputs) {
      if (in.id == *out.id) {
        return Status(StatusCode::kInvalidArgument,
                      path + ": this output is the input file " + in.path + " (same file)");
      }
    }
  }
  for (const State::Output& o : state_->outputs) {
    if (o.key == out.key || (out.id && o.id == out.id)) {
      return Status(StatusCode::kInvalidArgument,
                    path + ": this output is also the output " + o.path + " (same file)");
    }
  }
  state_->outputs.push_back(std::move(out));
  return Status();
}

std::vector<std::string> OutputSet::remove_stale_temporaries() {
  std::vector<std::string> notes;
  std::vector<std::string> dirs;
  for (const State::Output& o : state_->outputs) {
    if (std::find(dirs.begin(), dirs.end(), o.dir) == dirs.end()) dirs.push_back(o.dir);
  }
  const std::string suffix = kPartialSuffix;
  for (const std::string& dir : dirs) {
    DIR* d = ::opendir(dir.c_str());
    if (d == nullptr) continue;  // the write reports a missing or unreadable directory
    std::vector<std::pair<std::string, long long>> found;
    while (const dirent* e = ::readdir(d)) {
      const std::string entry = e->d_name;
      if (entry.size() <= suffix.size() || entry.compare(entry.size() - suffix.size(), suffix.size(), suffix) != 0) {
        continue;
      }
      for (const State::Output& o : state_->outputs) {
        if (o.dir != dir || entry.size() <= o.name.size() + 1 + suffix.size() ||
            entry.compare(0, o.name.size() + 1, o.name + ".") != 0) {
          continue;
        }
        long long pid = 0;
        const std::string middle = entry.substr(o.name.size() + 1, entry.size() - o.name.size() - 1 - suffix.size());
        if (parse_temporary_owner(middle, &pid)) found.emplace_back(entry, pid);
      }
    }
    ::closedir(d);
    for (const auto& [entry, pid] : found) {
      const std::string temp = join_path(dir, entry);
      if (is_registered_temporary(temp)) continue;  // ours, being written
      bool is_input = false;
      const auto id = file_identity(temp);
      for (const State::Input& in : state_->inputs) is_input = is_input || (id && in.id == *id);
      if (is_input) {
        notes.push_back(temp +
                        " looks like a temporary of an interrupted run but is an input of this one; left in place");
        continue;
      }
      if (pid != static_cast<long long>(::getpid()) &&
          (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH)) {
        notes.push_back(temp + " belongs to process " + std::to_string(pid) +
                        ", which is still running (another run writing the same output?); left in place");
        continue;
      }
      struct stat st {};
      if (::lstat(temp.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
        notes.push_back(temp + " is not a regular file; left in place");
        continue;
      }
      if (::unlink(temp.c_str()) != 0) {
        const int err = errno;
        notes.push_back("cannot remove " + temp + ", left by an interrupted run: " + os_error(err));
        continue;
      }
      notes.push_back("removed " + temp + ", left by an interrupted run (process " + std::to_string(pid) +
                      " no longer exists)");
    }
  }
  return notes;
}

Status OutputSet::write(const std::string& path, const ChunkProducer& produce) {
  RGS_ASSIGN_OR_RETURN(State::Output * out, state_->restage(path));
  return write_temporary(path, produce, &out->temp);
}

Status OutputSet::write(const std::string& path, const void* data, size_t size) {
  return write(path, [data, size](const ChunkSink& sink) { return sink(data, size); });
}

Status OutputSet::write_by_name(const std::string& path,
                                const std::function<Status(const std::string& temp_path)>& write_to) {
  RGS_ASSIGN_OR_RETURN(State::Output * out, state_->restage(path));
  return write_temporary_by_name(path, write_to, &out->temp);
}

Status OutputSet::commit() {
  RGS_RETURN_ERROR_IF(state_->closed, StatusCode::kInvalidArgument, "the outputs of this run were already committed");
  state_->closed = true;
  close_set(this);
  // An interrupt between two renames would leave some outputs new and some old.
  sigset_t block, previous;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  sigaddset(&block, SIGHUP);
  const bool masked = ::pthread_sigmask(SIG_BLOCK, &block, &previous) == 0;
  Status status;
  std::vector<std::string> dirs;
  for (State::Output& o : state_->outputs) {
    if (o.temp.path.empty()) continue;
    if (!status.ok()) {
      discard(&o.temp);
      continue;
    }
    status = rename_into_place(&o.temp, o.path);
    if (status.ok() && std::find(dirs.begin(), dirs.end(), o.dir) == dirs.end()) dirs.push_back(o.dir);
  }
  if (masked) ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  for (const std::string& dir : dirs) sync_directory(dir);
  return status;
}

bool OutputSet::has_output(const std::string& path) const { return state_->find(path) != nullptr; }

void remove_pending_temporaries() noexcept {
  g_walkers.fetch_add(1);
  const size_t used = g_temporaries_used.load();
  for (size_t i = 0; i < used && i < kMaxTemporaries; ++i) {
    const char* path = g_temporaries[i].load();
    if (path != nullptr) ::unlink(path);
  }
  g_walkers.fetch_sub(1);
}

}  // namespace rgs::format
