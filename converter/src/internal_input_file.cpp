#include "internal_input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdio>
#include <cstring>

#include "rgs/format/reader.h"

namespace rgs::converter::detail {

namespace {

/// What a file that is not a regular file is, in words.
std::string file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode) || S_ISBLK(mode)) return "a device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

/// Checks that the open descriptor `fd` is a regular file and returns its size (and, when `identity` is not
/// null, its device and inode); closes it otherwise.
Status check_regular(int* fd, const std::string& path, uint64_t* size, FileIdentity* identity = nullptr) {
  struct stat st;
  if (::fstat(*fd, &st) != 0) {
    const int err = errno;
    ::close(*fd);
    return Status(StatusCode::kIoError, path + ": cannot stat: " + errno_message(err));
  }
  if (!S_ISREG(st.st_mode)) {
    ::close(*fd);
    return Status(StatusCode::kIoError, path + ": not a regular file (" + file_kind(st.st_mode) + ")");
  }
  *size = static_cast<uint64_t>(st.st_size);
  if (identity != nullptr) *identity = FileIdentity{static_cast<uint64_t>(st.st_dev), static_cast<uint64_t>(st.st_ino)};
  return Status();
}

}  // namespace

// O_NONBLOCK: opening a FIFO returns at once (and is then refused) instead of waiting for a writer.
Status open_regular(const std::string& path, int* fd, uint64_t* size) {
  *fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY);
  if (*fd < 0) return Status(StatusCode::kIoError, path + ": cannot open: " + errno_message(errno));
  return check_regular(fd, path, size);
}

Status read_exact(int fd, const std::string& path, uint8_t* dst, size_t n, uint64_t offset) {
  const std::string where = path.empty() ? std::string() : path + ": ";
  size_t done = 0;
  while (done < n) {
    const ssize_t got = ::pread(fd, dst + done, n - done, static_cast<off_t>(offset + done));
    if (got < 0) {
      if (errno == EINTR) continue;
      return Status(StatusCode::kIoError, where + "read of " + std::to_string(n) + " bytes at offset " +
                                              std::to_string(offset) + " failed: " + errno_message(errno));
    }
    if (got == 0) {
      return Status(StatusCode::kIoError, where + "file ends at byte " + std::to_string(offset + done) +
                                              ", expected " + std::to_string(offset + n) +
                                              " (file changed while reading?)");
    }
    done += static_cast<size_t>(got);
  }
  return Status();
}

namespace {

/// Reads n bytes of `fd` from its start into `out`, allocated once the size is known; closes `fd`.
Status read_and_close(int fd, const std::string& path, uint64_t n, std::vector<uint8_t>* out) {
  const Status s = catch_bad_alloc([&] {
    out->resize(static_cast<size_t>(n));
    return read_exact(fd, path, out->data(), out->size());
  }, [&] { return path + ": cannot allocate " + std::to_string(n) + " bytes"; });
  ::close(fd);
  return s;
}

/// At most 96 bytes of input-derived text for a message, control bytes escaped.
std::string quoted(const std::string& text) {
  std::string out = "'";
  for (size_t i = 0; i < text.size() && i < 96; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 || c == 0x7f) {
      char buf[8];
      std::snprintf(buf, sizeof(buf), "\\x%02x", c);
      out += buf;
    } else {
      out += static_cast<char>(c);
    }
  }
  return out + (text.size() > 96 ? "'..." : "'");
}

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

/// True when `s` starts with a URI scheme ("http:", "file:", "C:"): a letter, then letters, digits, '+', '-'
/// or '.', then ':' (RFC 3986 §3.1).
bool has_uri_scheme(const std::string& s) {
  if (s.empty() || !std::isalpha(static_cast<unsigned char>(s[0]))) return false;
  for (size_t i = 1; i < s.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    if (c == ':') return true;
    if (!std::isalnum(c) && c != '+' && c != '-' && c != '.') return false;
  }
  return false;
}

}  // namespace

std::string errno_message(int err) {
  if (err == ENOENT) return "no such file or directory";
  if (err == EACCES) return "permission denied";
  if (err == ENOTDIR) return "a path component is not a directory";
  if (err == EISDIR) return "is a directory";
  return std::strerror(err);
}

