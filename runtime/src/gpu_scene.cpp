// GpuScene: upload of the .rgs runtime sections (one copy each; archive sections decoded concurrently on the
// host first) or of FP32 Gaussians.
#include "rgs/runtime/gpu_scene.h"

#include <algorithm>
#include <array>
#include <string>
#include <vector>

#include "rgs/format/spec.h"
#include "rgs/kernels/baseline_pipeline.h"
#include "rgs/parallel/fork_join.h"

namespace rgs::runtime {
namespace {

constexpr uint64_t kMaxGpuGaussians = (uint64_t{1} << 31) - 1;  // kernels index Gaussians with uint32/int

Status check_count(uint64_t count, const std::string& name) {
  RGS_RETURN_ERROR_IF(count > kMaxGpuGaussians, StatusCode::kLimitExceeded,
                      name + ": " + std::to_string(count) + " Gaussians exceed the GPU renderer's limit of " +
                          std::to_string(kMaxGpuGaussians));
  return Status();
}

/// Copies one section of `file` into `dst` (raw_size bytes): straight from the mapping when stored
/// uncompressed, else decoded into the pinned `staging` buffer and copied from there. Synchronous.
Status upload_section(const format::RgsFile& file, format::SectionId id, void* dst, size_t dst_bytes,
                      PinnedBuffer* staging, cudaStream_t stream) {
  const format::SectionEntry* entry = file.find(id);
  RGS_RETURN_ERROR_IF(entry == nullptr, StatusCode::kCorruptData,
                      file.name() + ": runtime section " + std::to_string(uint32_t(id)) + " is missing");
  // SPEC §4.9 A level-of-detail file's full detail is the prefix of its raw sections.
  const bool prefix = file.lod() != nullptr && entry->codec == format::Codec::kNone && dst_bytes <= entry->raw_size;
  RGS_RETURN_ERROR_IF(entry->raw_size != dst_bytes && !prefix, StatusCode::kCorruptData,
                      file.name() + ": section " + std::to_string(uint32_t(id)) + " holds " +
                          std::to_string(entry->raw_size) + " bytes, expected " + std::to_string(dst_bytes));
  if (dst_bytes == 0) return Status();
  const std::string what = file.name() + ": upload of section " + std::to_string(uint32_t(id));
  if (entry->codec == format::Codec::kNone) {
    RGS_ASSIGN_OR_RETURN(const format::ByteView bytes, file.stored_bytes(id));
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(dst, bytes.data, dst_bytes, cudaMemcpyHostToDevice, stream), what);
  } else {
    RGS_RETURN_IF_ERROR(staging->reserve(dst_bytes, what));
    RGS_RETURN_IF_ERROR(file.decode_section(id, staging->data(), dst_bytes));
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(dst, staging->data(), dst_bytes, cudaMemcpyHostToDevice, stream),
                             what);
  }
  // The staging buffer (and the mapping) must stay untouched until the copy is done.
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), what);
  return Status();
}

/// A runtime section and where it goes on the device (raw_size bytes).
struct SectionUpload {
  format::SectionId id;
  void* dst;
  size_t bytes;
};

/// Uploads the runtime sections of `file`. The archive-coded ones (Draco, quantized: SPEC §3.3), whose host
/// decode is most of an archive's load time, are first decoded and checked concurrently, each into its own
/// host buffer (their raw sizes are bounded at open), then copied in section order; the others go through
/// upload_section, one at a time. The first failing section in section order is reported. Synchronous.
Status upload_sections(const format::RgsFile& file, const std::vector<SectionUpload>& uploads, cudaStream_t stream) {
  std::vector<std::vector<uint8_t>> decoded(uploads.size());
  std::vector<Status> decode_status(uploads.size());
  std::vector<size_t> archive;
  for (size_t i = 0; i < uploads.size(); ++i) {
    const format::SectionEntry* entry = file.find(uploads[i].id);
    if (entry != nullptr && format::is_archive_codec(entry->codec) && entry->raw_size == uploads[i].bytes &&
        uploads[i].bytes > 0) {
      archive.push_back(i);
    }
  }
  const Status threads = parallel::parallel_for(archive.size(), 0, [&](uint64_t a) {
    const size_t i = archive[a];
    decoded[i].resize(uploads[i].bytes);
    decode_status[i] = file.decode_verified_section(uploads[i].id, decoded[i].data(), decoded[i].size());
  });
  RGS_RETURN_IF_ERROR(threads);
  PinnedBuffer staging;
  for (size_t i = 0; i < uploads.size(); ++i) {
    const SectionUpload& u = uploads[i];
    if (decoded[i].empty()) {
      RGS_RETURN_IF_ERROR(upload_section(file, u.id, u.dst, u.bytes, &staging, stream));
      continue;
    }
    RGS_RETURN_IF_ERROR(decode_status[i]);
    const std::string what = file.name() + ": upload of section " + std::to_string(uint32_t(u.id));
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(u.dst, decoded[i].data(), u.bytes, cudaMemcpyHostToDevice, stream), what);
    RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), what);
  }
  return Status();
}

