// Gaussians in a caller's CUDA device memory (a training framework's tensors, e.g. through DLPack) made into a
// Scene with device work only, and rendered frames written into gsplat's planar outputs in device memory.
// Usable without CUDA headers; in a build without CUDA both calls fail with kUnsupportedFeature.
#pragma once

#include <cstdint>
#include <string>

#include "rgs/api/renderer.h"
#include "rgs/api/scene.h"
#include "rgs/converter/scene_reader.h"
#include "rgs/format/status.h"

namespace rgs::api {

/// Float Gaussians in CUDA device memory in gsplat's rasterization() layout: float32, tightly packed row-major,
/// N = count (format::GaussianCloud's layout and encodings, docs/DESIGN.md#attributes).
struct DeviceGaussians {
  const float* means = nullptr;      ///< [N, 3] world units
  const float* quats = nullptr;      ///< [N, 4] (w, x, y, z), any nonzero norm (normalized on loading)
  const float* scales = nullptr;     ///< [N, 3] linear scales (exp of log scales), ≥ 0
  const float* opacities = nullptr;  ///< [N] activated opacities (sigmoid of logits), in [0, 1]
  /// [N, K, 3] SH coefficients, colour channel fastest (K = sh_coefficients), or [N, 3] RGB when `rgb`,
  /// rendered as the DC coefficient (c − 0.5) / C0.
  const float* colors = nullptr;
  uint64_t count = 0;
  uint32_t sh_coefficients = 1;  ///< K of `colors`: 1, 4, 9 or 16 (not read for RGB)
  uint32_t sh_degree = 0;        ///< SH degree rendered: the first (sh_degree + 1)² ≤ K coefficients (0 for RGB)
  bool rgb = false;
};

/// Options of load_device_gaussians().
struct DeviceLoadOptions {
  /// The CUDA device holding the arrays (made current on the calling thread); the scene lives there too.
  int cuda_device = 0;
  /// Gaussians with a non-finite value or a zero quaternion: rejected (kCorruptData) or dropped.
  converter::InvalidPolicy invalid_policy = converter::InvalidPolicy::kReject;
  /// Stands for the path in SceneInfo and messages.
  std::string name = "arrays";
  /// The Gaussians were trained with the 2D Mip filter (format::SceneMetadata::antialiased): renders scale their
  /// opacities by its compensation.
  bool antialiased = false;
  /// The work is enqueued on this stream, after what the caller enqueued there (the producer of the arrays).
  Stream stream = nullptr;
};

/// A CUDA scene (FP32 arrays, like load_cloud's) copied from `gaussians` on the device: the value rules of
/// converter::scene_from_cloud (checked by a kernel), quaternions normalized, SH reduced to sh_degree or RGB
/// turned into the DC term, bounds as converter::compute_bounds; no Gaussian passes through host memory (only
/// the counts of the checks and the bounds come back). Synchronous: the arrays may change or be freed once it
/// returns, and the scene never sees them again. The device arrays equal bit for bit those of the same
/// Gaussians in host memory through scene_from_cloud() and load_cloud(). Renders with every preset (the
/// RoofGS presets on FP32).
/// @return kInvalidArgument (a null, misaligned or host pointer, K not 1, 4, 9, 16 or below (sh_degree + 1)²,
/// a negative scale or an opacity outside [0, 1]: the first index), kCorruptData (non-finite values or zero
/// quaternions under kReject: their counts and the first index), kLimitExceeded (≥ 2^31 Gaussians),
/// kUnsupportedFeature (no CUDA in this build, or no usable device), kOutOfMemory, kCudaError.
Result<Scene> load_device_gaussians(const DeviceGaussians& gaussians, const DeviceLoadOptions& options = {});

/// What the depth channel of gsplat's colours holds.
enum class DepthOutput {
  kNone = 0,
  kExpected = 1,     ///< gsplat's "ED": Σ wᵢzᵢ / Σ wᵢ (0 where nothing blended)
  kAccumulated = 2,  ///< gsplat's "D": the expected depth times alpha
};

/// gsplat's outputs of one view in device memory of the image's device, tightly packed.
struct PlanarTarget {
  /// [H, W, C] float32: R, G, B when `rgb`, then the depth value unless depth is kNone (C = 3 + 1, 3 or 1).
  float* colors = nullptr;
  bool rgb = true;
  DepthOutput depth = DepthOutput::kNone;
  float* alphas = nullptr;  ///< [H, W, 1] float32, 1 − T
};

/// Writes the GPU `image` (kRgba32f, with a depth plane when target.depth asks for one) into `target`,
/// enqueued on `stream`: render the image on the same stream (Renderer::render into image.target()), so that
/// the copy follows the frame; nothing waits. Values are copied as rendered (D: one float product).
/// @return kInvalidArgument (a CPU image, another format, no depth plane, a null or misaligned array),
/// kUnsupportedFeature (no CUDA in this build), kCudaError.
Status write_planar(const Image& image, const PlanarTarget& target, Stream stream = nullptr);

}  // namespace rgs::api
