// Scene and camera loading shared by rgs-render and rgs-audit.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "read_limits_option.h"
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

/// Loads `path`: a .rgs file (RgsFile::open with read_limits() + read_scene, which checks checksums, frames
/// and the value rules of SPEC §4.3-4.7 before allocating, + dequantize) when it starts with the .rgs magic
/// or ends in .rgs, otherwise a 3DGS PLY (converter::read_ply, invalid values rejected). Errors name `path`.
Result<LoadedScene> load_scene(const std::string& path);

/// Largest Gaussian count a scene may have on the GPU (GpuScene and converter::replicate: 2^31 − 1).
inline constexpr uint64_t kMaxGpuGaussians = 0x7fffffff;

/// A scene tiled K times for benchmarks (rgs-bench --replicate), as the bytes of a complete .rgs file so that
/// the GPU loads it through the path of a file (format::RgsFile::from_bytes, runtime::GpuScene::from_rgs):
/// the compact attributes come with it.
struct ReplicatedScene {
  /// A .rgs file (SPEC v1.0), every section uncompressed; provenance gains "replicated" = K.
  std::vector<uint8_t> rgs_bytes;
  /// Bounds of all copies (the .rgs metadata): orbit cameras framed on them see the whole grid.
  format::SceneBounds bounds;
  uint64_t source_gaussians = 0;
  uint64_t gaussians = 0;  ///< copies × source_gaussians
  uint32_t copies = 1;
  uint32_t sh_degree = 0;
  bool source_is_rgs = false;
  uint64_t source_file_bytes = 0;
  /// How the copies were quantized: the source .rgs's own quantization (attributes copied unchanged), or
  /// converter::quantize with the default QuantizeOptions for a PLY source.
  std::string quantization;
};

/// Reads `path` and tiles it `copies` times with converter::replicate (a grid in the x–z plane, see
/// replicate.h). A .rgs source is replicated as stored (its quantized sections, scales and provenance kept);
/// a PLY source is first quantized with the default QuantizeOptions (linear scales, SH max scale), exactly
/// what `rgs-convert in.ply out.rgs` writes without options. For a .rgs file the Gaussian count is checked
/// from the header before any section is read.
/// Errors: kInvalidArgument (copies 0), kLimitExceeded (copies × Gaussians > kMaxGpuGaussians, naming both
/// numbers), those of reading `path` (which they name) and of quantizing/serializing.
Result<ReplicatedScene> replicate_scene_file(const std::string& path, uint32_t copies);

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