template <typename T>
Status upload_vector(const std::vector<T>& host, DeviceBuffer<T>* device, const std::string& what,
                     cudaStream_t stream) {
  RGS_RETURN_IF_ERROR(device->allocate_exactly(host.size(), what));
  if (host.empty()) return Status();
  RGS_RETURN_IF_CUDA_ERROR(
      cudaMemcpyAsync(device->data(), host.data(), host.size() * sizeof(T), cudaMemcpyHostToDevice, stream), what);
  return Status();
}

}  // namespace

Result<GpuScene> GpuScene::from_rgs(const format::RgsFile& file, cudaStream_t stream) {
  return from_rgs(file, GpuSceneOptions{}, stream);
}

Result<GpuScene> GpuScene::from_rgs(const format::RgsFile& file, const GpuSceneOptions& options,
                                    cudaStream_t stream) {
  const uint64_t n = file.full_detail_count();
  RGS_RETURN_IF_ERROR(check_count(n, file.name()));
  const format::SceneMetadata& meta = file.metadata();
  const uint64_t k = format::sh_coefficient_count(meta.sh_degree);
  // Checksums, zstd frames and the value rules of SPEC §4.3-4.7 first, in bounded host memory: the kernels
  // never see a value the spec rules out (NaN means, zero quaternions, negative scales, opacity above 1),
  // and a damaged frame fails before device memory is sized by what it claims. Archive sections decode whole
  // either way (their raw size is bounded at open): upload_sections checks them once decoded, before the copy.
  const bool dc_residual = file.find(format::SectionId::kShDcResidual) != nullptr;
  for (format::SectionId id : {format::SectionId::kMeans, format::SectionId::kRotations, format::SectionId::kScales,
                               format::SectionId::kOpacities, format::SectionId::kSh, format::SectionId::kShDcResidual}) {
    const format::SectionEntry* entry = file.find(id);
    if (id == format::SectionId::kShDcResidual && !dc_residual) continue;
    if (entry != nullptr && format::is_archive_codec(entry->codec)) continue;
    RGS_RETURN_IF_ERROR(file.verify_section(id));
  }

  GpuScene scene;
  RGS_RETURN_IF_ERROR(scene.allocate_compact(n, meta.sh_degree, dc_residual, file.name(), stream));
  using format::SectionId;
  const uint64_t sh_bytes = n * k * 3;
  std::vector<SectionUpload> uploads = {
      {SectionId::kMeans, scene.means_.data(), scene.means_.bytes()},
      {SectionId::kRotations, scene.rotations_fp16_.data(), scene.rotations_fp16_.bytes()},
      {SectionId::kScales, scene.scales_fp16_.data(), scene.scales_fp16_.bytes()},
      {SectionId::kOpacities, scene.opacities_fp16_.data(), scene.opacities_fp16_.bytes()},
      {SectionId::kSh, scene.sh_int8_.data(), sh_bytes}};
  if (dc_residual) uploads.push_back({SectionId::kShDcResidual, scene.sh_dc_residual_.data(), n * 3});
  RGS_RETURN_IF_ERROR(upload_sections(file, uploads, stream));
  RGS_RETURN_IF_ERROR(scene.finish_compact(meta, dc_residual, options, file.name(), stream));
  return scene;
}

