// load_device_gaussians and write_planar: a caller's device arrays in, gsplat's planar outputs out.
#include "rgs/api/device_gaussians.h"

#include "internal_load.h"
#include "internal_scene.h"

#if RGS_HAS_CUDA
#include "internal_gpu_scene_loading.h"
#include "rgs/runtime/device_arrays.h"
#endif

namespace rgs::api {

Result<Scene> load_device_gaussians(const DeviceGaussians& gaussians, const DeviceLoadOptions& options) {
#if RGS_HAS_CUDA
  RGS_RETURN_IF_ERROR(require_cuda_device(options.cuda_device));
  kernels::GaussianImportSource source;
  source.means = gaussians.means;
  source.rotations = gaussians.quats;
  source.scales = gaussians.scales;
  source.opacities = gaussians.opacities;
  source.colors = gaussians.colors;
  source.count = gaussians.count;
  source.color_coefficients = gaussians.rgb ? 1 : gaussians.sh_coefficients;
  source.sh_degree = gaussians.sh_degree;
  source.rgb = gaussians.rgb;
  runtime::DeviceImportOptions import;
  import.drop_invalid = options.invalid_policy == converter::InvalidPolicy::kSanitize;
  import.name = options.name;
  import.antialiased = options.antialiased;
  uint64_t dropped = 0;
  RGS_ASSIGN_OR_RETURN(runtime::GpuScene gpu, runtime::GpuScene::from_device(source, import, options.stream, &dropped));
  auto impl = std::make_shared<Scene::Impl>();
  SceneInfo& info = impl->info;
  const format::SceneBounds bounds = gpu.bounds().value_or(format::SceneBounds{});
  // The content frame of the bounds: the Gaussians never reach the host.
  info = detail::scene_info(options.name, Device::kCuda, bounds, ContentFrame::of_sphere(bounds), gpu.size(),
                            gpu.sh_degree(), gpu.antialiased());
  info.description = "float Gaussians in device memory";
  info.has_fp32 = true;
  info.memory_bytes = gpu.device_bytes();
  if (dropped != 0) info.notes.push_back(std::to_string(dropped) + " invalid Gaussians dropped (sanitize)");
  impl->gpu.emplace(std::move(gpu));
  return Scene(std::move(impl));
#else
  (void)gaussians;
  return Status(StatusCode::kUnsupportedFeature,
                options.name + ": device arrays: this build has no CUDA support (RGS_WITH_CUDA=OFF)");
#endif
}

Status write_planar(const Image& image, const PlanarTarget& target, Stream stream) {
  RGS_RETURN_ERROR_IF(image.device() != Device::kCuda, StatusCode::kInvalidArgument,
                      "write_planar: the image is not on the GPU");
  RGS_RETURN_ERROR_IF(image.format() != PixelFormat::kRgba32f, StatusCode::kInvalidArgument,
                      std::string("write_planar: the image is ") + pixel_format_name(image.format()) +
                          ", not rgba32f");
#if RGS_HAS_CUDA
  kernels::PlanarOutputParams params;
  params.rgba = static_cast<const float*>(image.color());
  params.depth = image.depth();
  params.width = image.width();
  params.height = image.height();
  params.colors = target.colors;
  params.rgb = target.rgb;
  params.depth_mode = static_cast<kernels::PlanarDepth>(static_cast<uint32_t>(target.depth));
  params.alphas = target.alphas;
  return runtime::write_planar_output(params, stream);
#else
  (void)target;
  (void)stream;
  return Status(StatusCode::kUnsupportedFeature, "write_planar: this build has no CUDA support");
#endif
}

}  // namespace rgs::api
