// Scene loading straight into device memory (CUDA builds).
#include "internal_gpu_scene_loading.h"
#include "internal_load.h"

#include "rgs/format/reader.h"
#include "rgs/runtime/cuda_device.h"

namespace rgs::api {

Status require_cuda_device(int ordinal) {
  std::string why;
  const int count = runtime::cuda_device_count(&why);
  RGS_RETURN_ERROR_IF(count == 0, StatusCode::kUnsupportedFeature, "no usable CUDA device: " + why);
  RGS_RETURN_ERROR_IF(ordinal < 0 || ordinal >= count, StatusCode::kUnsupportedFeature,
                      "CUDA device " + std::to_string(ordinal) + " does not exist (" + std::to_string(count) +
                          " device" + (count == 1 ? "" : "s") + ")");
  return runtime::use_cuda_device(ordinal);
}

Result<LoadedGpuScene> upload_rgs_file(const format::RgsFile& file, uint64_t source_file_bytes, const std::string& name,
                                       const runtime::GpuSceneOptions& options, cudaStream_t stream) {
  auto scene = runtime::GpuScene::from_rgs(file, options, stream);  // checks checksums, frames and values first
  if (!scene.ok()) return naming(scene.status(), name);
  return LoadedGpuScene{std::move(scene).value(), file.metadata().bounds, true, source_file_bytes, "RoofGS .rgs", {}};
}

}  // namespace rgs::api
