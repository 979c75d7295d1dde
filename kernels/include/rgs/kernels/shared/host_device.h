// Portability layer of the math shared by the CPU reference renderer and the CUDA kernels.
//
// Every function under rgs/kernels/shared/ is header-only, takes and returns plain scalars or small PODs,
// and is marked RGS_HOST_DEVICE so that one definition serves both renderers (STYLE.md §5). They use the
// C float functions (sqrtf, fmaf, ...), which nvcc provides on the device and libm on the host; with
// IEEE-correct rounding on both sides (no --use_fast_math on this code) they give identical results
// wherever only +, -, *, /, sqrtf and fmaf are involved. expf/logf may differ by an ulp between libm and
// CUDA.
#pragma once

#include <math.h>  // sqrtf, fmaf, floorf, ... in the global namespace, as CUDA declares them

#include <cstdint>
#include <cstring>

#if defined(__CUDACC__)
/// Marks a function callable from host and device code; implies inline.
#define RGS_HOST_DEVICE __host__ __device__ inline
#else
/// Marks a function callable from host and device code; implies inline.
#define RGS_HOST_DEVICE inline
#endif

namespace rgs::kernels {

/// Side of a square screen tile in pixels (the 3DGS BLOCK_X = BLOCK_Y = 16).
constexpr int kTileSize = 16;

/// The IEEE-754 bit pattern of `v` (CUDA __float_as_uint).
RGS_HOST_DEVICE uint32_t float_as_uint(float v) {
#if defined(__CUDA_ARCH__)
  return __float_as_uint(v);
#else
  uint32_t u;
  std::memcpy(&u, &v, sizeof u);
  return u;
#endif
}

/// The float whose IEEE-754 bit pattern is `u` (CUDA __uint_as_float).
RGS_HOST_DEVICE float uint_as_float(uint32_t u) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(u);
#else
  float v;
  std::memcpy(&v, &u, sizeof v);
  return v;
#endif
}

/// Integer min/max/clamp usable on both sides (std::min is not a device function).
RGS_HOST_DEVICE int min_int(int a, int b) { return a < b ? a : b; }
RGS_HOST_DEVICE int max_int(int a, int b) { return a > b ? a : b; }
RGS_HOST_DEVICE int clamp_int(int v, int lo, int hi) { return min_int(hi, max_int(lo, v)); }

/// Number of tiles needed to cover `pixels` pixels: ceil(pixels / 16).
RGS_HOST_DEVICE int tile_count_for(int pixels) { return (pixels + kTileSize - 1) / kTileSize; }

}  // namespace rgs::kernels
