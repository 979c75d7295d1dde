// Half-precision blending of the folded rasterizer (beyond the paper): α, transmittance T and the colour sum
// of the current colour window of a thread's two pixels held as pairs of IEEE binary16 values in one 32-bit
// word each (CUDA __half2, low half = the first pixel (x, y), high half = the second (x, y + 1)), so that one
// half2 instruction blends both pixels; the closed windows' colour is FP32. The power P stays FP32
// (folded_power, dual_pixel_power); α is 2^v of it in base 2, rounded to binary16 (half2_alpha), in place of the
// paper's fast exponential. Every operation here but that exp2 is IEEE
// round-to-nearest-even with subnormals kept (no flush to zero), on the device with the half2 instructions and on
// the host in software, bit for bit. The exp2 is the device's FP32 approximation, which the host does not
// reproduce: it rounds the exact 2^v, and the two differ by one binary16 unit of α where 2^v lies within the
// approximation's error of a rounding boundary (lab/tests/test_gpu_half_alpha.cpp counts how often).
//
// Error: binary16 keeps 11 significant bits (relative rounding 2^-12 a step); α is off by at most 0.05 %
// (kHalfAlphaMaxRelativeError). Against the FP32 blend of the same pairs the measured
// images are in docs/RENDERER.md#measured-quality-of-each-switch.
#pragma once

#include <cmath>
#include <cstring>

#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/fast_exp.h"
#include "rgs/kernels/shared/host_device.h"

#if defined(__CUDACC__)
#include <cuda_fp16.h>
#endif

namespace rgs::kernels {

/// A pair of binary16 values in one word: bits 0–15 the first pixel's, bits 16–31 the second's.
using Half2Bits = uint32_t;

/// 1.0 in both halves (the initial transmittance).
constexpr Half2Bits kHalf2One = 0x3c003c00u;
/// The sign bits of both halves.
constexpr Half2Bits kHalf2Signs = 0x80008000u;
/// kTransmittanceMin (1e−4) rounded to binary16: 1678·2^−24 ≈ 1.00017e−4, in both halves.
constexpr Half2Bits kHalf2TransmittanceMin = 0x068e068eu;
/// kAlphaMin (1/255) rounded to binary16: 0x1c04 ≈ 0.0039215, in both halves.
constexpr Half2Bits kHalf2AlphaMin = 0x1c041c04u;

namespace detail {

/// Binary16 bits of the double `value` rounded to nearest, ties to even (subnormals kept, overflow to ±inf,
/// NaN to a quiet NaN). Host side of the half2 emulation: every result below is an exact double first.
inline uint16_t half_bits_from_double(double value) {
  uint64_t d;
  std::memcpy(&d, &value, sizeof d);
  const uint16_t sign = static_cast<uint16_t>((d >> 48) & 0x8000u);
  const double magnitude = value < 0 ? -value : value;
  if (magnitude != magnitude) return static_cast<uint16_t>(sign | 0x7e00u);
  if (magnitude >= 65520.0) return static_cast<uint16_t>(sign | 0x7c00u);  // rounds past 65504: inf
  // The binade's unit in the last place: 2^(e − 10) for magnitude in [2^e, 2^(e+1)), at least 2^−24.
  int exponent = 0;
  std::frexp(magnitude, &exponent);  // magnitude = m·2^exponent, m in [0.5, 1)
  const int e = exponent - 1 < -14 ? -14 : exponent - 1;
  const double ulp = std::ldexp(1.0, e - 10);
  const double units = std::nearbyint(magnitude / ulp);  // exact division by a power of two; ties to even
  const double rounded = units * ulp;
  if (rounded >= 65520.0) return static_cast<uint16_t>(sign | 0x7c00u);
  if (rounded < 6.103515625e-05) return static_cast<uint16_t>(sign | static_cast<uint16_t>(units));  // subnormal
  int re = 0;
  const double m = std::frexp(rounded, &re);  // rounded = m·2^re, m in [0.5, 1)
  const uint16_t biased = static_cast<uint16_t>(re - 1 + 15);
  const uint16_t mantissa = static_cast<uint16_t>(std::ldexp(m, 11) - 1024.0);
  return static_cast<uint16_t>(sign | (biased << 10) | mantissa);
}

/// The binary16 value of `bits` as a double (exact).
inline double half_bits_to_double(uint16_t bits) {
  const int exponent = (bits >> 10) & 0x1f;
  const int mantissa = bits & 0x3ff;
  double v;
  if (exponent == 0x1f) {
    v = mantissa != 0 ? std::nan("") : HUGE_VAL;
  } else if (exponent == 0) {
    v = std::ldexp(double(mantissa), -24);
  } else {
    v = std::ldexp(double(mantissa + 1024), exponent - 25);
  }
  return (bits & 0x8000u) ? -v : v;
}

/// Correctly rounded binary16 of the exact sum p + c of two doubles (p + c itself may not be a double):
/// the double sum s and its exact error e (Knuth's TwoSum); s rounds to binary16 as p + c does unless s sits
/// exactly halfway between two binary16 values and e ≠ 0, where e breaks the tie.
inline uint16_t half_bits_of_sum(double p, double c) {
  const double s = p + c;
  const double pv = s - c, cv = s - pv;
  const double e = (p - pv) + (c - cv);
  const uint16_t rounded = half_bits_from_double(s);
  if (e == 0.0 || s != s) return rounded;
  const uint16_t below = half_bits_from_double(std::nextafter(s, -HUGE_VAL));
  const uint16_t above = half_bits_from_double(std::nextafter(s, HUGE_VAL));
  if (below == above || s != (half_bits_to_double(below) + half_bits_to_double(above)) / 2) return rounded;
  return e > 0 ? above : below;
}

inline uint16_t half_lane(Half2Bits h, int lane) { return static_cast<uint16_t>(h >> (16 * lane)); }
inline Half2Bits half2_of(uint16_t first, uint16_t second) { return uint32_t(first) | uint32_t(second) << 16; }

/// Host emulation of a two-operand half2 instruction: op(bits_a, value_a, bits_b, value_b) -> result bits, per
/// half (values as exact doubles).
template <typename Op>
inline Half2Bits lanewise(Half2Bits a, Half2Bits b, Op op) {
  uint16_t r[2];
  for (int i = 0; i < 2; ++i) {
    const uint16_t x = half_lane(a, i), y = half_lane(b, i);
    r[i] = op(x, half_bits_to_double(x), y, half_bits_to_double(y));
  }
  return half2_of(r[0], r[1]);
}

#if defined(__CUDA_ARCH__)
__device__ inline __half2 as_half2(Half2Bits h) { return *reinterpret_cast<const __half2*>(&h); }
__device__ inline Half2Bits as_bits(__half2 h) { return *reinterpret_cast<const Half2Bits*>(&h); }
#endif

}  // namespace detail

/// a·b per half, rounded to nearest even (__hmul2).
RGS_HOST_DEVICE Half2Bits half2_mul(Half2Bits a, Half2Bits b) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__hmul2(detail::as_half2(a), detail::as_half2(b)));
#else
  return detail::lanewise(a, b, [](uint16_t, double x, uint16_t, double y) {
    return detail::half_bits_from_double(x * y);  // exact product: 22 bits
  });
