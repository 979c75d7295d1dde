#include "gpu_scene_loading.h"

#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/reader.h"
#include "read_limits_option.h"
#include "rgs/runtime/cuda_device.h"
#include "scene_loading.h"

namespace rgs::tools {

namespace {
/// `status` with `path` in front unless its message names the file already.
Status naming(Status status, const std::string& path) {
  if (status.message().find(path) == std::string::npos) status.prepend(path);
  return status;
}
}  // namespace

Status require_cuda_device(int ordinal) {
  std::string why;
  const int count = runtime::cuda_device_count(&why);
  RGS_RETURN_ERROR_IF(count == 0, StatusCode::kUnsupportedFeature, "no usable CUDA device: " + why);
  RGS_RETURN_ERROR_IF(ordinal < 0 || ordinal >= count, StatusCode::kUnsupportedFeature,
                      "CUDA device " + std::to_string(ordinal) + " does not exist (" + std::to_string(count) +
                          " device" + (count == 1 ? "" : "s") + ")");
  return runtime::use_cuda_device(ordinal);
}

Result<LoadedGpuScene> load_gpu_scene(const std::string& path) {
  if (is_rgs_path(path)) {
    RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(path, read_options()));
    auto scene = runtime::GpuScene::from_rgs(file);  // checks checksums, frames and values first
    if (!scene.ok()) return naming(scene.status(), path);
    return LoadedGpuScene{std::move(scene).value(), file.metadata().bounds, true, file.file_size()};
  }
  RGS_ASSIGN_OR_RETURN(converter::PlyScene ply, converter::read_ply(path));
  const format::SceneBounds bounds = converter::compute_bounds(ply.cloud);
  auto scene = runtime::GpuScene::from_cloud(ply.cloud, bounds);
  if (!scene.ok()) return naming(scene.status(), path);
  return LoadedGpuScene{std::move(scene).value(), bounds, false, ply.file_bytes};
}

Result<LoadedGpuScene> upload_replicated_scene(const ReplicatedScene& replicated, const std::string& name) {
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::from_bytes(replicated.rgs_bytes.data(),
                                                                         replicated.rgs_bytes.size(), {}, name));
  auto scene = runtime::GpuScene::from_rgs(file);
  if (!scene.ok()) return naming(scene.status(), name);
  return LoadedGpuScene{std::move(scene).value(), file.metadata().bounds, true, replicated.source_file_bytes};
}

}  // namespace rgs::tools
