// Fuzz target: a bundled SOG (.sog, a ZIP archive of meta.json and its WebP images) read by read_sog from
// a file of this process. The archive's end record, central directory, local headers, sizes, methods,
// CRCs and names, and the meta.json inside, all come from the input. Any input must give ok or an error
// Status: never a crash, leak or undefined behaviour, nor memory taken from sizes the archive declares
// (run_fuzzers.sh's -rss_limit_mb); errors name the file and quote little of the input; what the reader
// accepts converts as rgs-convert does (fuzz_sanitized_cloud.h). Seeds: corpus/zip/ (make_fuzz_corpus.py)
// and the bundles of tests/data/sog.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_sanitized_cloud.h"
#include "fuzz_scene_folder.h"
#include "rgs/converter/playcanvas_readers.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const rgs::fuzz::SceneFolder dir("zip");
  const std::string path = (dir.scene() / "bundle.sog").string();
  rgs::fuzz::SceneFolder::write(path, std::vector<uint8_t>(data, data + size));
  auto read = [&](const uint8_t*, size_t, const std::string&, const rgs::converter::SceneReadOptions& options) {
    auto result = rgs::converter::read_sog(path, options);
    rgs::fuzz::check_scene_error(result.status(), path);
    return result;
  };
  rgs::fuzz::check_reader(read, rgs::converter::SceneReadOptions{}, data, size);
  return 0;
}
