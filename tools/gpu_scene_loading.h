// Loading a scene straight into GPU memory for rgs-render --backend cuda and rgs-bench. Built only with
// RGS_WITH_CUDA (rgs/config.h: RGS_HAS_CUDA).
#pragma once

#include <cstdint>
#include <string>

#include "rgs/format/metadata.h"
#include "rgs/format/status.h"
#include "rgs/runtime/gpu_scene.h"
#include "scene_loading.h"

namespace rgs::tools {

/// A scene in device memory, with what the tools print about it.
struct LoadedGpuScene {
  runtime::GpuScene scene;
  /// .rgs: the file's metadata bounds; PLY: converter::compute_bounds (also given to the GpuScene).
  format::SceneBounds bounds;
  /// True for a .rgs input (then scene.has_compact()); sniffed by its magic or the .rgs extension.
  bool is_rgs = false;
  uint64_t file_bytes = 0;
};

/// Checks that a CUDA device can be used and makes `ordinal` current. Errors: kUnsupportedFeature when the
/// CUDA runtime sees no device (the message carries runtime::cuda_device_count's reason) or `ordinal` is out
/// of range; kCudaError from cudaSetDevice.
Status require_cuda_device(int ordinal = 0);

/// Loads `path` onto the current device: a .rgs file through format::RgsFile::open (with read_limits()) and
/// runtime::GpuScene::from_rgs (sections checked on the host, including the value rules of SPEC §4.3-4.7,
/// then uploaded as stored), otherwise a 3DGS PLY through
/// converter::read_ply and GpuScene::from_cloud with converter::compute_bounds. Errors name `path`.
Result<LoadedGpuScene> load_gpu_scene(const std::string& path);

/// Uploads a replicate_scene_file() result onto the current device through format::RgsFile::from_bytes and
/// runtime::GpuScene::from_rgs (compact sections and the FP32 arrays widened on the GPU); `name` appears in
/// errors. The bytes may be freed once this returns. is_rgs is true (the scene has compact attributes),
/// file_bytes the source file's size.
Result<LoadedGpuScene> upload_replicated_scene(const ReplicatedScene& replicated, const std::string& name);

}  // namespace rgs::tools
