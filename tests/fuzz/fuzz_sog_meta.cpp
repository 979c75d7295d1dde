// Fuzz target: the meta.json of a PlayCanvas SOG scene, read by read_sog next to real images (the guitar crop
// of tests/data/sog/guitar_crop_sh3: 877 Gaussians, SH degree 3, splat-transform's WebP files). meta.json
// drives every count, image name, codebook and allocation of the reader, so mutating it alone reaches the
// checks of counts against image sizes, codebook lengths and SH bands. Any input must give ok or an error
// Status: never a crash, hang, leak or undefined behaviour; what the reader accepts must convert as
// rgs-convert does (fuzz_sanitized_cloud.h). Seeds: corpus/sog_meta/ (make_fuzz_corpus.py).
#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "fuzz_sanitized_cloud.h"
#include "rgs/converter/playcanvas_readers.h"

namespace {

namespace fs = std::filesystem;

/// A folder of this process holding copies of the fixture's images; removed at exit.
struct SceneDir {
  fs::path path = fs::temp_directory_path() / ("rgs_fuzz_sog_" + std::to_string(::getpid()));
  SceneDir() {
    fs::create_directories(path);
    for (const auto& entry : fs::directory_iterator(RGS_SOG_FIXTURE_DIR)) {
      if (entry.path().extension() == ".webp") {
        fs::copy_file(entry.path(), path / entry.path().filename(), fs::copy_options::overwrite_existing);
      }
    }
  }
  ~SceneDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};

const fs::path& scene_dir() {
  static const SceneDir dir;
  return dir.path;
}

/// read_sog on a folder whose meta.json holds `data`.
rgs::Result<rgs::converter::InputScene> read_sog_meta(const uint8_t* data, size_t size, const std::string&,
                                                      const rgs::converter::SceneReadOptions& options) {
  {
    std::ofstream meta(scene_dir() / "meta.json", std::ios::binary | std::ios::trunc);
    meta.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  return rgs::converter::read_sog(scene_dir().string(), options);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  rgs::fuzz::check_reader(&read_sog_meta, rgs::converter::SceneReadOptions{}, data, size);
  return 0;
}
