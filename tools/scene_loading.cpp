#include "scene_loading.h"

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "cli_common.h"
#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"

namespace rgs::tools {

namespace {
bool has_rgs_magic(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[8] = {};
  in.read(head, 8);
  return in.gcount() == 8 && std::memcmp(head, format::kMagic, 8) == 0;
}
}  // namespace

bool is_rgs_path(const std::string& path) { return has_rgs_magic(path) || extension_of(path) == ".rgs"; }

Result<LoadedScene> load_scene(const std::string& path) {
  LoadedScene scene;
  if (is_rgs_path(path)) {
    RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(path));
    RGS_ASSIGN_OR_RETURN(format::EncodedScene encoded, file.read_scene());
    auto cloud = format::dequantize(encoded);
    if (!cloud.ok()) return Status(cloud.status()).prepend(path);
    scene.cloud = std::move(cloud).value();
    scene.bounds = file.metadata().bounds;
    scene.is_rgs = true;
    scene.file_bytes = file.file_size();
    return scene;
  }
  RGS_ASSIGN_OR_RETURN(converter::PlyScene ply, converter::read_ply(path));
  scene.cloud = std::move(ply.cloud);
  scene.bounds = converter::compute_bounds(scene.cloud);
  scene.file_bytes = ply.file_bytes;
  return scene;
}

Result<std::vector<runtime::Camera>> make_cameras(const CameraChoice& choice, const format::SceneBounds& bounds) {
  std::vector<runtime::Camera> cameras;
  if (!choice.cameras_path.empty()) {
    runtime::InriaCameraOptions options;
    options.every_kth = choice.every;
    options.width = choice.width;
    options.height = choice.height;
    RGS_ASSIGN_OR_RETURN(cameras, runtime::load_inria_cameras(choice.cameras_path, options));
  } else {
    RGS_RETURN_ERROR_IF(choice.orbit == 0, StatusCode::kInvalidArgument, "--orbit needs at least 1 camera");
    uint32_t w = choice.width, h = choice.height;
    if (w == 0 && h == 0) {
      w = choice.orbit_width;
      h = choice.orbit_height;
    } else if (h == 0) {
      h = static_cast<uint32_t>(std::max(1.0, std::round(double(w) * choice.orbit_height / choice.orbit_width)));
    } else if (w == 0) {
      w = static_cast<uint32_t>(std::max(1.0, std::round(double(h) * choice.orbit_width / choice.orbit_height)));
    }
    RGS_ASSIGN_OR_RETURN(cameras, runtime::orbit_cameras(bounds, choice.orbit, w, h));
  }
  if (choice.limit > 0 && cameras.size() > choice.limit) cameras.resize(choice.limit);
  return cameras;
}

std::string file_safe_name(const std::string& name, size_t index) {
  if (name.empty()) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "view_%03zu", index);
    return buf;
  }
  std::string out = name;
  for (char& ch : out) {
    if (ch == '/' || ch == '\\' || static_cast<unsigned char>(ch) < 32) ch = '_';
  }
  if (out == "." || out == "..") out = "view_" + std::to_string(index);
  return out;
}

}  // namespace rgs::tools
