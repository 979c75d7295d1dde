// OutputSet: the outputs of one command-line run, staged and committed together; the temporaries earlier
// runs left behind, removed once their process is gone.
#include "output_set.h"

#include <dirent.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <optional>
#include <utility>

namespace rgs::tools {
namespace {

/// Splits "dir/name" into ("dir", "name"); a bare name lives in ".".
std::pair<std::string, std::string> split_path(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  if (slash == std::string::npos) return {".", path};
  return {slash == 0 ? "/" : path.substr(0, slash), path.substr(slash + 1)};
}

std::string join_path(const std::string& dir, const std::string& name) {
  return (dir == "/" ? std::string("/") : dir + "/") + name;
}

/// Where an output goes: its directory's identity and its last component, or the path as written when the
/// directory cannot be examined (the write reports why).
struct OutputKey {
  std::optional<format::FileId> dir;
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
  std::tie(dir, key.name) = split_path(path);
  key.dir = format::file_id(dir);
  key.lexical = path;
  return key;
}

/// True for "<pid>" or "<pid>-<n>" (the middle of a temporary's name); sets `*pid`.
bool parse_temporary_owner(const std::string& middle, long long* pid) {
  const size_t dash = middle.find('-');
  const std::string digits = middle.substr(0, dash);
  const std::string tail = dash == std::string::npos ? "0" : middle.substr(dash + 1);
  auto all_digits = [](const std::string& s, size_t most) {
    return !s.empty() && s.size() <= most && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
  };
  if (!all_digits(digits, 18) || !all_digits(tail, 4)) return false;
  *pid = std::stoll(digits);
  return *pid > 0;
}

/// What remove_stale_temporaries() does with the temporary `temp` of process `pid`: removes it when that
/// process is gone, else says why it stays.
std::string remove_stale(const std::string& temp, long long pid, bool is_input) {
  if (is_input) return temp + " looks like a temporary of an interrupted run but is an input of this one; left in place";
  if (pid != static_cast<long long>(::getpid()) && (::kill(static_cast<pid_t>(pid), 0) == 0 || errno != ESRCH)) {
    return temp + " belongs to process " + std::to_string(pid) +
           ", which is still running (another run writing the same output?); left in place";
  }
  struct stat st {};
  if (::lstat(temp.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) return temp + " is not a regular file; left in place";
  if (::unlink(temp.c_str()) != 0) {
    const int err = errno;
    return "cannot remove " + temp + ", left by an interrupted run: " + std::strerror(err);
  }
  return "removed " + temp + ", left by an interrupted run (process " + std::to_string(pid) + " no longer exists)";
}

}  // namespace

struct OutputSet::State {
  struct Input {
    std::string path;
    format::FileId id;
  };
  struct Output {
    std::string path;
    std::string dir, name;
    OutputKey key;
    std::optional<format::FileId> id;      ///< when it exists
    std::optional<format::StagedFile> staged;  ///< its content, once written
  };
  std::vector<Input> inputs;
  std::vector<Output> outputs;
  std::vector<std::string> created_directories;  ///< removed when empty unless the commit succeeds
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
    out->staged.reset();
    return out;
  }
};

OutputSet::OutputSet() : state_(std::make_unique<State>()) {}

OutputSet::~OutputSet() {
  state_->outputs.clear();  // the temporaries first, so that a folder this run created can be empty
  std::error_code ec;
  // Newest first: a folder created inside another one this run created is removed before it.
  for (auto dir = state_->created_directories.rbegin(); dir != state_->created_directories.rend(); ++dir) {
    std::filesystem::remove(*dir, ec);
  }
}

Status OutputSet::add_input(const std::string& path) {
  const auto id = format::file_id(path);
  if (!id) return Status();
  for (const State::Output& o : state_->outputs) {
    if (o.id == id) return Status(StatusCode::kInvalidArgument, o.path + ": this output is the input file " + path);
  }
  state_->inputs.push_back({path, *id});
  return Status();
}

Status OutputSet::add_output(const std::string& path) {
  RGS_RETURN_IF_ERROR(format::check_output_file(path, {}));  // a file name, not a directory, device or pipe
  State::Output out;
  out.path = path;
  std::tie(out.dir, out.name) = split_path(path);
  out.key = output_key(path);
  out.id = format::file_id(path);
  for (const State::Input& in : state_->inputs) {  // identities as recorded by add_input
    if (out.id == in.id) {
      return Status(StatusCode::kInvalidArgument, path + ": this output is the input file " + in.path + " (same file)");
    }
  }
  for (const State::Output& o : state_->outputs) {
    if (o.key == out.key || (out.id && o.id == out.id)) {
      return Status(StatusCode::kInvalidArgument, path + ": this output is also the output " + o.path + " (same file)");
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
  const std::string suffix = format::kPartialSuffix;
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
      if (format::is_pending_temporary(temp)) continue;  // ours, being written
      const auto id = format::file_id(temp);
      bool is_input = false;
      for (const State::Input& in : state_->inputs) is_input = is_input || (id && in.id == *id);
      notes.push_back(remove_stale(temp, pid, is_input));
    }
  }
  return notes;
}

Status OutputSet::write(const std::string& path, const format::ChunkProducer& produce) {
  RGS_ASSIGN_OR_RETURN(State::Output * out, state_->restage(path));
  RGS_ASSIGN_OR_RETURN(out->staged, format::StagedFile::write(path, produce));
  return Status();
}

Status OutputSet::write_by_name(const std::string& path, const format::ByNameWriter& write_to) {
  RGS_ASSIGN_OR_RETURN(State::Output * out, state_->restage(path));
  RGS_ASSIGN_OR_RETURN(out->staged, format::StagedFile::write_by_name(path, write_to));
  return Status();
}

Status OutputSet::commit() {
  RGS_RETURN_ERROR_IF(state_->closed, StatusCode::kInvalidArgument, "the outputs of this run were already committed");
  state_->closed = true;
  // An interrupt between two renames would leave some outputs new and some old.
  sigset_t block, previous;
  sigemptyset(&block);
  sigaddset(&block, SIGINT);
  sigaddset(&block, SIGTERM);
  sigaddset(&block, SIGHUP);
  const bool masked = ::pthread_sigmask(SIG_BLOCK, &block, &previous) == 0;
  Status status;
  for (State::Output& o : state_->outputs) {
    if (!o.staged) continue;
    if (status.ok()) status = o.staged->commit();
    o.staged.reset();  // after a failure, the rest are removed
  }
  if (masked) ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  if (status.ok()) state_->created_directories.clear();
  return status;
}

bool OutputSet::has_output(const std::string& path) const { return state_->find(path) != nullptr; }

Status OutputSet::create_directory(const std::string& path, const std::string& what) {
  std::error_code ec;
  const bool existed = std::filesystem::exists(path, ec);
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path)) {
    return Status(StatusCode::kIoError, path + ": cannot create " + what + (ec ? ": " + ec.message() : std::string()));
  }
  if (!existed) state_->created_directories.push_back(path);
  return Status();
}

}  // namespace rgs::tools
