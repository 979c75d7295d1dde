// Per-pixel math of the rasterizer: the baseline 3DGS Gaussian power and alpha rules, and the RoofGS folded
// coefficients C1..C6 with the dual-pixel update (paper §"Rasterization Reorganization for Dual-Pixel ILP",
// Eqs. coeff, dot, dual_pixel; docs/DESIGN.md#folded-rasterizer).
#pragma once

#include <cmath>

#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/host_device.h"
#include "rgs/kernels/shared/projection.h"

namespace rgs::kernels {

/// Alpha is clamped to this before blending (3DGS min(0.99, ·)).
constexpr float kAlphaMax = 0.99f;
/// The smallest alpha a Gaussian may contribute with (3DGS skips alpha < 1/255).
constexpr float kAlphaMin = 1.0f / 255.0f;
/// A pixel stops before the Gaussian that would bring its transmittance below this (3DGS 0.0001).
constexpr float kTransmittanceMin = 0.0001f;

/// A linear colour value as an 8-bit code by the 3DGS rule floor(clamp(v, 0, 1)·255 + 0.5), no gamma; NaN
/// gives 0. The one definition for every 8-bit output (images written by the tools, RGBA8 targets on the CPU
/// and the GPU, the audit's report images).
RGS_HOST_DEVICE unsigned char unorm8(float v) {
  const float c = fminf(fmaxf(v, 0.f), 1.f);  // fmaxf(NaN, 0) = 0
  return static_cast<unsigned char>(floorf(c * 255.f + 0.5f));
}

/// Baseline Gaussian power at a pixel: power = −0.5·(a·dx² + c·dy²) − b·dx·dy, with (dx, dy) = mean − pixel
/// and the conic (a, b, c). Order of operations as 3DGS renderCUDA.
RGS_HOST_DEVICE float baseline_power(const Conic& conic, float dx, float dy) {
  return -0.5f * (conic.a * dx * dx + conic.c * dy * dy) - conic.b * dx * dy;
}

/// Folded per-(Gaussian, tile) coefficients: P(x, y) = C1·x² + C2·xy + C3·y² + C4·x + C5·y + C6 equals the
/// Gaussian power plus ln(o), so alpha~ = exp(P). x, y are TILE-LOCAL pixel coordinates (0..15; the pixel
/// minus the tile origin 16·(tx, ty)): in absolute coordinates C6 ≈ a·u²/2 reaches ~1e6 at 4K and FP32
/// cancellation costs 55–60 dB (docs/DESIGN.md#folded-rasterizer), while tile-local the folding is exact to ~95 dB.
struct FoldedCoefficients {
  float c1, c2, c3, c4, c5, c6;
};

/// Folds the conic (a, b, c) of 3DGS (quadratic form a·dx² + 2b·dx·dy + c·dy²), the tile-local mean (u, v)
/// and ln(o). The paper writes the form as A(x−u)² + B(x−u)(y−v) + C(y−v)², so its B = 2b; with that,
///   C1 = −A/2, C2 = −B/2, C3 = −C/2, C4 = A·u + B·v/2, C5 = C·v + B·u/2,
///   C6 = −(A·u² + B·u·v + C·v²)/2 + ln o.
/// In terms of the conic: C2 = −b, C4 = a·u + b·v, C5 = c·v + b·u (B/2 = b exactly).
RGS_HOST_DEVICE FoldedCoefficients fold_coefficients(const Conic& conic, float u, float v, float log_opacity) {
  FoldedCoefficients k;
  k.c1 = -0.5f * conic.a;
  k.c2 = -conic.b;
  k.c3 = -0.5f * conic.c;
  k.c4 = conic.a * u + conic.b * v;
  k.c5 = conic.c * v + conic.b * u;
  k.c6 = -0.5f * (conic.a * u * u + 2.f * conic.b * u * v + conic.c * v * v) + log_opacity;
  return k;
}

/// Pixel terms hoisted out of the Gaussian loop: x², xy, y², x, y of a tile-local pixel.
struct PixelTerms {
  float xx, xy, yy, x, y;
};

/// PixelTerms of the tile-local pixel (x, y).
RGS_HOST_DEVICE PixelTerms pixel_terms(float x, float y) { return PixelTerms{x * x, x * y, y * y, x, y}; }

/// P = C1·x² + C2·xy + C3·y² + C4·x + C5·y + C6 as the FMA chain
/// fma(C1, x², fma(C2, xy, fma(C3, y², fma(C4, x, fma(C5, y, C6))))) — the order a kernel must use to match.
RGS_HOST_DEVICE float folded_power(const FoldedCoefficients& k, const PixelTerms& p) {
  return fmaf(k.c1, p.xx, fmaf(k.c2, p.xy, fmaf(k.c3, p.yy, fmaf(k.c4, p.x, fmaf(k.c5, p.y, k.c6)))));
}

/// Dual-pixel update (paper Eq. dual_pixel): P(x, y+1) = P(x, y) + C2·x + C3·(2y+1) + C5, evaluated as
/// P + fma(C2, x, fma(C3, 2y + 1, C5)).
RGS_HOST_DEVICE float dual_pixel_power(float p_xy, const FoldedCoefficients& k, const PixelTerms& p) {
  return p_xy + fmaf(k.c2, p.x, fmaf(k.c3, 2.f * p.y + 1.f, k.c5));
}

/// The folded rasterizer's fast-exp alpha test in the form the GPU's inner loop evaluates it: returns whether
/// the pair passes (P ≤ 0 and exp̂(P) ≥ 1/255) and sets *alpha = min(0.99, exp̂(P)) when it does (otherwise
/// *alpha is unspecified, possibly NaN). exp̂'s bit pattern I = floor(P·2^23·log2 e + bias) is compared and
/// clamped as an integer, which orders like the floats it encodes while they are positive; any I below the
/// pattern of 1/255 fails, including the negative and saturated I of P below fast_exp's clamp at −87, so that
/// clamp and the float conversion are not needed. fast_exp_alpha below states the equivalence with the
/// reference form.
/// @param P     folded power (power + ln o), any float.
/// @param bias  fast_exp_bias(σ), computed once per frame.
RGS_HOST_DEVICE bool fast_exp_alpha_passes(float P, float bias, float* alpha) {
  const float v = fmaf(P, fast_exp_scale(), bias);
#if defined(__CUDA_ARCH__)
  const int32_t bits = __float2int_rd(v);  // one F2I.FLOOR; NaN gives 0, out-of-range values saturate
#else
  // v < 2^31 whenever P ≤ 0; NaN, negative and too large v (P > 0) all land below 1/255's pattern.
  const int32_t bits = (v >= 0.f && v < 2147483648.f) ? static_cast<int32_t>(floorf(v)) : -1;
#endif
  const int32_t min_bits = static_cast<int32_t>(float_as_uint(kAlphaMin));
  const int32_t max_bits = static_cast<int32_t>(float_as_uint(kAlphaMax));
  *alpha = uint_as_float(static_cast<uint32_t>(min_int(bits, max_bits)));
  return !(P > 0.f) && bits >= min_bits;
}

/// fast_exp_alpha_passes as one value: α = min(0.99, exp̂(P)), or −1 when the pair is skipped (P > 0 or
/// exp̂(P) < 1/255); bit for bit equal to  P > 0 ? −1 : (a = fminf(kAlphaMax, fast_exp(P, σ)), a < kAlphaMin ? −1 : a)
/// for every float P but NaN, which is skipped (tested).
RGS_HOST_DEVICE float fast_exp_alpha(float P, float bias) {
  float alpha;
  return fast_exp_alpha_passes(P, bias, &alpha) ? alpha : -1.f;
}

}  // namespace rgs::kernels