#endif
}

/// a − b per half, rounded to nearest even (__hsub2).
RGS_HOST_DEVICE Half2Bits half2_sub(Half2Bits a, Half2Bits b) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__hsub2(detail::as_half2(a), detail::as_half2(b)));
#else
  return detail::lanewise(a, b, [](uint16_t, double x, uint16_t, double y) {
    return detail::half_bits_from_double(x - y);  // exact in a double
  });
#endif
}

/// a·b + c per half with one rounding to nearest even (__hfma2).
RGS_HOST_DEVICE Half2Bits half2_fma(Half2Bits a, Half2Bits b, Half2Bits c) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__hfma2(detail::as_half2(a), detail::as_half2(b), detail::as_half2(c)));
#else
  uint16_t r[2];
  for (int i = 0; i < 2; ++i) {
    const double product = detail::half_bits_to_double(detail::half_lane(a, i)) *
                           detail::half_bits_to_double(detail::half_lane(b, i));  // exact: 22 bits
    r[i] = detail::half_bits_of_sum(product, detail::half_bits_to_double(detail::half_lane(c, i)));
  }
  return detail::half2_of(r[0], r[1]);
#endif
}

/// 0xffff in each half where a ≥ b (ordered: false with a NaN), else 0 (__hge2_mask).
RGS_HOST_DEVICE Half2Bits half2_ge_mask(Half2Bits a, Half2Bits b) {
#if defined(__CUDA_ARCH__)
  return __hge2_mask(detail::as_half2(a), detail::as_half2(b));
#else
  return detail::lanewise(a, b, [](uint16_t, double x, uint16_t, double y) { return uint16_t(x >= y ? 0xffffu : 0u); });
#endif
}

/// min(a, b) per half (__hmin2): a NaN operand yields the other one (two NaNs: a NaN), and +0 > −0.
RGS_HOST_DEVICE Half2Bits half2_min(Half2Bits a, Half2Bits b) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__hmin2(detail::as_half2(a), detail::as_half2(b)));
#else
  return detail::lanewise(a, b, [](uint16_t x, double xv, uint16_t y, double yv) {
    if (xv != xv) return yv != yv ? uint16_t(0x7fffu) : y;
    if (yv != yv) return x;
    if (xv == 0.0 && yv == 0.0) return (x & 0x8000u) ? x : y;  // −0 is the smaller zero
    return xv < yv ? x : y;
  });
