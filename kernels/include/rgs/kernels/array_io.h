// Float arrays in a caller's device memory (a training framework's tensors): Gaussians imported into the FP32
// layout of Fp32GaussiansView with the value checks a file's Gaussians get, and a rendered RGBA frame split
// into gsplat's planar outputs (colours and alphas as separate arrays).
#pragma once

#include <cuda_runtime_api.h>

#include <cstddef>
#include <cstdint>

#include "rgs/kernels/shared/host_device.h"

namespace rgs::kernels {

/// The caller's Gaussians (device memory, float32, tightly packed row-major; N = count):
/// - means      [N, 3] world units;
/// - rotations  [N, 4] quaternions (w, x, y, z) of any nonzero norm (normalized on import);
/// - scales     [N, 3] linear scales;
/// - opacities  [N] activated opacities;
/// - colors     [N, K, 3] SH coefficients, colour channel fastest (K = color_coefficients), of which the first
///   (sh_degree + 1)² are imported; or, when `rgb`, [N, 3] RGB colours, imported as the DC coefficient that
///   renders them, (c − 0.5) / kShC0 (then sh_degree is 0).
struct GaussianImportSource {
  const float* means = nullptr;
  const float* rotations = nullptr;
  const float* scales = nullptr;
  const float* opacities = nullptr;
  const float* colors = nullptr;
  uint64_t count = 0;  ///< at most 2^31 − 1
  uint32_t color_coefficients = 1;
  uint32_t sh_degree = 0;
  bool rgb = false;
};

/// What launch_check_gaussians() finds, in device memory. Index fields hold the smallest index with the
/// property, or kNoGaussian; AABB fields are order-preserving keys of floats (ordered_float_key()).
struct GaussianImportTotals {
  /// Non-finite values among a Gaussian's imported values (NaN opacities only: an infinite one is outside
  /// [0, 1]), the Gaussians with at least one, and finite quaternions of squared norm below FLT_MIN.
  unsigned long long nonfinite_values;
  unsigned long long gaussians_with_nonfinite;
  unsigned long long zero_norm_quaternions;
  /// Gaussians with a non-finite value or a zero quaternion (those a sanitizing import drops).
  unsigned long long invalid;
  unsigned long long first_invalid;
  unsigned long long first_negative_scale;  ///< a scale below 0 (not NaN)
  unsigned long long first_bad_opacity;     ///< an opacity below 0 or above 1 (not NaN)
  /// Keys of the smallest and largest mean coordinate per axis over the valid Gaussians.
  unsigned int aabb_min_key[3];
  unsigned int aabb_max_key[3];
  /// Bits of the largest float64 squared distance of a valid mean from the centre launch_gather_gaussians()
  /// was given (non-negative, so its bits order as the values do).
  unsigned long long radius2_bits;
};

/// GaussianImportTotals's "no such Gaussian".
constexpr unsigned long long kNoGaussian = ~0ull;

/// A key whose unsigned order is the float order (−0 below +0; no NaN is ever keyed).
RGS_HOST_DEVICE unsigned int ordered_float_key(unsigned int float_bits) {
  return (float_bits & 0x80000000u) ? ~float_bits : (float_bits | 0x80000000u);
}
/// The float bits of ordered_float_key()'s result.
RGS_HOST_DEVICE unsigned int float_bits_of_key(unsigned int key) {
  return (key & 0x80000000u) ? (key & 0x7fffffffu) : ~key;
}

/// Resets *totals and checks every Gaussian of `source` on `stream` (one grid-stride pass): counts and first
/// indices as GaussianImportTotals says, the AABB of the valid means and, when `valid` is not null, valid[i]
/// = 1 for a valid Gaussian and 0 otherwise ([N] uint32). Values are those the import writes (RGB
/// converted, SH beyond sh_degree ignored). Does not synchronize.
/// @return the launch error (cudaGetLastError folded in).
cudaError_t launch_check_gaussians(const GaussianImportSource& source, GaussianImportTotals* totals,
                                   unsigned int* valid, cudaStream_t stream);

/// Scratch bytes launch_compact_offsets() needs for `count` Gaussians.
size_t compact_offsets_scratch_bytes(uint64_t count);

/// offsets[i] = Σ_{j<i} valid[j] ([N] uint32 each): where a sanitizing import writes Gaussian i. `scratch`
/// holds compact_offsets_scratch_bytes(count) bytes. Does not synchronize. @return the launch error.
cudaError_t launch_compact_offsets(const unsigned int* valid, unsigned int* offsets, uint64_t count, void* scratch,
                                   size_t scratch_bytes, cudaStream_t stream);

/// FP32 destination of an import (Fp32GaussiansView's layout, K = (sh_degree + 1)²), device memory.
struct GaussianImportTarget {
  float* means = nullptr;      ///< [M, 3]
  float* rotations = nullptr;  ///< [M, 4] unit quaternions: q·(1/√Σq²) in float64, rounded to float
  float* scales = nullptr;     ///< [M, 3]
  float* opacities = nullptr;  ///< [M]
  float* sh = nullptr;         ///< [M, K, 3]
  /// Null: every Gaussian is written at its own index (M = N; the caller has checked that all are valid).
  /// Otherwise launch_compact_offsets()'s result: valid Gaussians only, in order (M = the valid count).
  const unsigned int* offsets = nullptr;
  /// The bounding sphere's centre the squared radius is measured from (GaussianImportTotals::radius2_bits).
  float center[3] = {0, 0, 0};
};

/// Writes the valid Gaussians of `source` into `target` and sets totals->radius2_bits (reset first) on
/// `stream`. Does not synchronize. @return the launch error.
cudaError_t launch_gather_gaussians(const GaussianImportSource& source, const GaussianImportTarget& target,
                                    GaussianImportTotals* totals, cudaStream_t stream);

/// What the depth plane of gsplat's colours holds.
enum class PlanarDepth : uint32_t {
  kNone = 0,
  kExpected = 1,     ///< ED: Σ wᵢzᵢ / Σ wᵢ as rendered
  kAccumulated = 2,  ///< D: ED·α
};

/// One rendered frame split into gsplat's outputs (device memory, tightly packed).
struct PlanarOutputParams {
  const float* rgba = nullptr;   ///< [H, W, 4] float32 as the renderer writes it
  const float* depth = nullptr;  ///< [H, W] float32 expected depth; required unless depth_mode is kNone
  uint32_t width = 0, height = 0;
  /// [H, W, C] float32: R, G, B when `rgb`, then the depth value unless depth_mode is kNone (C = 3·rgb + 1·depth).
  float* colors = nullptr;
  bool rgb = true;
  PlanarDepth depth_mode = PlanarDepth::kNone;
  float* alphas = nullptr;  ///< [H, W, 1] float32: A = 1 − T
};

/// Writes one frame's planar outputs on `stream`, one thread per pixel. No-op for a zero size.
/// @return the launch error.
cudaError_t launch_planar_output(const PlanarOutputParams& params, cudaStream_t stream);

}  // namespace rgs::kernels
