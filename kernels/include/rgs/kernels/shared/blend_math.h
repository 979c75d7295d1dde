// Per-pixel math of the rasterizer: the baseline 3DGS Gaussian power and alpha rules, and the RoofGS folded
// coefficients C1..C6 with the dual-pixel update (paper §"Rasterization Reorganization for Dual-Pixel ILP",
// Eqs. coeff, dot, dual_pixel; DESIGN.md RoofGS item 5).
#pragma once

#include "rgs/kernels/shared/host_device.h"
#include "rgs/kernels/shared/projection.h"

namespace rgs::kernels {

/// Alpha is clamped to this before blending (3DGS min(0.99, ·)).
constexpr float kAlphaMax = 0.99f;
/// A pixel stops before the Gaussian that would bring its transmittance below this (3DGS 0.0001).
constexpr float kTransmittanceMin = 0.0001f;

/// Baseline Gaussian power at a pixel: power = −0.5·(a·dx² + c·dy²) − b·dx·dy, with (dx, dy) = mean − pixel
/// and the conic (a, b, c). Order of operations as 3DGS renderCUDA.
RGS_HOST_DEVICE float baseline_power(const Conic& conic, float dx, float dy) {
  return -0.5f * (conic.a * dx * dx + conic.c * dy * dy) - conic.b * dx * dy;
}

/// Folded per-(Gaussian, tile) coefficients: P(x, y) = C1·x² + C2·xy + C3·y² + C4·x + C5·y + C6 equals the
/// Gaussian power plus ln(o), so alpha~ = exp(P). x, y are TILE-LOCAL pixel coordinates (0..15; the pixel
/// minus the tile origin 16·(tx, ty)): in absolute coordinates C6 ≈ a·u²/2 reaches ~1e6 at 4K and FP32
/// cancellation costs 55–60 dB (DESIGN.md), while tile-local the folding is exact to ~95 dB.
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

}  // namespace rgs::kernels