uint64_t decode_budget(uint64_t file_bytes, uint32_t ratio) {
  const uint64_t basis = std::max<uint64_t>(file_bytes, format::kDecompressionRatioMinBytes);
  return basis > UINT64_MAX / std::max<uint32_t>(ratio, 1) ? UINT64_MAX : basis * ratio;
}

Status check_decode_budget(uint64_t decoded, uint64_t file_bytes, uint32_t ratio, const std::string& where,
                           const std::string& what) {
  if (decoded <= decode_budget(file_bytes, ratio)) return Status();
  return Status(StatusCode::kLimitExceeded,
                (where.empty() ? "" : where + ": ") + what + " decode to " + std::to_string(decoded) + " bytes, more than the decompression-" +
                    "ratio limit of " + std::to_string(ratio) + " x " +
                    std::to_string(std::max<uint64_t>(file_bytes, format::kDecompressionRatioMinBytes)) +
                    " bytes of input (files under 1 MiB count as 1 MiB; format/SPEC.md 5.5); raise "
                    "--max-decompression-ratio to read it");
}

Status read_whole_file(const std::string& path, uint64_t max_bytes, std::vector<uint8_t>* out) {
  int fd = -1;
  uint64_t size = 0;
  RGS_RETURN_IF_ERROR(open_regular(path, &fd, &size));
  if (size > max_bytes) {
    ::close(fd);
    return Status(StatusCode::kLimitExceeded, path + ": file is " + std::to_string(size) +
                                                  " bytes, above the limit of " + std::to_string(max_bytes));
  }
  return read_and_close(fd, path, size, out);
}

Status read_file_head(const std::string& path, size_t max_bytes, std::vector<uint8_t>* out, uint64_t* file_size) {
  int fd = -1;
  RGS_RETURN_IF_ERROR(open_regular(path, &fd, file_size));
  out->resize(static_cast<size_t>(std::min<uint64_t>(*file_size, max_bytes)));
  Status s = read_exact(fd, path, out->data(), out->size());
  ::close(fd);
  return s;
}

// --- SceneFolder ----------------------------------------------------------------------------------

SceneFolder::SceneFolder(std::string root, std::string entry) : root_(std::move(root)) {
  if (root_.empty()) root_ = ".";
  if (entry.empty()) return;
  // The entry file was (or is about to be) read as the user named it; a name inside the scene that reaches
  // it again reads nothing new.
  struct stat st;
  if (::stat(entry.c_str(), &st) == 0 && S_ISREG(st.st_mode)) {
    distinct_.emplace(FileIdentity{static_cast<uint64_t>(st.st_dev), static_cast<uint64_t>(st.st_ino)},
                      static_cast<uint64_t>(st.st_size));
  }
  files_.push_back(std::move(entry));
}

Result<std::string> resolve_scene_reference(const std::string& reference, const std::string& base,
                                            const std::string& where, const std::string& field) {
  const std::string named = where + ": field '" + field + "' names " + quoted(reference);
  auto refuse = [&](const std::string& why) { return Status(StatusCode::kCorruptData, named + ", " + why); };
  if (reference.empty()) return refuse("an empty file name");
  // RFC 3986: the scheme, query and fragment are read from the reference as written, the path after
  // percent-decoding.
  if (has_uri_scheme(reference)) return refuse("a URI scheme other than data: (outside the scene's folder)");
  // A query or fragment has no meaning for a file (a '?' or '#' in a file name is percent-encoded).
  if (reference.find_first_of("?#") != std::string::npos) return refuse("a URI with a query or fragment");
  std::string decoded;
  for (size_t i = 0; i < reference.size(); ++i) {
    if (reference[i] == '%') {
      const int hi = i + 2 < reference.size() ? hex_value(reference[i + 1]) : -1;
      const int lo = hi >= 0 ? hex_value(reference[i + 2]) : -1;
      if (lo < 0) return refuse("a malformed percent-escape");
      decoded += static_cast<char>(hi * 16 + lo);
      i += 2;
    } else {
      decoded += reference[i];
    }
  }
  if (decoded.find('\0') != std::string::npos) return refuse("a NUL byte");
  if (decoded[0] == '/') return refuse("an absolute path (outside the scene's folder)");
  std::string relative = base;
  size_t start = 0;
  while (start <= decoded.size()) {
    size_t end = decoded.find('/', start);
    if (end == std::string::npos) end = decoded.size();
    const std::string part = decoded.substr(start, end - start);
    if (part == "..") return refuse("a '..' component (outside the scene's folder)");
    if (!part.empty() && part != ".") relative += (relative.empty() ? "" : "/") + part;
    start = end + 1;
  }
  if (relative.empty() || relative == base) return refuse("no file");
  return relative;
}

