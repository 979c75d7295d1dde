// What the fuzz targets of multi-file scenes (fuzz_gltf_json.cpp, fuzz_sog_folder.cpp, fuzz_zip.cpp) assert
// about the files a reader touches: a scene folder of this process inside a root folder whose other files
// are canaries (copies of scene files, so that a reader escaping the scene folder would find a valid file),
// an inotify watch that reports any canary opened, a watchdog that frees a read blocked on a FIFO and says
// so, and the bounds on error messages (they name the file; they quote little of the input).
#pragma once

#include <fcntl.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "fuzz_check.h"
#include "rgs/format/status.h"

namespace rgs::fuzz {

/// Longest error message accepted: a few paths of this process and at most ~200 characters of the input.
constexpr size_t kMaxMessageBytes = 2048;

/// root/ (canaries) and root/scene/ (the scene), under the temp folder, named after the process; removed
/// at exit. Linux: inotify reports what is opened in root/.
class SceneFolder {
 public:
  explicit SceneFolder(const std::string& tag)
      : root_(std::filesystem::temp_directory_path() / ("rgs_fuzz_" + tag + "_" + std::to_string(::getpid()))),
        scene_(root_ / "scene") {
    std::filesystem::remove_all(root_);
    std::filesystem::create_directories(scene_);
    inotify_ = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    RGS_FUZZ_CHECK(inotify_ >= 0, "inotify_init1 failed");
    RGS_FUZZ_CHECK(::inotify_add_watch(inotify_, root_.c_str(), IN_OPEN | IN_ACCESS) >= 0, "inotify_add_watch failed");
  }
  ~SceneFolder() {
    ::close(inotify_);
    std::error_code ec;
    std::filesystem::remove_all(root_, ec);
  }
  SceneFolder(const SceneFolder&) = delete;
  SceneFolder& operator=(const SceneFolder&) = delete;

  const std::filesystem::path& root() const { return root_; }
  const std::filesystem::path& scene() const { return scene_; }

  /// Writes `bytes` as root/`name` (outside the scene folder).
  void add_canary(const std::string& name, const std::vector<uint8_t>& bytes) const { write(root_ / name, bytes); }

  /// Discards the events seen so far (call before a read).
  void forget_events() const { (void)opened_outside(); }

  /// The name of a file of root/ (outside the scene folder) opened or read since the last call, or "".
  /// Folders are not counted: a reader may open the scene folder, or walk through root/ to it.
  std::string opened_outside() const {
    alignas(inotify_event) char buf[4096];
    std::string found;
    for (;;) {
      const ssize_t n = ::read(inotify_, buf, sizeof(buf));
      if (n <= 0) break;
      for (ssize_t at = 0; at < n;) {
        const auto* e = reinterpret_cast<const inotify_event*>(buf + at);
        if (!(e->mask & IN_ISDIR) && e->len > 0 && found.empty()) found = e->name;
        at += static_cast<ssize_t>(sizeof(inotify_event) + e->len);
      }
    }
    return found;
  }

  static void write(const std::filesystem::path& path, const std::vector<uint8_t>& bytes) {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  static std::vector<uint8_t> read(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }

 private:
  std::filesystem::path root_;
  std::filesystem::path scene_;
  int inotify_ = -1;
};

/// While alive, watches a read that may meet the FIFO `path`: after `grace`, it opens the FIFO for writing
/// (which succeeds only while a reader holds it open, blocked or not) and closes it again, so that a read
/// blocked there returns. blocked() says whether that happened: a reader that opens a FIFO must not wait.
class FifoWatchdog {
 public:
  explicit FifoWatchdog(std::string path, std::chrono::milliseconds grace = std::chrono::milliseconds(2000))
      : path_(std::move(path)), thread_([this, grace] { watch(grace); }) {}
  ~FifoWatchdog() { stop(); }
  FifoWatchdog(const FifoWatchdog&) = delete;
  FifoWatchdog& operator=(const FifoWatchdog&) = delete;

  /// Ends the watch (call when the read has returned); true when the read had to be freed.
  bool blocked() {
    stop();
    return blocked_;
  }

 private:
  void watch(std::chrono::milliseconds grace) {
    std::unique_lock<std::mutex> lock(mutex_);
    if (cv_.wait_for(lock, grace, [this] { return done_; })) return;
    while (!done_) {
      const int fd = ::open(path_.c_str(), O_WRONLY | O_NONBLOCK | O_CLOEXEC);
      if (fd >= 0) {
        blocked_ = true;
        ::close(fd);
      }
      cv_.wait_for(lock, std::chrono::milliseconds(50), [this] { return done_; });
    }
  }
  void stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      done_ = true;
    }
    cv_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

  std::string path_;
  std::mutex mutex_;
  std::condition_variable cv_;
  bool done_ = false;
  bool blocked_ = false;
  std::thread thread_;
};

/// An error of a read of `path`: it names the file (`path`'s folder, or a file in it) and stays short.
inline void check_scene_error(const Status& status, const std::string& path) {
  if (status.ok()) return;
  const std::string folder = std::filesystem::path(path).parent_path().string();
  RGS_FUZZ_CHECK(status.message().find(folder) != std::string::npos,
                 "the error does not name the file: " + status.to_string());
  RGS_FUZZ_CHECK(
      status.message().size() <= kMaxMessageBytes,
      "an error message of " + std::to_string(status.message().size()) + " bytes: " + status.message().substr(0, 300));
}

}  // namespace rgs::fuzz
