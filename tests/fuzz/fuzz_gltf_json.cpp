// Fuzz target: the JSON of a .gltf scene, read by read_scene as scene/scene.gltf next to a real buffer
// (scene/scene.bin: guitar's first 256 Gaussians, tests/data/hostile/gltf/scene.bin). The folder around the
// scene holds canaries: scene.bin and canary.bin, copies of that buffer, so that a buffer uri leaving the
// scene folder ('..', an absolute path, their percent-encoded spellings) would find a valid buffer there.
// Any input must give ok or an error Status: never a crash, hang, leak or undefined behaviour; no canary is
// ever opened (fuzz_scene_folder.h); errors name the file and quote little of the input; what the reader
// accepts converts as rgs-convert does (fuzz_sanitized_cloud.h). Seeds: corpus/gltf_json/
// (make_fuzz_corpus.py).
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fuzz_sanitized_cloud.h"
#include "fuzz_scene_folder.h"
#include "rgs/converter/scene_reader.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const rgs::fuzz::SceneFolder dir("gltf_json");
  static const bool ready = [] {
    const auto bin = rgs::fuzz::SceneFolder::read(RGS_GLTF_BUFFER);
    RGS_FUZZ_CHECK(!bin.empty(), std::string("cannot read ") + RGS_GLTF_BUFFER);
    rgs::fuzz::SceneFolder::write(dir.scene() / "scene.bin", bin);
    dir.add_canary("scene.bin", bin);
    dir.add_canary("canary.bin", bin);
    return true;
  }();
  (void)ready;
  const std::string path = (dir.scene() / "scene.gltf").string();
  rgs::fuzz::SceneFolder::write(path, std::vector<uint8_t>(data, data + size));
  auto read = [&](const uint8_t*, size_t, const std::string&, const rgs::converter::SceneReadOptions& options) {
    dir.forget_events();
    auto result = rgs::converter::read_scene(path, options);
    const std::string opened = dir.opened_outside();
    RGS_FUZZ_CHECK(opened.empty(), "read_scene opened '" + opened + "' outside the scene folder (" +
                                       (result.ok() ? std::string("and read the scene") : result.status().to_string()) +
                                       ")");
    rgs::fuzz::check_scene_error(result.status(), path);
    return result;
  };
  rgs::fuzz::check_reader(read, rgs::converter::SceneReadOptions{}, data, size);
  return 0;
}
