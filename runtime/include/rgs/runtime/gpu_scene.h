// A scene in GPU memory: the .rgs runtime profile uploaded section by section, plus (optionally) the FP32
// attributes the baseline pipeline reads. Available only with RGS_WITH_CUDA.
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>
#include <optional>
#include <string>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/metadata.h"
#include "rgs/format/reader.h"
#include "rgs/format/status.h"
#include "rgs/kernels/device_scene.h"
#include "rgs/runtime/device_buffer.h"

namespace rgs::kernels {
struct GaussianImportSource;
}

namespace rgs::runtime {

struct DeviceImportOptions;

/// What GpuScene::from_rgs() keeps on the device besides the compact sections.
struct GpuSceneOptions {
  /// Also widen the compact attributes into FP32 arrays (rotations, scales, opacities, SH; means are FP32 in
  /// the file already and shared). Only the baseline pipeline and the RoofGS pipeline with
  /// GpuRoofgsOptions::compact_attributes off read them; without them a .rgs scene holds its runtime sections
  /// only (about 76 B per Gaussian at SH degree 3 instead of about 300 B).
  bool fp32_attributes = true;
};

/// Gaussians in device memory. Move-only; owns its allocations.
///
/// From a .rgs file, the runtime sections (means, rotations, scales, opacities, SH; format/SPEC.md §4) are
/// copied to the device as they are stored, one copy per section and no CPU decode: uncompressed sections
/// go straight from the memory-mapped file, zstd sections are decoded into a pinned upload buffer first.
/// The FP32 attributes of the baseline are then widened on the GPU (kernels::dequantize, the same values as
/// format::dequantize() on the host). From a GaussianCloud (a PLY, say), the FP32 arrays are uploaded and
/// there is no compact profile.
class GpuScene {
 public:
  /// Uploads the runtime profile of `file` on `stream` and waits for it (of a level-of-detail file, SPEC §4.9,
  /// the full detail: its first full_detail_count() Gaussians). Every runtime section is first
  /// checked on the host with RgsFile::verify_section() (checksum, whole zstd frame in bounded memory, the
  /// value rules of SPEC §4.3-4.7), before any device allocation. Errors: those of verify_section()
  /// (kChecksumMismatch, kCorruptData naming the Gaussian; the file's name in the message), kLimitExceeded
  /// (≥ 2^31 Gaussians), kOutOfMemory / kCudaError from the device.
  static Result<GpuScene> from_rgs(const format::RgsFile& file, cudaStream_t stream = nullptr);

  /// Same, keeping the FP32 arrays only when options.fp32_attributes (has_fp32()).
  static Result<GpuScene> from_rgs(const format::RgsFile& file, const GpuSceneOptions& options,
                                   cudaStream_t stream = nullptr);

  /// Uploads a runtime profile held in host memory (converter::quantize's output: a scene quantized in memory and
  /// never serialized) on `stream` and waits for it: the same device arrays as from_rgs() of the file it would
  /// write, the FP32 arrays only when options.fp32_attributes. `name` prefixes the messages. Errors:
  /// kInvalidArgument (arrays inconsistent with the count and SH degree), kLimitExceeded (≥ 2^31 Gaussians),
  /// kOutOfMemory / kCudaError from the device.
  static Result<GpuScene> from_encoded(const format::EncodedScene& encoded, const GpuSceneOptions& options,
                                       const std::string& name, cudaStream_t stream = nullptr);

  /// Uploads FP32 Gaussians on `stream` and waits for it. `bounds` (e.g. converter::compute_bounds) is
  /// kept for the RoofGS depth key; without it bounds() is empty. Errors: kInvalidArgument (inconsistent
  /// cloud), kLimitExceeded (≥ 2^31 Gaussians), kOutOfMemory / kCudaError.
  static Result<GpuScene> from_cloud(const format::GaussianCloud& cloud,
                                     const std::optional<format::SceneBounds>& bounds = std::nullopt,
                                     cudaStream_t stream = nullptr);

  /// Builds an FP32 scene from Gaussians in device memory of the current device (`source`, kernels/array_io.h:
  /// a caller's tensors), with device work only, and waits for it: the values are checked as a file's are
  /// (converter::scene_from_cloud), quaternions normalized, SH reduced to source.sh_degree or RGB turned into
  /// the DC term, and the bounds computed as converter::compute_bounds would (runtime/device_arrays.h). The
  /// source is only read, and may change once this returns. `dropped` (optional) receives the Gaussians
  /// options.drop_invalid removed. Errors: kInvalidArgument (a null, misaligned or non-device pointer, an SH
  /// layout other than K = 1, 4, 9, 16 ≥ (sh_degree + 1)², a negative scale or an opacity outside [0, 1]:
  /// the first index), kCorruptData (non-finite values or zero quaternions without drop_invalid: the counts
  /// and the first index), kLimitExceeded (≥ 2^31 Gaussians), kOutOfMemory, kCudaError.
  static Result<GpuScene> from_device(const kernels::GaussianImportSource& source, const DeviceImportOptions& options,
                                      cudaStream_t stream = nullptr, uint64_t* dropped = nullptr);

