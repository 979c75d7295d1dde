// Scene loading for the host: the implementation behind the front door (scene.h), shared with the lab's
// benchmarks and the tests. Private to the build: never installed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/api/camera.h"
#include "rgs/runtime/camera.h"

namespace rgs::api {

/// A scene in host memory: float Gaussians and their bounds.
struct HostScene {
  /// Activated float Gaussians (another format as read, or a .rgs dequantized: format::GaussianCloud's layout).
  format::GaussianCloud cloud;
  /// .rgs: the file's metadata bounds; other formats: converter::compute_bounds.
  format::SceneBounds bounds;
  /// True when the input was a .rgs file (sniffed by its magic, not its extension).
  bool is_rgs = false;
  uint64_t file_bytes = 0;
  /// "rgs", or converter::InputScene::format_id ("ply", "sog", "spz", ...).
  std::string format_id;
  /// The format in words ("RoofGS .rgs", "binary_little_endian PLY", "Niantic SPZ v4 ...").
  std::string description;
  /// What the reader noted (converter::InputScene::notes: the SPZ axes assumed, ignored fields), for the
  /// tools to print.
  std::vector<std::string> notes;
};

/// True when `path` is to be read as a .rgs file: it starts with the .rgs magic or ends in .rgs (so a
/// missing or truncated "x.rgs" still gets the .rgs reader's error). The format library's test, shared with
/// the audit's scene loading.
using format::is_rgs_path;

/// Loads `path` into host memory through converter::read_scene(path, options): any format it detects (a .rgs
/// file dequantized; 3DGS PLY, PlayCanvas compressed PLY / SOG, SPZ, glTF, .splat). Errors name `path`: those
/// of read_scene.
Result<HostScene> load_host_scene(const std::string& path, const converter::SceneReadOptions& options = {});



}  // namespace rgs::api
