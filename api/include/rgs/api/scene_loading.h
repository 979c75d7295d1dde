// Scene and camera loading for the host: the implementation the tools (rgs-render, rgs-audit, rgs-bench)
// and the front door (scene.h) share.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"
#include "rgs/converter/scene_reader.h"
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

/// Which views to render.
struct CameraChoice {
  /// INRIA cameras.json; empty: an orbit.
  std::string cameras_path;
  uint32_t every = 1;  ///< every k-th camera of the file
  uint32_t limit = 0;  ///< at most this many key views of the file, or views of an orbit or path (0 = all)
  /// With cameras_path: this many views flown through the file's cameras (after `every` and `limit`) in order
  /// (runtime::fly_through_cameras: a centripetal Catmull–Rom spline through their centres at steady speed,
  /// rotations slerped), at width × height as for the file's cameras; 0: the file's cameras themselves.
  /// Needs cameras_path.
  uint32_t fly = 0;
  uint32_t orbit = 0;  ///< orbit camera count when cameras_path is empty
  /// Camera path view count (runtime::path_cameras: a rising spiral, near and far) when cameras_path is
  /// empty; used instead of `orbit` when not 0.
  uint32_t path = 0;
  /// Requested size; 0 = default (cameras: the file's own; orbit: `orbit_width` × `orbit_height`). With only
  /// one side given, the other keeps the default's aspect ratio.
  uint32_t width = 0, height = 0;
  uint32_t orbit_width = 1920, orbit_height = 1080;
};

/// Builds the cameras: runtime::load_inria_cameras (field of view kept on resize), flown through with
/// runtime::fly_through_cameras when `fly` is set (keys whose sizes differ are first resized to the first key's
/// size, field of view kept), runtime::path_cameras or runtime::orbit_cameras around `bounds`.
/// Errors: those of the loaders and of fly_through_cameras (prefixed with the cameras path: e.g. fewer than 2
/// cameras left after `every` and `limit`); kInvalidArgument for an orbit of 0 cameras or `fly` without
/// cameras_path.
Result<std::vector<runtime::Camera>> make_cameras(const CameraChoice& choice, const format::SceneBounds& bounds);

}  // namespace rgs::api
