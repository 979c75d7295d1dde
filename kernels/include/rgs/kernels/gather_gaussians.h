// Copies runs of compact Gaussians between device arrays: how the level-of-detail streamer scatters uploaded
// ranges into its page pool and gathers a frame's selection out of it (runtime/lod_streamer.h).
#pragma once

#include <cuda_runtime_api.h>

#include <cstdint>

namespace rgs::kernels {

/// Compact Gaussian arrays (format/SPEC.md §4.3–§4.8 layout, little-endian as stored), indexed by Gaussian.
struct CompactArrays {
  float* means = nullptr;           ///< [n, 3]
  uint16_t* rotations = nullptr;    ///< [n, 4] f16 bits
  uint16_t* scales = nullptr;       ///< [n, 3] f16 bits
  uint16_t* opacities = nullptr;    ///< [n] f16 bits
  int8_t* sh = nullptr;             ///< [n, K, 3]
  int8_t* sh_dc_residual = nullptr; ///< [n, 3], or null when the scene has none
};

/// One run: Gaussians [src, src + count) of the source go to [dst, dst + count) of the destination.
struct GatherRun {
  uint32_t src = 0;
  uint32_t dst = 0;
  uint32_t count = 0;
};

/// Copies every run of `runs` (device memory, `run_count` entries) from `src` to `dst`; `sh_bytes` = 3K bytes of
/// SH per Gaussian; the residual is copied when both arrays have one. Runs must not overlap in `dst`.
/// Asynchronous on `stream`.
cudaError_t gather_gaussians(const GatherRun* runs, uint32_t run_count, CompactArrays src, CompactArrays dst,
                             uint32_t sh_bytes, cudaStream_t stream);

}  // namespace rgs::kernels