  /// A scene over compact arrays the caller owns in device memory and keeps alive and unchanged while it
  /// renders (the level-of-detail streamer's frame arrays, runtime/lod_streamer.h): has_compact(), no FP32
  /// arrays, device_bytes() 0. `bounds` must hold every mean (the RoofGS depth key's range). `capacity`: the
  /// most Gaussians the arrays hold (0: view.count), which renderers size their per-Gaussian buffers for, so
  /// that views of a count that changes frame by frame allocate nothing after the first.
  static GpuScene compact_view(const kernels::CompactGaussiansView& view, const format::SceneBounds& bounds,
                               uint32_t capacity = 0, bool antialiased = false);

  GpuScene(GpuScene&&) noexcept = default;
  GpuScene& operator=(GpuScene&&) noexcept = default;

  uint32_t size() const { return count_; }
  /// The most Gaussians a scene over the same arrays holds: size(), or compact_view's `capacity`.
  uint32_t capacity() const { return capacity_ > count_ ? capacity_ : count_; }
  uint32_t sh_degree() const { return sh_degree_; }
  /// Scene AABB and bounding sphere (the .rgs metadata, or what from_cloud() was given).
  const std::optional<format::SceneBounds>& bounds() const { return bounds_; }
  /// The scene was trained with the 2D Mip filter (format::SceneMetadata::antialiased, GaussianCloud::antialiased,
  /// DeviceImportOptions::antialiased): renderers scale its opacities by their compensation.
  bool antialiased() const { return antialiased_; }
  /// True for scenes from a .rgs file: compact() is then valid.
  bool has_compact() const { return has_compact_; }
  /// True when the FP32 arrays are on the device (from_cloud(), or from_rgs() with fp32_attributes): the
  /// baseline pipeline and the RoofGS pipeline without compact attributes need them.
  bool has_fp32() const { return has_fp32_; }
  /// Device bytes held (compact sections, with the SH allocation's padding, + FP32 arrays).
  uint64_t device_bytes() const;
  /// Bytes of the runtime sections as the .rgs file states them uncompressed (means, rotations, scales,
  /// opacities, SH, SH DC residual: format/SPEC.md §4): N·(12 + 8 + 6 + 2 + 3K + 3r) with K = (degree + 1)² and
  /// r = 1 when the file has the DC residual. 0 for from_cloud().
  uint64_t runtime_section_bytes() const { return runtime_section_bytes_; }

  /// FP32 view for the baseline pipeline. Without has_fp32() only `means` is set (the rest null).
  kernels::Fp32GaussiansView fp32() const;
  /// Compact view of the .rgs sections (valid only when has_compact()).
  kernels::CompactGaussiansView compact() const { return compact_view_; }

 private:
  /// from_rgs() and from_encoded(): allocates the compact arrays of `n` Gaussians (the int8 ones zero-padded).
  Status allocate_compact(uint64_t n, uint32_t sh_degree, bool dc_residual, const std::string& name,
                          cudaStream_t stream);
  /// from_rgs() and from_encoded(), once the compact arrays hold the sections: the compact view from `meta`, and
  /// the FP32 arrays widened on the device when options.fp32_attributes.
  Status finish_compact(const format::SceneMetadata& meta, bool dc_residual, const GpuSceneOptions& options,
                        const std::string& name, cudaStream_t stream);

  GpuScene() = default;

  uint32_t count_ = 0;
  uint32_t capacity_ = 0;
  uint32_t sh_degree_ = 0;
  std::optional<format::SceneBounds> bounds_;
  bool antialiased_ = false;
  bool has_compact_ = false;
  bool has_fp32_ = false;
  uint64_t runtime_section_bytes_ = 0;
  kernels::CompactGaussiansView compact_view_;
  // FP32 arrays (means are shared with the compact profile, which stores them as FP32 already).
  DeviceBuffer<float> means_, rotations_, scales_, opacities_, sh_;
  // Compact sections, byte for byte as in the file.
  DeviceBuffer<uint16_t> rotations_fp16_, scales_fp16_, opacities_fp16_;
  DeviceBuffer<int8_t> sh_int8_, sh_dc_residual_;
};

}  // namespace rgs::runtime