#endif
}

/// The binary16 value of `bits` as a float (exact).
RGS_HOST_DEVICE float half_to_float(uint16_t bits) {
#if defined(__CUDA_ARCH__)
  return __half2float(__ushort_as_half(bits));
#else
  return static_cast<float>(detail::half_bits_to_double(bits));
#endif
}

/// A float rounded to binary16, in both halves (__float2half2_rn): a colour channel for both pixels.
RGS_HOST_DEVICE Half2Bits half2_broadcast(float v) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__float2half2_rn(v));
#else
  const uint16_t h = detail::half_bits_from_double(static_cast<double>(v));
  return detail::half2_of(h, h);
#endif
}

/// The low (first pixel's) half of `h` in both halves (__low2half2; on the device an operand swizzle of the
/// instruction that reads it).
RGS_HOST_DEVICE Half2Bits half2_low(Half2Bits h) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__low2half2(detail::as_half2(h)));
#else
  return (h & 0xffffu) | (h << 16);
#endif
}

/// The high half of `h` in both halves (__high2half2).
RGS_HOST_DEVICE Half2Bits half2_high(Half2Bits h) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__high2half2(detail::as_half2(h)));
#else
  return (h >> 16) | (h & 0xffff0000u);
#endif
}

/// log2 e as a float: the folded coefficients times it give the power in base 2 (exp2_coefficients).
constexpr float kLog2e = 1.44269504088896341f;

/// The folded coefficients whose power is v = P·log2 e instead of P (each one FP32 product, one rounding), so
/// that folded_power and dual_pixel_power give both pixels' exponent in base 2 for half2_alpha.
RGS_HOST_DEVICE FoldedCoefficients exp2_coefficients(const FoldedCoefficients& f) {
  return FoldedCoefficients{f.c1 * kLog2e, f.c2 * kLog2e, f.c3 * kLog2e, f.c4 * kLog2e, f.c5 * kLog2e, f.c6 * kLog2e};
}

/// Two floats rounded to binary16, `first` in the low half (__floats2half2_rn: one F2FP instruction).
RGS_HOST_DEVICE Half2Bits half2_pack(float first, float second) {
#if defined(__CUDA_ARCH__)
  return detail::as_bits(__floats2half2_rn(first, second));
#else
  return detail::half2_of(detail::half_bits_from_double(static_cast<double>(first)),
                          detail::half_bits_from_double(static_cast<double>(second)));
#endif
}

/// The largest |α / 2^v − 1| of half2_alpha for α ≥ 1/255 (v in [log2(1/255), 0]): the rounding to binary16,
/// at most 2^−11 relative for these normal values, plus the device's FP32 exp2 approximation, about 2^−22
/// (tests/runtime/test_half_blend.cpp measures the host's form, lab/tests/test_gpu_half_alpha.cpp the device's).
constexpr double kHalfAlphaMaxRelativeError = 0.0005;
/// 3DGS's α clamp 0.99 rounded to the nearest binary16 (0x3bec = 0.990234375), in both halves.
constexpr Half2Bits kHalf2AlphaMax = 0x3bec3becu;

/// The α each pixel of a thread blends with, from both pixels' folded powers in base 2 (folded_power and
/// dual_pixel_power of exp2_coefficients): e = 2^v per pixel rounded to binary16, then min(e, 0.990234) where
/// e ≥ 1/255, else +0 (the pair is skipped there). On the device 2^v is ex2.approx.ftz.f32 (SASS MUFU.EX2),
/// and one F2FP rounds both to binary16: three instructions for both pixels before the clamp. On the host it is
/// the exact 2^v rounded once (see the top of this file for where the two differ). The clamp takes the place of
/// both 3DGS's 0.99 clamp and the FP32 loop's P > 0 skip: a folded power is ≤ ln o ≤ 0 but for rounding, and
/// skipping where e > 1 would drop opaque Gaussians at their centres. A NaN power is skipped (the 1/255 test is
/// on e, before the clamp, which would turn a NaN into 0.990234); from v ≥ 16 on e is +inf, clamped to 0.990234.
RGS_HOST_DEVICE Half2Bits half2_alpha(float v_first, float v_second) {
#if defined(__CUDA_ARCH__)
  float e_first, e_second;
  asm("ex2.approx.ftz.f32 %0, %1;" : "=f"(e_first) : "f"(v_first));
  asm("ex2.approx.ftz.f32 %0, %1;" : "=f"(e_second) : "f"(v_second));
  const Half2Bits e = half2_pack(e_first, e_second);
#else
  const Half2Bits e = detail::half2_of(detail::half_bits_from_double(std::exp2(static_cast<double>(v_first))),
                                       detail::half_bits_from_double(std::exp2(static_cast<double>(v_second))));
#endif
  return half2_min(e, kHalf2AlphaMax) & half2_ge_mask(e, kHalf2AlphaMin);
}

