// GpuScene::from_device (Gaussians from a caller's device arrays, device work only) and write_planar_output
// (a rendered frame into gsplat's planar outputs).
#include "rgs/runtime/device_arrays.h"

#include <cstring>
#include <string>

#include "rgs/format/gaussian_cloud.h"
#include "rgs/runtime/cuda_device.h"
#include "rgs/runtime/gpu_scene.h"

namespace rgs::runtime {
namespace {

constexpr uint64_t kMaxDeviceGaussians = (uint64_t{1} << 31) - 1;  // kernels index Gaussians with uint32/int

/// Checks that `p` is device memory (or managed memory) of the current device, aligned to `alignment`.
Status check_device_pointer(const void* p, size_t alignment, const std::string& what) {
  RGS_RETURN_ERROR_IF(p == nullptr, StatusCode::kInvalidArgument, what + ": null pointer");
  RGS_RETURN_ERROR_IF(reinterpret_cast<uintptr_t>(p) % alignment != 0, StatusCode::kInvalidArgument,
                      what + ": address not aligned to " + std::to_string(alignment) + " bytes");
  cudaPointerAttributes attributes{};
  RGS_RETURN_IF_CUDA_ERROR(cudaPointerGetAttributes(&attributes, p), what + ": cudaPointerGetAttributes");
  int device = 0;
  RGS_RETURN_IF_CUDA_ERROR(cudaGetDevice(&device), what + ": cudaGetDevice");
  const bool on_device = attributes.type == cudaMemoryTypeDevice || attributes.type == cudaMemoryTypeManaged;
  RGS_RETURN_ERROR_IF(!on_device, StatusCode::kInvalidArgument, what + ": not in CUDA device memory");
  RGS_RETURN_ERROR_IF(attributes.type == cudaMemoryTypeDevice && attributes.device != device,
                      StatusCode::kInvalidArgument,
                      what + ": on CUDA device " + std::to_string(attributes.device) + ", not the current device " +
                          std::to_string(device));
  return Status();
}

Status check_source(const kernels::GaussianImportSource& s, const std::string& name) {
  RGS_RETURN_ERROR_IF(s.count > kMaxDeviceGaussians, StatusCode::kLimitExceeded,
                      name + ": " + std::to_string(s.count) + " Gaussians exceed the GPU renderer's limit of " +
                          std::to_string(kMaxDeviceGaussians));
  if (s.rgb) {
    RGS_RETURN_ERROR_IF(s.sh_degree != 0, StatusCode::kInvalidArgument, name + ": RGB colours have SH degree 0");
  } else {
    const uint32_t k = s.color_coefficients;
    RGS_RETURN_ERROR_IF(k != 1 && k != 4 && k != 9 && k != 16, StatusCode::kInvalidArgument,
                        name + ": " + std::to_string(k) + " SH coefficients per channel; expected 1, 4, 9 or 16");
    RGS_RETURN_ERROR_IF(s.sh_degree > 3 || format::sh_coefficient_count(s.sh_degree) > k, StatusCode::kInvalidArgument,
                        name + ": SH degree " + std::to_string(s.sh_degree) + " needs more than the " +
                            std::to_string(k) + " coefficients given");
  }
  if (s.count == 0) return Status();
  RGS_RETURN_IF_ERROR(check_device_pointer(s.means, 4, name + ": means"));
  RGS_RETURN_IF_ERROR(check_device_pointer(s.rotations, 4, name + ": quaternions"));
  RGS_RETURN_IF_ERROR(check_device_pointer(s.scales, 4, name + ": scales"));
  RGS_RETURN_IF_ERROR(check_device_pointer(s.opacities, 4, name + ": opacities"));
  RGS_RETURN_IF_ERROR(check_device_pointer(s.colors, 4, name + ": colours"));
  return Status();
}

float float_of_key(unsigned int key) {
  const unsigned int bits = kernels::float_bits_of_key(key);
  float v = 0;
  std::memcpy(&v, &bits, sizeof v);
  return v;
}

Status read_totals(const DeviceBuffer<kernels::GaussianImportTotals>& device, kernels::GaussianImportTotals* host,
                   const std::string& what, cudaStream_t stream) {
  RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(host, device.data(), sizeof *host, cudaMemcpyDeviceToHost, stream), what);
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), what);
  return Status();
}

}  // namespace

