// Portability layer of the math shared by the CPU reference renderer and the CUDA kernels.
//
// Every function under rgs/kernels/shared/ is header-only, takes and returns plain scalars or small PODs,
// and is marked RGS_HOST_DEVICE so that one definition serves both renderers
// (CONTRIBUTING.md#cuda-code-and-the-cpu-reference). They use the C float functions (sqrtf, fmaf, floorf,
// ...), which nvcc provides on the device and libm on the host.
//
// Bit-exactness between host and device: nvcc contracts a*b + c into FMA by default (--fmad=true), the host
// build (x86-64 without -mfma) does not. Checked on an H100 (2026-11-21, 200,000 random Gaussians through
// every function here, sm_90, nvcc 13.0): with --fmad=false every result was bit-identical to the host's;
// with the default --fmad=true most float results differed in the last bits (and 2 AccuTile tile counts and
// 965 of 200,000 depth bins changed). Kernels that must match the CPU reference term by term are therefore
// to be compiled with --fmad=false (never --use_fast_math), and rgs_runtime builds with -ffp-contract=off so
// a -march with FMA cannot change the host side; otherwise compare with tolerances. Functions whose
// exact operation order is part of their definition (folded_power, dual_pixel_power, fast_exp,
// accurate_determinant) use explicit fmaf. Transcendentals (logf in snugbox_threshold; the renderers' expf
// for alpha and logf for ln o) may differ by an ulp between libm and CUDA (none did in that check).
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