Result<GpuScene> GpuScene::from_encoded(const format::EncodedScene& encoded, const GpuSceneOptions& options,
                                        const std::string& name, cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(!encoded.is_consistent(), StatusCode::kInvalidArgument,
                      name + ": the quantized arrays do not match the count and SH degree");
  const uint64_t n = encoded.count;
  RGS_RETURN_IF_ERROR(check_count(n, name));
  const bool dc_residual = !encoded.sh_dc_residual.empty();
  GpuScene scene;
  RGS_RETURN_IF_ERROR(scene.allocate_compact(n, encoded.metadata.sh_degree, dc_residual, name, stream));
  const std::string what = name + ": upload of the quantized arrays";
  auto upload = [&](void* dst, const void* src, size_t bytes) -> Status {
    if (bytes == 0) return Status();
    RGS_RETURN_IF_CUDA_ERROR(cudaMemcpyAsync(dst, src, bytes, cudaMemcpyHostToDevice, stream), what);
    return Status();
  };
  RGS_RETURN_IF_ERROR(upload(scene.means_.data(), encoded.means.data(), encoded.means.size() * sizeof(float)));
  RGS_RETURN_IF_ERROR(upload(scene.rotations_fp16_.data(), encoded.rotations.data(), encoded.rotations.size() * 2));
  RGS_RETURN_IF_ERROR(upload(scene.scales_fp16_.data(), encoded.scales.data(), encoded.scales.size() * 2));
  RGS_RETURN_IF_ERROR(upload(scene.opacities_fp16_.data(), encoded.opacities.data(), encoded.opacities.size() * 2));
  RGS_RETURN_IF_ERROR(upload(scene.sh_int8_.data(), encoded.sh.data(), encoded.sh.size()));
  if (dc_residual) {
    RGS_RETURN_IF_ERROR(upload(scene.sh_dc_residual_.data(), encoded.sh_dc_residual.data(), encoded.sh_dc_residual.size()));
  }
  // The host arrays must stay untouched until the copies are done.
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), what);
  RGS_RETURN_IF_ERROR(scene.finish_compact(encoded.metadata, dc_residual, options, name, stream));
  return scene;
}

Status GpuScene::allocate_compact(uint64_t n, uint32_t sh_degree, bool dc_residual, const std::string& name,
                                  cudaStream_t stream) {
  count_ = uint32_t(n);
  sh_degree_ = sh_degree;
  has_compact_ = true;
  RGS_RETURN_IF_ERROR(means_.allocate_exactly(n * 3, name + ": means"));
  RGS_RETURN_IF_ERROR(rotations_fp16_.allocate_exactly(n * 4, name + ": rotations"));
  RGS_RETURN_IF_ERROR(scales_fp16_.allocate_exactly(n * 3, name + ": scales"));
  RGS_RETURN_IF_ERROR(opacities_fp16_.allocate_exactly(n, name + ": opacities"));
  // The int8 arrays are padded with zeros, so that no kernel reads uninitialized bytes (kCompactShPadding).
  auto allocate_padded = [&](DeviceBuffer<int8_t>* buffer, uint64_t bytes, const char* what) -> Status {
    const uint64_t padded = (bytes + kernels::kCompactShPadding - 1) / kernels::kCompactShPadding *
                            kernels::kCompactShPadding;
    RGS_RETURN_IF_ERROR(buffer->allocate_exactly(padded, name + ": " + what));
    if (padded > bytes) {
      RGS_RETURN_IF_CUDA_ERROR(cudaMemsetAsync(buffer->data() + bytes, 0, padded - bytes, stream),
                               name + ": " + what + " padding");
    }
    return Status();
  };
  RGS_RETURN_IF_ERROR(allocate_padded(&sh_int8_, n * format::sh_coefficient_count(sh_degree) * 3, "SH"));
  if (dc_residual) RGS_RETURN_IF_ERROR(allocate_padded(&sh_dc_residual_, n * 3, "SH DC residual"));
  return Status();
}