/// Colour windows (beyond the paper). Summed in binary16 alone, a pixel's colour loses every late contribution
/// below half a unit of the sum (2^−12 of it): taebak's 8-bit image read 60.5–60.8 dB against the 3DGS
/// rasterizer's. So a pixel sums its colour in binary16 over a window of kColourWindowEntries consecutive
/// entries of its walk list only, then adds the window's sum to an FP32 colour (close_colour_window):
/// docs/RENDERER.md#colour-windows for what it measured and cost. A window is one step of the GPU's walk
/// (render_kernels.cuh: kUnroll pairs, one liveness test), so its bounds follow the walk lists: the pairs of a
/// batch of walk_batch_pairs consecutive pairs of the tile's list (of a chunk's, from its first pair) that the
/// pixel's 4×4 block keeps (block_mask) under block culling, else every pair of the batch, each batch's list
/// walked in windows from its start. The CPU reference builds the same lists.
constexpr int kColourWindowEntries = 4;

/// Pairs per batch of the GPU's folded rasterizer: two a thread with block culling, one without.
constexpr uint32_t walk_batch_pairs(bool block_culling) { return block_culling ? 256u : 128u; }

/// The running state of a thread's two pixels: T as Half2Bits, the sign of T the stop flag as in the FP32 loop
/// (T < 0: done, −T the final transmittance); the colour as the binary16 sum of the current colour window
/// (r, g, b: Half2Bits) plus the FP32 sum of the windows closed before it (C[pixel][channel]).
struct HalfPixelPair {
  Half2Bits T = kHalf2One;
  Half2Bits r = 0, g = 0, b = 0;
  float C[2][3] = {{0.f, 0.f, 0.f}, {0.f, 0.f, 0.f}};
};

/// Channel `channel` (0 r, 1 g, 2 b) of pixel `lane`'s colour: the closed windows' FP32 sum plus the current
/// window's binary16 sum, one FP32 addition.
RGS_HOST_DEVICE float half_pixel_colour(const HalfPixelPair& s, int lane, int channel) {
  const Half2Bits window = channel == 0 ? s.r : channel == 1 ? s.g : s.b;
  return s.C[lane][channel] + half_to_float(static_cast<uint16_t>(window >> (16 * lane)));
}

/// Ends the current colour window (kColourWindowEntries): its sums join C, and the next window starts at +0.
RGS_HOST_DEVICE void close_colour_window(HalfPixelPair& s) {
  for (int lane = 0; lane < 2; ++lane) {
    for (int channel = 0; channel < 3; ++channel) s.C[lane][channel] = half_pixel_colour(s, lane, channel);
  }
  s.r = s.g = s.b = 0;
}

/// One front-to-back step of both pixels (the FP32 blend_predicated's rule in binary16): w = α·T,
/// T' = T − w, take the pair where T' ≥ 1e−4 (window colour += c·w, T = T'), else stop (T = −|T|). α = +0
/// (skipped) gives w = +0 and changes nothing; a done pixel (T < 0) gives T' < 0, which stops again and keeps
/// T. Returns the taken weights w (0 where not taken) for callers that also sum depth.
/// @param alpha  half2_alpha's result
/// @param r, g, b  the Gaussian's colour in both halves (half2_broadcast)
RGS_HOST_DEVICE Half2Bits blend_half2(HalfPixelPair& s, Half2Bits alpha, Half2Bits r, Half2Bits g, Half2Bits b) {
  const Half2Bits w = half2_mul(alpha, s.T);
  const Half2Bits test_T = half2_sub(s.T, w);
  const Half2Bits take = half2_ge_mask(test_T, kHalf2TransmittanceMin);
  const Half2Bits w_taken = w & take;
  s.r = half2_fma(r, w_taken, s.r);
  s.g = half2_fma(g, w_taken, s.g);
  s.b = half2_fma(b, w_taken, s.b);
  s.T = (test_T & take) | ((s.T | kHalf2Signs) & ~take);
  return w_taken;
}

/// Whether either pixel of the pair is still blending.
RGS_HOST_DEVICE bool half_pair_live(const HalfPixelPair& s) { return (s.T & kHalf2Signs) != kHalf2Signs; }

}  // namespace rgs::kernels