std::string SceneFolder::display(const std::string& relative) const {
  return root_ == "." ? relative : root_ + (root_.back() == '/' ? "" : "/") + relative;
}

std::string SceneFolder::display_bounded(const std::string& relative) const {
  return display(relative.size() <= 96 ? relative : relative.substr(0, 96) + "...");
}

void SceneFolder::record(const std::string& relative, const FileIdentity& identity, uint64_t bytes) const {
  const std::string path = display(relative);
  std::lock_guard<std::mutex> lock(mutex_);
  if (std::find(files_.begin(), files_.end(), path) == files_.end()) files_.push_back(path);
  uint64_t& counted = distinct_[identity];
  counted = std::max(counted, bytes);
}

uint64_t SceneFolder::distinct_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  uint64_t total = 0;
  for (const auto& [identity, bytes] : distinct_) total += bytes;
  return total;
}

uint64_t SceneFolder::distinct_files() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return distinct_.size();
}

std::vector<std::string> SceneFolder::files() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return files_;
}

Status SceneFolder::open_file(const std::string& relative, int* fd, uint64_t* size, FileIdentity* identity) const {
  const std::string path = display_bounded(relative);
  int dir = ::open(root_.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (dir < 0) return Status(StatusCode::kIoError, root_ + ": cannot open the scene's folder: " + errno_message(errno));
  // Walk the components with O_NOFOLLOW, so that no link on the way is followed.
  size_t start = 0;
  for (;;) {
    const size_t slash = relative.find('/', start);
    const bool last = slash == std::string::npos;
    const std::string part = relative.substr(start, last ? std::string::npos : slash - start);
    struct stat st;
    if (::fstatat(dir, part.c_str(), &st, AT_SYMLINK_NOFOLLOW) != 0) {
      const int err = errno;
      ::close(dir);
      return Status(StatusCode::kIoError, path + ": cannot open: " + errno_message(err));
    }
    if (S_ISLNK(st.st_mode)) {
      ::close(dir);
      return Status(StatusCode::kCorruptData, path + ": is or passes through a symbolic link; files a scene names "
                                                     "are not followed through links (docs/INPUT_HYGIENE.md)");
    }
    if (last ? !S_ISREG(st.st_mode) : !S_ISDIR(st.st_mode)) {
      ::close(dir);
      return Status(StatusCode::kIoError, display_bounded(relative.substr(0, last ? relative.size() : slash)) +
                                              ": not a regular file (" + file_kind(st.st_mode) + ")");
    }
    const int flags = O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NOCTTY | (last ? O_NONBLOCK : O_DIRECTORY);
    const int next = ::openat(dir, part.c_str(), flags);
    const int err = errno;
    ::close(dir);
    if (next < 0) {
      if (err == ELOOP) return Status(StatusCode::kCorruptData, path + ": is or passes through a symbolic link");
      return Status(StatusCode::kIoError, path + ": cannot open: " + errno_message(err));
    }
    if (last) {
      *fd = next;
      break;
    }
    dir = next;
    start = slash + 1;
  }
  // The file may have been swapped between the check and the open: check what was opened.
  return check_regular(fd, path, size, identity);
}

Status SceneFolder::read(const std::string& relative, uint64_t n, std::vector<uint8_t>* out, bool prefix) const {
  int fd = -1;
  uint64_t size = 0;
  FileIdentity identity;
  RGS_RETURN_IF_ERROR(open_file(relative, &fd, &size, &identity));
  record(relative, identity, std::min(size, n));
  const std::string path = display_bounded(relative);
  if (prefix ? size < n : size > n) {
    ::close(fd);
    return prefix ? Status(StatusCode::kCorruptData, path + ": file has " + std::to_string(size) +
                                                         " bytes, fewer than the " + std::to_string(n) + " declared")
                  : Status(StatusCode::kLimitExceeded, path + ": file is " + std::to_string(size) +
                                                           " bytes, above the limit of " + std::to_string(n));
  }
  return read_and_close(fd, path, prefix ? n : size, out);
}

}  // namespace rgs::converter::detail
