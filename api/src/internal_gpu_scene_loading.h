// Loading a scene straight into GPU memory, shared by the front door and the lab's rgs-bench. Available only with
// RGS_WITH_CUDA (rgs/config.h: RGS_HAS_CUDA).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "rgs/converter/scene_reader.h"
#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/runtime/gpu_scene.h"

namespace rgs::api {

/// A scene in device memory, with what the tools print about it.
struct LoadedGpuScene {
  runtime::GpuScene scene;
  /// .rgs: the file's metadata bounds; other formats: converter::compute_bounds (also given to the GpuScene).
  format::SceneBounds bounds;
  /// True for a .rgs input (then scene.has_compact()); sniffed by its magic or the .rgs extension.
  bool is_rgs = false;
  uint64_t file_bytes = 0;
  /// The format in words, as converter::InputScene::description.
  std::string description;
  /// What the reader noted, as converter::InputScene::notes.
  std::vector<std::string> notes;
};

/// Checks that a CUDA device can be used and makes `ordinal` current on the calling thread. Errors:
/// kUnsupportedFeature when the CUDA runtime sees no device (the message carries its reason) or `ordinal`
/// is out of range; kCudaError from cudaSetDevice.
Status require_cuda_device(int ordinal = 0);

/// Uploads an opened .rgs file onto the current device through GpuScene::from_rgs(options) (sections uploaded
/// as stored, no host decode; FP32 arrays only with options.fp32_attributes); `name` appears in errors. is_rgs
/// is true, file_bytes = `source_file_bytes`. Synchronous on `stream`.
Result<LoadedGpuScene> upload_rgs_file(const format::RgsFile& file, uint64_t source_file_bytes, const std::string& name,
                                       const runtime::GpuSceneOptions& options = {}, cudaStream_t stream = nullptr);

}  // namespace rgs::api
