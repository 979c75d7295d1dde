// Schraudolph's bit-level exponential (Neural Computation 11(4), 1999), as RoofGS uses it for alpha
// (paper §"Range-Aware Fast Exponential Evaluation", Eq. fma_exp; docs/DESIGN.md#fast-exponential).
#pragma once

#include "rgs/kernels/shared/host_device.h"

namespace rgs::kernels {

/// The paper's calibration σ: minimizes the maximum relative error over [−ln 255, 0] (≈ 0.0298).
constexpr float kFastExpSigmaMinMax = 0.045677f;
/// Alternative σ with near-zero mean relative error over the same range, which gives the better image
/// (docs/DESIGN.md#image-quality-of-each-technique).
constexpr float kFastExpSigmaZeroMean = 0.05798f;
/// The argument range the fast exp is specified for: P ∈ [−ln 255, 0], where opacity culling and the alpha
/// skip leave every contributing Gaussian–pixel pair.
constexpr float kFastExpRangeMin = -5.5412635451584258f;  // −ln 255
/// Relative-error bound the tests hold the approximation to over [−ln 255, 0] with σ = 0.045677.
constexpr float kFastExpMaxRelativeError = 0.0315f;
/// Arguments are clamped to [kFastExpClampMin, 0] before the bit construction so that the integer stays a
/// positive normal float pattern (exp̂(−87) ≈ 1e−38, far below the 1/255 alpha threshold).
constexpr float kFastExpClampMin = -87.0f;

/// 2^23 · log2(e) and 2^23 · (127 − σ), the two constants of I(P) = floor(P·2^23·log2 e + 2^23·(127 − σ)).
RGS_HOST_DEVICE float fast_exp_scale() { return 12102203.161561485f; }
RGS_HOST_DEVICE float fast_exp_bias(float sigma) { return 8388608.f * (127.f - sigma); }

/// exp̂(P) = reinterpret_float(I), I = floor(P·2^23·log2(e) + 2^23·(127 − σ)).
/// FP32 evaluation, identical on host and device: P is clamped to [−87, 0], then v = fmaf(P, scale, bias)
/// (one rounding; v ≈ 1e9 so it is a multiple of 64 and the floor is exact up to that granularity, which
/// adds < 8e−6 relative error), then I = (int)floorf(v). Relative error ≤ 0.0315 on [−ln 255, 0] with
/// σ = 0.045677 (tested); arguments above 0 return exp̂(0) ≈ 0.97, callers must skip them first.
RGS_HOST_DEVICE float fast_exp(float P, float sigma = kFastExpSigmaMinMax) {
  const float p = fminf(fmaxf(P, kFastExpClampMin), 0.f);
  const float v = fmaf(p, fast_exp_scale(), fast_exp_bias(sigma));
  return uint_as_float(static_cast<uint32_t>(static_cast<int32_t>(floorf(v))));
}

}  // namespace rgs::kernels
