// Scene and camera loading shared by rgs-render and rgs-audit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"

namespace rgs::tools {

/// A scene ready to render: float Gaussians and their bounds.
struct LoadedScene {
  /// Activated float Gaussians (a PLY as read, or a .rgs dequantized).
  format::GaussianCloud cloud;
  /// .rgs: the file's metadata bounds; PLY: converter::compute_bounds.
  format::SceneBounds bounds;
  /// True when the input was a .rgs file (sniffed by its magic, not its extension).
  bool is_rgs = false;
  uint64_t file_bytes = 0;
};

/// True when `path` is to be read as a .rgs file: it starts with the .rgs magic or ends in .rgs (so a
/// missing or truncated "x.rgs" still gets the .rgs reader's error).
bool is_rgs_path(const std::string& path);

/// Loads `path`: a .rgs file (RgsFile::open + read_scene + dequantize) when it starts with the .rgs magic or
/// ends in .rgs, otherwise a 3DGS PLY (converter::read_ply, invalid values rejected). Errors name `path`.
Result<LoadedScene> load_scene(const std::string& path);

/// Which views to render.
struct CameraChoice {
  /// INRIA cameras.json; empty: an orbit.
  std::string cameras_path;
  uint32_t every = 1;  ///< every k-th camera of the file
  uint32_t limit = 0;  ///< at most this many views (0 = all)
  uint32_t orbit = 0;  ///< orbit camera count when cameras_path is empty
  /// Requested size; 0 = default (cameras: the file's own; orbit: `orbit_width` × `orbit_height`). With only
  /// one side given, the other keeps the default's aspect ratio.
  uint32_t width = 0, height = 0;
  uint32_t orbit_width = 1920, orbit_height = 1080;
};

/// Builds the cameras: load_inria_cameras (field of view kept on resize) or orbit_cameras around `bounds`.
Result<std::vector<runtime::Camera>> make_cameras(const CameraChoice& choice, const format::SceneBounds& bounds);

/// A view name usable as a file name: '/', '\\' and control characters replaced by '_'; "view_<i>" if empty.
std::string file_safe_name(const std::string& name, size_t index);

}  // namespace rgs::tools
