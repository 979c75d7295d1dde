// OutputTransaction: the outputs of one run, staged and committed together; the temporaries earlier runs left
// behind, removed once their process is gone.
#include "rgs/format/output_transaction.h"

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

#include "internal_file_io.h"

namespace rgs::format {
namespace {

using detail::join_path;
using detail::split_path;

/// Where an output goes: its directory's identity and its last component, or the path as written when the
/// directory cannot be examined (the write reports why).
struct OutputKey {
  std::optional<FileId> dir;
  std::string name;
  std::string lexical;
  bool operator==(const OutputKey& o) const {
    if (dir.has_value() != o.dir.has_value()) return false;
    return dir ? (*dir == *o.dir && name == o.name) : lexical == o.lexical;
  }
};

/// The path an output will have once the folders a sink creates for it exist: its existing part with symbolic
/// links resolved, the rest normalized ("out/new/../x" is "out/x" once "new" is a folder). The identity rules
/// compare that path, so a spelling through a folder not made yet cannot name an input or another output unseen.
std::string as_written(const std::string& path) {
  std::error_code ec;
  const std::filesystem::path resolved = std::filesystem::weakly_canonical(path, ec);
  return ec || resolved.empty() ? path : resolved.string();
}

OutputKey output_key(const std::string& given) {
  OutputKey key;
  std::string dir;
  const std::string path = as_written(given);
  std::tie(dir, key.name) = split_path(path);
  key.dir = file_id(dir);
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

struct OutputTransaction::State {
  struct Input {
    std::string path;
    FileId id;
  };
  struct Output {
    std::string path;
    std::string dir, name;
    OutputKey key;
    std::optional<FileId> id;      ///< when it exists
    std::optional<StagedFile> staged;  ///< its content, once written
    bool replaced = false;             ///< it existed and commit() renamed its new content over it
  };
  struct CreatedFolder {
    std::string path;
    size_t slot;  ///< in the table an interrupt walks (internal_file_io.h)
  };
  std::vector<Input> inputs;
  std::vector<Output> outputs;
  std::vector<CreatedFolder> created_folders;  ///< removed when empty unless the commit succeeds
  bool closed = false;

  /// Unregisters the created folders from the interrupt's table, removing them first unless `keep`.
  void release_folders(bool keep) {
    std::error_code ec;
    // Newest first: a folder created inside another one is removed before it.
    for (auto folder = created_folders.rbegin(); folder != created_folders.rend(); ++folder) {
      if (!keep) std::filesystem::remove(folder->path, ec);
      detail::unregister_created_folder(folder->slot);
    }
    created_folders.clear();
  }

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

OutputTransaction::OutputTransaction() : state_(std::make_unique<State>()) {}

OutputTransaction::~OutputTransaction() {
  state_->outputs.clear();  // the temporaries first, so that a folder this run created can be empty
  state_->release_folders(false);
}

Status OutputTransaction::add_input(const std::string& path) {
  const auto id = file_id(path);
  if (!id) return Status();
  for (const State::Output& o : state_->outputs) {
    if (o.id == id) return Status(StatusCode::kInvalidArgument, o.path + ": this output is the input file " + path);
  }
  for (const State::Input& in : state_->inputs) {
    if (in.id == *id) return Status();
  }
  state_->inputs.push_back({path, *id});
  return Status();
}

Status OutputTransaction::add_output(const std::string& path) {
  RGS_RETURN_IF_ERROR(check_output_file(path, {}));  // a file name, not a directory, device or pipe
  State::Output out;
  out.path = path;
  std::tie(out.dir, out.name) = split_path(path);
  out.key = output_key(path);
  out.id = file_id(as_written(path));
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

Status OutputTransaction::declare(const std::vector<std::string>& paths) {
  for (const std::string& path : paths) {
    if (!has_output(path)) RGS_RETURN_IF_ERROR(add_output(path));
  }
  return Status();
}

std::vector<std::string> OutputTransaction::remove_stale_temporaries() {
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
      if (is_pending_temporary(temp)) continue;  // ours, being written
      const auto id = file_id(temp);
      bool is_input = false;
      for (const State::Input& in : state_->inputs) is_input = is_input || (id && in.id == *id);
      notes.push_back(remove_stale(temp, pid, is_input));
    }
  }
  return notes;
}

Status OutputTransaction::write(const std::string& path, const ChunkProducer& produce) {
  RGS_ASSIGN_OR_RETURN(State::Output * out, state_->restage(path));
  RGS_ASSIGN_OR_RETURN(out->staged, StagedFile::write(path, produce));
  return Status();
}

Status OutputTransaction::write_by_name(const std::string& path, const ByNameWriter& write_to) {
  RGS_ASSIGN_OR_RETURN(State::Output * out, state_->restage(path));
  RGS_ASSIGN_OR_RETURN(out->staged, StagedFile::write_by_name(path, write_to));
  return Status();
}

Status OutputTransaction::commit() {
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
    if (status.ok()) {
      status = o.staged->commit();
      o.replaced = status.ok() && o.id.has_value();
    }
    o.staged.reset();  // after a failure, the rest are removed
  }
  if (status.ok()) state_->release_folders(true);
  if (masked) ::pthread_sigmask(SIG_SETMASK, &previous, nullptr);
  return status;
}

std::vector<std::string> OutputTransaction::replaced() const {
  std::vector<std::string> paths;
  for (const State::Output& o : state_->outputs) {
    if (o.replaced) paths.push_back(o.path);
  }
  return paths;
}

bool OutputTransaction::has_output(const std::string& path) const { return state_->find(path) != nullptr; }

Status OutputTransaction::create_folder(const std::string& path) {
  std::error_code ec;
  // Each missing ancestor is created (and registered) on its own, so that all of them can be removed again.
  std::vector<std::filesystem::path> missing;
  for (std::filesystem::path p = path; !p.empty() && !std::filesystem::exists(p, ec); p = p.parent_path()) {
    missing.push_back(p);
    if (p == p.parent_path()) break;
  }
  for (auto p = missing.rbegin(); p != missing.rend(); ++p) {
    // Registered before it exists: an interrupt between the two finds nothing to remove, never a folder it
    // does not know.
    const size_t slot = detail::register_created_folder(p->string());
    if (!std::filesystem::create_directory(*p, ec) && !ec) {
      detail::unregister_created_folder(slot);  // created by someone else meanwhile: not ours to remove
      continue;
    }
    if (ec) {
      detail::unregister_created_folder(slot);
      break;
    }
    state_->created_folders.push_back({p->string(), slot});
  }
  if (ec || !std::filesystem::is_directory(path)) {
    return Status(StatusCode::kIoError, path + ": cannot create folder" + (ec ? ": " + ec.message() : std::string()));
  }
  return Status();
}

}  // namespace rgs::format
