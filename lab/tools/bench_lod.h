// rgs-bench's streamed mode: a level-of-detail scene rendered under a splat and memory budget along a camera
// path (runtime::LodStreamer), each frame timed, with its quality against the full detail rendered 2x2 supersampled
// (docs/LOD.md#measuring-quality).
#pragma once

#include <cstdint>
#include <string>
#include <functional>
#include <vector>

#include "rgs/format/status.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/lod_streamer.h"
#include "rgs/format/output_transaction.h"

namespace rgs::tools {

struct LodBenchOptions {
  std::string input;
  /// > 1: the input tiled this many times (lab::replicate) and given levels of detail in memory
  /// (converter::build_lod with `lod_levels`), the recipe of the big scene in docs/LOD.md.
  uint32_t replicate = 1;
  uint32_t lod_levels = 0;  ///< 0: auto
  runtime::LodStreamOptions stream;
  uint64_t scratch_budget = 0;  ///< GpuRenderOptions::scratch_budget
  /// Also render the full detail of every view at 1x and 2x and score the levels and the plain full render against
  /// the supersampled reference (PSNR, SSIM) and the popping along the path, where it fits the device
  /// (docs/LOD.md#measuring-quality).
  bool quality = true;
  std::string json_path;
  /// With replicate > 1: also write the level-of-detail file built in memory here (for rgs-view and the viewer
  /// benchmark, which read files).
  std::string save_path;
};

/// Loads or builds the scene, makes the cameras with `make_cameras(bounds)`, renders every view once in path
/// order (a fly-through from a cold pool), prints a line per view and a summary (median and 95th percentile
/// frame time, splats, bytes streamed and resident; with `quality` PSNR, SSIM, the floor and the popping), and writes
/// the JSON to `outputs`.
Status bench_lod(const LodBenchOptions& options,
                 const std::function<Result<std::vector<runtime::Camera>>(const format::SceneBounds&)>& make_cameras,
                 format::OutputTransaction& outputs);

}  // namespace rgs::tools
