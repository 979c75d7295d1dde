// Fuzz target: a SOG folder read by read_sog, with its meta.json and what stands at one image's name both
// taken from the input. The folder holds the seven real images of tests/data/sog/guitar_crop_sh3 (877
// Gaussians, SH degree 3); the folder around it holds canaries, copies of the same seven images under the
// same names, so that a name leaving the folder or a link out of it would find a valid image.
//
// Input: byte 0 picks what replaces the image of slot byte 1 (mod 7, in the order of kImages) before the read:
//   0 nothing, 1 removed, 2 a symbolic link to its canary, 3 a FIFO, 4 a folder, 5 moved to sub/<name>;
// the rest is meta.json.
// Any input must give ok or an error Status: never a crash, leak or undefined behaviour, never a read
// blocked on the FIFO (fuzz_scene_folder.h frees it after 2 s and reports it) and never a canary opened;
// errors name the file and quote little of the input; what the reader accepts converts as rgs-convert does
// (fuzz_sanitized_cloud.h). Seeds: corpus/sog_folder/ (make_fuzz_corpus.py).
#include <sys/stat.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "fuzz_sanitized_cloud.h"
#include "fuzz_scene_folder.h"
#include "rgs/converter/playcanvas_readers.h"

namespace {

namespace fs = std::filesystem;

constexpr const char* kImages[] = {"means_l.webp", "means_u.webp",       "quats.webp",     "scales.webp",
                                   "sh0.webp",     "shN_centroids.webp", "shN_labels.webp"};
constexpr size_t kImageCount = sizeof(kImages) / sizeof(kImages[0]);
enum Change : uint8_t { kKeep, kRemove, kSymlink, kFifo, kFolder, kMove, kChangeCount };

struct Scene {
  rgs::fuzz::SceneFolder dir{"sog_folder"};
  std::vector<uint8_t> images[kImageCount];
  Scene() {
    for (size_t i = 0; i < kImageCount; ++i) {
      images[i] = rgs::fuzz::SceneFolder::read(fs::path(RGS_SOG_FIXTURE_DIR) / kImages[i]);
      RGS_FUZZ_CHECK(!images[i].empty(), std::string("cannot read the fixture's ") + kImages[i]);
      dir.add_canary(kImages[i], images[i]);
    }
  }
  /// Puts back the seven images (whatever stands at their names) and removes sub/.
  void restore() const {
    std::error_code ec;
    fs::remove_all(dir.scene() / "sub", ec);
    for (size_t i = 0; i < kImageCount; ++i) {
      const fs::path p = dir.scene() / kImages[i];
      fs::remove_all(p, ec);
      rgs::fuzz::SceneFolder::write(p, images[i]);
    }
  }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const Scene scene;
  if (size < 2) return 0;
  const auto change = static_cast<Change>(data[0] % kChangeCount);
  const size_t slot = data[1] % kImageCount;
  scene.restore();
  const fs::path target = scene.dir.scene() / kImages[slot];
  std::error_code ec;
  switch (change) {
    case kKeep: break;
    case kRemove: fs::remove(target, ec); break;
    case kSymlink:
      fs::remove(target, ec);
      fs::create_symlink(scene.dir.root() / kImages[slot], target, ec);
      break;
    case kFifo:
      fs::remove(target, ec);
      RGS_FUZZ_CHECK(::mkfifo(target.c_str(), 0600) == 0, "mkfifo failed");
      break;
    case kFolder:
      fs::remove(target, ec);
      fs::create_directory(target, ec);
      break;
    case kMove:
      fs::create_directory(scene.dir.scene() / "sub", ec);
      fs::rename(target, scene.dir.scene() / "sub" / kImages[slot], ec);
      break;
    case kChangeCount: break;
  }
  const std::string meta = (scene.dir.scene() / "meta.json").string();
  rgs::fuzz::SceneFolder::write(meta, std::vector<uint8_t>(data + 2, data + size));
  auto read = [&](const uint8_t*, size_t, const std::string&, const rgs::converter::SceneReadOptions& options) {
    scene.dir.forget_events();
    std::unique_ptr<rgs::fuzz::FifoWatchdog> watchdog;
    if (change == kFifo) watchdog = std::make_unique<rgs::fuzz::FifoWatchdog>(target.string());
    auto result = rgs::converter::read_sog(scene.dir.scene().string(), options);
    RGS_FUZZ_CHECK(!watchdog || !watchdog->blocked(),
                   "read_sog waited on the FIFO " + target.string() + " until it was freed");
    const std::string opened = scene.dir.opened_outside();
    RGS_FUZZ_CHECK(opened.empty(), "read_sog opened '" + opened + "' outside the scene folder (" +
                                       (result.ok() ? std::string("and read the scene") : result.status().to_string()) +
                                       ")");
    rgs::fuzz::check_scene_error(result.status(), meta);
    return result;
  };
  rgs::fuzz::check_reader(read, rgs::converter::SceneReadOptions{}, data, size);
  return 0;
}
