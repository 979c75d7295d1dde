// Scene loading straight into device memory (CUDA builds).
#include "internal_gpu_scene_loading.h"

#include "rgs/converter/ply_reader.h"
#include "rgs/converter/quantize.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/reader.h"
#include "rgs/runtime/cuda_device.h"

namespace rgs::api {

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

Result<LoadedGpuScene> load_gpu_scene(const std::string& path, const runtime::GpuSceneOptions& options,
                                      cudaStream_t stream, const converter::SceneReadOptions& read_options) {
  if (format::is_rgs_path(path)) {
    RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::open(path, converter::rgs_read_options(read_options)));
    return upload_rgs_file(file, file.file_size(), path, options, stream);
  }
  RGS_ASSIGN_OR_RETURN(converter::InputScene input, converter::read_scene(path, read_options));
  const format::SceneBounds& bounds = input.bounds;
  auto scene = runtime::GpuScene::from_cloud(input.cloud, bounds, stream);
  if (!scene.ok()) return naming(scene.status(), path);
  return LoadedGpuScene{std::move(scene).value(), bounds, false, input.file_bytes, input.description,
                        std::move(input.notes)};
}

Result<LoadedGpuScene> upload_rgs_bytes(const std::vector<uint8_t>& rgs_bytes, uint64_t source_file_bytes,
                                        const std::string& name, const runtime::GpuSceneOptions& options,
                                        cudaStream_t stream) {
  RGS_ASSIGN_OR_RETURN(format::RgsFile file, format::RgsFile::from_bytes(rgs_bytes.data(), rgs_bytes.size(), {}, name));
  return upload_rgs_file(file, source_file_bytes, name, options, stream);
}

Result<LoadedGpuScene> upload_rgs_file(const format::RgsFile& file, uint64_t source_file_bytes, const std::string& name,
                                       const runtime::GpuSceneOptions& options, cudaStream_t stream) {
  auto scene = runtime::GpuScene::from_rgs(file, options, stream);  // checks checksums, frames and values first
  if (!scene.ok()) return naming(scene.status(), name);
  return LoadedGpuScene{std::move(scene).value(), file.metadata().bounds, true, source_file_bytes, "RoofGS .rgs", {}};
}

}  // namespace rgs::api