Result<GpuScene> GpuScene::from_device(const kernels::GaussianImportSource& source,
                                       const DeviceImportOptions& options, cudaStream_t stream, uint64_t* dropped) {
  const std::string& name = options.name;
  RGS_RETURN_IF_ERROR(check_source(source, name));
  if (dropped != nullptr) *dropped = 0;
  DeviceBuffer<kernels::GaussianImportTotals> totals;
  RGS_RETURN_IF_ERROR(totals.allocate_exactly(1, name + ": import totals"));
  DeviceBuffer<unsigned int> valid;
  if (options.drop_invalid) RGS_RETURN_IF_ERROR(valid.allocate_exactly(source.count, name + ": valid flags"));
  RGS_RETURN_IF_CUDA_ERROR(kernels::launch_check_gaussians(source, totals.data(), valid.data(), stream),
                           name + ": check kernel");
  kernels::GaussianImportTotals t{};
  RGS_RETURN_IF_ERROR(read_totals(totals, &t, name + ": check kernel", stream));

  // The rules and messages of converter::scene_from_cloud: the encodings first (the smallest index; at one
  // index the scale before the opacity), then non-finite values and zero quaternions.
  if (t.first_negative_scale != kernels::kNoGaussian || t.first_bad_opacity != kernels::kNoGaussian) {
    if (t.first_negative_scale <= t.first_bad_opacity) {
      return Status(StatusCode::kInvalidArgument,
                    name + ": Gaussian " + std::to_string(t.first_negative_scale) +
                        " has a negative scale (scales are linear, not log: exp() them first)");
    }
    return Status(StatusCode::kInvalidArgument,
                  name + ": Gaussian " + std::to_string(t.first_bad_opacity) +
                      " has an opacity outside [0, 1] (opacities are activated, not logits: sigmoid() them first)");
  }
  if (t.invalid != 0 && !options.drop_invalid) {
    return Status(StatusCode::kCorruptData,
                  std::to_string(t.gaussians_with_nonfinite) + " Gaussians have non-finite values (" +
                      std::to_string(t.nonfinite_values) + " values) and " + std::to_string(t.zero_norm_quaternions) +
                      " have zero-norm quaternions (first: Gaussian " + std::to_string(t.first_invalid) +
                      "); rerun with --sanitize to drop them")
        .prepend(name);
  }

  const uint64_t kept = source.count - t.invalid;
  const uint32_t degree = source.rgb ? 0 : source.sh_degree;
  GpuScene scene;
  scene.count_ = uint32_t(kept);
  scene.sh_degree_ = degree;
  scene.antialiased_ = options.antialiased;
  scene.has_fp32_ = true;
  format::SceneBounds bounds;
  kernels::GaussianImportTarget target;
  if (kept > 0) {
    for (int a = 0; a < 3; ++a) {
      bounds.aabb_min[a] = float_of_key(t.aabb_min_key[a]);
      bounds.aabb_max[a] = float_of_key(t.aabb_max_key[a]);
    }
    double center[3];
    format::set_sphere_center(&bounds, center);
    for (int a = 0; a < 3; ++a) target.center[a] = bounds.sphere_center[a];
  }
  const uint64_t values = uint64_t(format::sh_coefficient_count(degree)) * 3;
  RGS_RETURN_IF_ERROR(scene.means_.allocate_exactly(kept * 3, name + ": means"));
  RGS_RETURN_IF_ERROR(scene.rotations_.allocate_exactly(kept * 4, name + ": quaternions"));
  RGS_RETURN_IF_ERROR(scene.scales_.allocate_exactly(kept * 3, name + ": scales"));
  RGS_RETURN_IF_ERROR(scene.opacities_.allocate_exactly(kept, name + ": opacities"));
  RGS_RETURN_IF_ERROR(scene.sh_.allocate_exactly(kept * values, name + ": SH"));
  target.means = scene.means_.data();
  target.rotations = scene.rotations_.data();
  target.scales = scene.scales_.data();
  target.opacities = scene.opacities_.data();
  target.sh = scene.sh_.data();
  DeviceBuffer<unsigned int> offsets;
  DeviceBuffer<uint8_t> scan_scratch;
  if (t.invalid != 0) {
    RGS_RETURN_IF_ERROR(offsets.allocate_exactly(source.count, name + ": offsets"));
    const size_t scratch_bytes = kernels::compact_offsets_scratch_bytes(source.count);
    RGS_RETURN_IF_ERROR(scan_scratch.allocate_exactly(scratch_bytes, name + ": scan scratch"));
    RGS_RETURN_IF_CUDA_ERROR(kernels::launch_compact_offsets(valid.data(), offsets.data(), source.count,
                                                             scan_scratch.data(), scratch_bytes, stream),
                             name + ": offset scan");
    target.offsets = offsets.data();
  }
  RGS_RETURN_IF_CUDA_ERROR(kernels::launch_gather_gaussians(source, target, totals.data(), stream),
                           name + ": gather kernel");
  RGS_RETURN_IF_ERROR(read_totals(totals, &t, name + ": gather kernel", stream));
  if (kept > 0) {
    double radius2 = 0;
    std::memcpy(&radius2, &t.radius2_bits, sizeof radius2);
    bounds.sphere_radius = format::sphere_radius_for(radius2);
  }
  scene.bounds_ = bounds;
  if (dropped != nullptr) *dropped = t.invalid;
  return scene;
}

Status write_planar_output(const kernels::PlanarOutputParams& params, cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(params.width == 0 || params.height == 0, StatusCode::kInvalidArgument,
                      "planar output: empty image");
  const bool with_depth = params.depth_mode != kernels::PlanarDepth::kNone;
  RGS_RETURN_ERROR_IF(!params.rgb && !with_depth, StatusCode::kInvalidArgument,
                      "planar output: neither colours nor depth asked for");
  RGS_RETURN_ERROR_IF(params.rgba == nullptr || reinterpret_cast<uintptr_t>(params.rgba) % 16 != 0,
                      StatusCode::kInvalidArgument, "planar output: the frame must be a 16-byte aligned RGBA array");
  RGS_RETURN_ERROR_IF(with_depth && params.depth == nullptr, StatusCode::kInvalidArgument,
                      "planar output: a depth plane is asked for and the frame has none");
  for (const void* p : {static_cast<const void*>(params.colors), static_cast<const void*>(params.alphas),
                        static_cast<const void*>(params.depth)}) {
    RGS_RETURN_ERROR_IF(reinterpret_cast<uintptr_t>(p) % 4 != 0, StatusCode::kInvalidArgument,
                        "planar output: an array not aligned to 4 bytes");
  }
  RGS_RETURN_ERROR_IF(params.colors == nullptr || params.alphas == nullptr, StatusCode::kInvalidArgument,
                      "planar output: null colours or alphas");
  RGS_RETURN_IF_CUDA_ERROR(kernels::launch_planar_output(params, stream), "planar output kernel");
  return Status();
}

}  // namespace rgs::runtime