Status GpuScene::finish_compact(const format::SceneMetadata& meta, bool dc_residual, const GpuSceneOptions& options,
                                const std::string& name, cudaStream_t stream) {
  bounds_ = meta.bounds;
  antialiased_ = meta.antialiased;
  const uint64_t n = count_;
  const uint64_t k = format::sh_coefficient_count(meta.sh_degree);
  kernels::CompactGaussiansView& view = compact_view_;
  view.means = means_.data();
  view.rotations = rotations_fp16_.data();
  view.scales = scales_fp16_.data();
  view.opacities = opacities_fp16_.data();
  view.sh = sh_int8_.data();
  view.sh_dc_residual = dc_residual ? sh_dc_residual_.data() : nullptr;
  for (int d = 0; d < 4; ++d) {
    for (int c = 0; c < 3; ++c) view.sh_scales[d][c] = meta.sh_quantization.scales[d][c];
  }
  view.scale_encoding = meta.scale_encoding == format::ScaleEncoding::kLog ? kernels::CompactScaleEncoding::kLog
                                                                         : kernels::CompactScaleEncoding::kLinear;
  view.sh_degree = meta.sh_degree;
  view.count = uint32_t(n);

  runtime_section_bytes_ = n * (12 + 8 + 6 + 2 + (dc_residual ? 3 : 0)) + n * k * 3;
  if (!options.fp32_attributes) return Status();

  // FP32 attributes for the baseline, widened on the device.
  RGS_RETURN_IF_ERROR(rotations_.allocate_exactly(n * 4, name + ": FP32 rotations"));
  RGS_RETURN_IF_ERROR(scales_.allocate_exactly(n * 3, name + ": FP32 scales"));
  RGS_RETURN_IF_ERROR(opacities_.allocate_exactly(n, name + ": FP32 opacities"));
  RGS_RETURN_IF_ERROR(sh_.allocate_exactly(n * k * 3, name + ": FP32 SH"));
  RGS_RETURN_IF_CUDA_ERROR(kernels::dequantize(view, rotations_.data(), scales_.data(), opacities_.data(),
                                               sh_.data(), stream),
                           name + ": dequantize kernel");
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), name + ": dequantize kernel");
  has_fp32_ = true;
  return Status();
}

Result<GpuScene> GpuScene::from_cloud(const format::GaussianCloud& cloud,
                                      const std::optional<format::SceneBounds>& bounds, cudaStream_t stream) {
  RGS_RETURN_ERROR_IF(!cloud.is_consistent(), StatusCode::kInvalidArgument,
                      "GpuScene: Gaussian cloud arrays do not match its size " + std::to_string(cloud.size()) +
                          " and SH degree " + std::to_string(cloud.sh_degree));
  RGS_RETURN_IF_ERROR(check_count(cloud.size(), "GpuScene"));
  GpuScene scene;
  scene.count_ = uint32_t(cloud.size());
  scene.sh_degree_ = cloud.sh_degree;
  scene.bounds_ = bounds;
  scene.antialiased_ = cloud.antialiased;
  scene.has_fp32_ = true;
  RGS_RETURN_IF_ERROR(upload_vector(cloud.means, &scene.means_, "GpuScene: means", stream));
  RGS_RETURN_IF_ERROR(upload_vector(cloud.rotations, &scene.rotations_, "GpuScene: rotations", stream));
  RGS_RETURN_IF_ERROR(upload_vector(cloud.scales, &scene.scales_, "GpuScene: scales", stream));
  RGS_RETURN_IF_ERROR(upload_vector(cloud.opacities, &scene.opacities_, "GpuScene: opacities", stream));
  RGS_RETURN_IF_ERROR(upload_vector(cloud.sh, &scene.sh_, "GpuScene: SH", stream));
  RGS_RETURN_IF_CUDA_ERROR(cudaStreamSynchronize(stream), "GpuScene: upload");
  return scene;
}

uint64_t GpuScene::device_bytes() const {
  return means_.bytes() + rotations_.bytes() + scales_.bytes() + opacities_.bytes() + sh_.bytes() +
         rotations_fp16_.bytes() + scales_fp16_.bytes() + opacities_fp16_.bytes() + sh_int8_.bytes() +
         sh_dc_residual_.bytes();
}

GpuScene GpuScene::compact_view(const kernels::CompactGaussiansView& view, const format::SceneBounds& bounds,
                                uint32_t capacity, bool antialiased) {
  GpuScene scene;
  scene.antialiased_ = antialiased;
  scene.count_ = view.count;
  scene.capacity_ = capacity;
  scene.sh_degree_ = view.sh_degree;
  scene.bounds_ = bounds;
  scene.has_compact_ = true;
  scene.compact_view_ = view;
  scene.runtime_section_bytes_ =
      uint64_t{view.count} * (12 + 8 + 6 + 2 + (view.sh_dc_residual != nullptr ? 3 : 0) +
                              3 * format::sh_coefficient_count(view.sh_degree));
  return scene;
}

kernels::Fp32GaussiansView GpuScene::fp32() const {
  kernels::Fp32GaussiansView view;
  view.means = means_.data() != nullptr ? means_.data() : compact_view_.means;
  view.rotations = has_fp32_ ? rotations_.data() : nullptr;
  view.scales = has_fp32_ ? scales_.data() : nullptr;
  view.opacities = has_fp32_ ? opacities_.data() : nullptr;
  view.sh = has_fp32_ ? sh_.data() : nullptr;
  view.sh_degree = sh_degree_;
  view.count = count_;
  return view;
}

}  // namespace rgs::runtime
