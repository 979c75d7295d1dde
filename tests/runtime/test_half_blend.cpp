// Half-precision blending (kernels/shared/half_blend.h): the host emulation of the half2 instructions rounds
// as IEEE binary16 does (against format::float_to_half_bits and an exact 113-bit evaluation), α is 2^v rounded
// to nearest within its stated error, clamps at 0.99 and skips below 1/255, and one blend step follows its stated
// rules.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <utility>

#include <doctest/doctest.h>

#include "rgs/format/half.h"
#include "rgs/kernels/shared/blend_math.h"
#include "rgs/kernels/shared/half_blend.h"

namespace rgs::test {
namespace {

namespace k = rgs::kernels;
using Exact = __float128;  // 113-bit significand: a·b + c of binary16 values is exact in it

uint16_t lane(k::Half2Bits h, int i) { return static_cast<uint16_t>(h >> (16 * i)); }
k::Half2Bits pair(uint16_t first, uint16_t second) { return uint32_t(first) | uint32_t(second) << 16; }
Exact exact_of(uint16_t h) { return static_cast<Exact>(k::detail::half_bits_to_double(h)); }

/// Whether `r` is `exact` rounded to the nearest binary16, ties to even (finite values only).
bool is_nearest_even(uint16_t r, Exact exact) {
  const Exact value = exact_of(r);
  const Exact error = value > exact ? value - exact : exact - value;
  // The neighbours of r on the binary16 line (through zero: +0's lower neighbour is the smallest negative).
  const auto neighbour = [](uint16_t h, int step) -> uint16_t {
    const bool negative = (h & 0x8000u) != 0;
    const uint16_t magnitude = h & 0x7fffu;
    if (magnitude == 0) return step > 0 ? uint16_t(0x0001u) : uint16_t(0x8001u);
    return static_cast<uint16_t>((negative ? -step : step) + int(h));
  };
  for (int step : {-1, 1}) {
    const uint16_t n = neighbour(r, step);
    if ((n & 0x7c00u) == 0x7c00u) continue;  // beyond the largest finite value
    const Exact other = exact_of(n) > exact ? exact_of(n) - exact : exact - exact_of(n);
    if (other < error) return false;
    if (other == error && (r & 1u) != 0) return false;  // a tie goes to the even significand
  }
  return true;
}

/// A random finite binary16 with a magnitude in [2^lo, 2^hi) or a subnormal, either sign.
uint16_t random_half(std::mt19937& rng, int lo, int hi) {
  std::uniform_int_distribution<int> exponent(lo + 15, hi + 14), mantissa(0, 1023), sign(0, 1), kind(0, 15);
  if (kind(rng) == 0) return static_cast<uint16_t>(sign(rng) << 15 | mantissa(rng));  // subnormal or zero
  const int e = std::max(1, std::min(30, exponent(rng)));
  return static_cast<uint16_t>(sign(rng) << 15 | e << 10 | mantissa(rng));
}

TEST_CASE("half emulation: double -> binary16 rounds as format::float_to_half_bits (F16C) on every 257th float") {
  uint64_t checked = 0, mismatches = 0;
  for (uint64_t bits = 0; bits <= 0xffffffffull; bits += 257) {
    float f;
    const uint32_t b = uint32_t(bits);
    std::memcpy(&f, &b, 4);
    if (std::isnan(f)) continue;
    ++checked;
    mismatches += k::detail::half_bits_from_double(double(f)) != format::float_to_half_bits(f);
  }
  MESSAGE(checked << " floats rounded to binary16, " << mismatches << " mismatches");
  CHECK(checked > 16000000);
  CHECK(mismatches == 0);
}

TEST_CASE("half emulation: half2_mul, half2_sub and half2_fma round the exact result to nearest even") {
  std::mt19937 rng(2026);
  uint64_t checked = 0, wrong_mul = 0, wrong_sub = 0, wrong_fma = 0;
  for (int i = 0; i < 200000; ++i) {
    // Magnitudes as in the blend (α, T, w in [2^-24, 1], colours up to a few, C up to a few) and wider.
    const uint16_t a = random_half(rng, -14, 3), b = random_half(rng, -14, 3), c = random_half(rng, -14, 6);
    const uint16_t a2 = random_half(rng, -24, 7), b2 = random_half(rng, -24, 7), c2 = random_half(rng, -24, 14);
    const k::Half2Bits mul = k::half2_mul(pair(a, a2), pair(b, b2));
    const k::Half2Bits sub = k::half2_sub(pair(a, a2), pair(c, c2));
    const k::Half2Bits fma = k::half2_fma(pair(a, a2), pair(b, b2), pair(c, c2));
    const uint16_t as[2] = {a, a2}, bs[2] = {b, b2}, cs[2] = {c, c2};
    for (int l = 0; l < 2; ++l) {
      const Exact p = exact_of(as[l]) * exact_of(bs[l]);
      const Exact d = exact_of(as[l]) - exact_of(cs[l]);
      const Exact s = p + exact_of(cs[l]);
      const auto finite = [](Exact v) { return v < Exact(65504) && v > Exact(-65504); };
      if (!finite(p) || !finite(d) || !finite(s)) continue;
      ++checked;
      wrong_mul += !is_nearest_even(lane(mul, l), p);
      wrong_sub += !is_nearest_even(lane(sub, l), d);
      wrong_fma += !is_nearest_even(lane(fma, l), s);
    }
  }
  MESSAGE(checked << " lanes: " << wrong_mul << " / " << wrong_sub << " / " << wrong_fma
                  << " not the nearest-even binary16 (mul / sub / fma)");
  CHECK(checked > 390000);
  CHECK(wrong_mul == 0);
  CHECK(wrong_sub == 0);
  CHECK(wrong_fma == 0);
  // A product exactly halfway between two binary16 values (1 + 2^-11 = 1.5 × 0.6669921875) rounds to even (1.0);
  // a sum just past the halfway point rounds up.
  const uint16_t one_and_a_half = format::float_to_half_bits(1.5f), b = format::float_to_half_bits(0.6669921875f);
  CHECK(lane(k::half2_mul(pair(one_and_a_half, 0), pair(b, 0)), 0) == format::float_to_half_bits(1.f));
  CHECK(lane(k::half2_fma(pair(one_and_a_half, 0), pair(b, 0), pair(0x0001u, 0)), 0) ==
        format::float_to_half_bits(1.0009765625f));
  // The helper under half2_fma breaks a double tie by the sum's exact error: 1 + 2^-11 is halfway between 1
  // (0x3c00) and 1 + 2^-10 (0x3c01); a tiny term on either side decides, and a sum a double-ulp past the
  // halfway point rounds up whatever its error's sign.
  const double halfway = 1.0 + std::ldexp(1.0, -11);
  CHECK(k::detail::half_bits_of_sum(halfway, 0.0) == 0x3c00u);  // an exact tie: to even
  CHECK(k::detail::half_bits_of_sum(halfway, std::ldexp(1.0, -80)) == 0x3c01u);
  CHECK(k::detail::half_bits_of_sum(halfway, -std::ldexp(1.0, -80)) == 0x3c00u);
  CHECK(k::detail::half_bits_of_sum(halfway + std::ldexp(1.0, -52), -std::ldexp(1.0, -60)) == 0x3c01u);
}

TEST_CASE("half emulation: half2_min follows __hmin2 on NaN and signed zeros") {
  const uint16_t nan = 0x7e00u, one = 0x3c00u, minus_two = 0xc000u, plus_zero = 0x0000u, minus_zero = 0x8000u;
  CHECK(k::half2_min(pair(nan, one), pair(one, nan)) == pair(one, one));
  CHECK(lane(k::half2_min(pair(nan, 0), pair(nan, 0)), 0) == 0x7fffu);
  CHECK(k::half2_min(pair(plus_zero, minus_zero), pair(minus_zero, plus_zero)) == pair(minus_zero, minus_zero));
  CHECK(k::half2_min(pair(one, minus_two), pair(minus_two, one)) == pair(minus_two, minus_two));
  CHECK(k::half2_min(pair(0x7c00u, 0x3bd1u), pair(0x3bd1u, 0x7c00u)) == pair(0x3bd1u, 0x3bd1u));  // inf
}

TEST_CASE("half2_alpha: within its stated error of 2^v, and its clamp and skip rules") {
  // Dense over v in [log2(1/255), log2(0.99)]: α = 2^v rounded to the nearest binary16, against 2^v.
  const double lowest = std::log2(1.0 / 255), highest = std::log2(0.99);
  double worst = 0, sum = 0;
  int count = 0;
  for (int i = 0; i <= 400000; ++i) {
    const float v = float(lowest + (highest - lowest) * i / 400000.0);
    const double exact = std::exp2(double(v));
    if (exact < 1.0 / 255 * 1.003 || exact > 0.99) continue;  // clear of the 1/255 skip and the 0.99 clamp
    const k::Half2Bits alpha = k::half2_alpha(v, v);
    REQUIRE(lane(alpha, 0) == lane(alpha, 1));
    REQUIRE(is_nearest_even(lane(alpha, 0), static_cast<Exact>(exact)));
    const double relative = k::detail::half_bits_to_double(lane(alpha, 0)) / exact - 1.0;
    worst = std::max(worst, std::fabs(relative));
    sum += relative;
    ++count;
  }
  MESSAGE(count << " powers: max relative error " << worst << ", mean " << sum / count);
  CHECK(count > 390000);
  CHECK(worst <= std::ldexp(1.0, -11));  // half a unit of binary16's 11 bits, relative
  CHECK(worst < k::kHalfAlphaMaxRelativeError);
  CHECK(worst > 0.0004);                  // binary16: not exact
  CHECK(std::fabs(sum / count) < 1e-5);   // rounding to nearest: no bias
  // The folded powers in base 2: exp2_coefficients scales every coefficient by log2 e.
  const k::FoldedCoefficients f{-0.5f, 0.1f, -0.25f, 0.5f, -1.f, -0.75f};
  const k::FoldedCoefficients g = k::exp2_coefficients(f);
  CHECK(g.c1 == f.c1 * k::kLog2e);
  CHECK(g.c6 == f.c6 * k::kLog2e);

  const uint16_t alpha_max = lane(k::kHalf2AlphaMax, 0);
  CHECK(alpha_max == format::float_to_half_bits(k::kAlphaMax));  // 0.99 to the nearest binary16
  // In range: per lane.
  CHECK(lane(k::half2_alpha(-1.f, -100.f), 0) == 0x3800u);  // 2^−1 exactly
  CHECK(lane(k::half2_alpha(-1.f, -100.f), 1) == 0);
  // Below 1/255 (v < log2(1/255) ≈ −7.99) and far below: skipped; the padding record's −1e30 is −inf.
  CHECK(k::half2_alpha(-8.1f, -30.f) == 0);
  CHECK(k::half2_alpha(-1e30f, -INFINITY) == 0);
  // v = 0 and v > 0 (a folded power only by rounding) clamp to 0.990234; a NaN power is skipped.
  CHECK(k::half2_alpha(0.f, 1e-3f) == k::kHalf2AlphaMax);
  CHECK(k::half2_alpha(20.f, INFINITY) == k::kHalf2AlphaMax);
  CHECK(k::half2_alpha(std::nanf(""), -1.f) == pair(0, 0x3800u));
  // half2_pack rounds to nearest, first pixel low; half2_low / half2_high broadcast one half.
  CHECK(k::half2_pack(1.f + 1.f / 2048, -2.f) == pair(0x3c00u, 0xc000u));  // a tie: to even
  CHECK(k::half2_low(pair(0x3c00u, 0xc000u)) == pair(0x3c00u, 0x3c00u));
  CHECK(k::half2_high(pair(0x3c00u, 0xc000u)) == pair(0xc000u, 0xc000u));
}

TEST_CASE("blend_half2: a skipped pair changes no bit, a done pixel stays done, a step rounds as stated") {
  const uint16_t half_alpha = format::float_to_half_bits(0.3f), red = format::float_to_half_bits(0.8f);
  k::HalfPixelPair live;
  live.r = pair(format::float_to_half_bits(0.25f), format::float_to_half_bits(0.5f));
  live.T = pair(format::float_to_half_bits(0.6f), format::float_to_half_bits(0.7f));
  k::HalfPixelPair done = live;
  done.T |= k::kHalf2Signs;

  // α = +0 in both lanes (skipped): no bit changes, live or done, and the taken weights are 0.
  for (const k::HalfPixelPair& start : {live, done}) {
    k::HalfPixelPair s = start;
    CHECK(k::blend_half2(s, 0u, pair(red, red), 0u, 0u) == 0u);
    CHECK(s.T == start.T);
    CHECK(s.r == start.r);
  }
  // A done pixel with α > 0: unchanged.
  k::HalfPixelPair d = done;
  CHECK(k::blend_half2(d, pair(half_alpha, half_alpha), pair(red, red), 0u, 0u) == 0u);
  CHECK(d.T == done.T);
  CHECK(d.r == done.r);
  CHECK_FALSE(k::half_pair_live(d));

  // A live step: w = α·T, T' = T − w, C' = c·w + C, each one binary16 rounding of the exact value.
  k::HalfPixelPair s = live;
  const k::Half2Bits w = k::blend_half2(s, pair(half_alpha, half_alpha), pair(red, red), 0u, 0u);
  for (int l = 0; l < 2; ++l) {
    const double T = k::detail::half_bits_to_double(lane(live.T, l));
    const double alpha = k::detail::half_bits_to_double(half_alpha);
    const uint16_t w_expected = k::detail::half_bits_from_double(alpha * T);
    const double wd = k::detail::half_bits_to_double(w_expected);
    CHECK(lane(w, l) == w_expected);
    CHECK(lane(s.T, l) == k::detail::half_bits_from_double(T - wd));
    CHECK(lane(s.r, l) == k::detail::half_bits_from_double(k::detail::half_bits_to_double(red) * wd +
                                                          k::detail::half_bits_to_double(lane(live.r, l))));
  }
  // The stop rule: a step that would take T below 1e-4 (binary16 1.00017e-4) leaves C and marks the pixel done
  // with −T; the other pixel goes on.
  k::HalfPixelPair near;
  near.T = pair(format::float_to_half_bits(2e-4f), format::float_to_half_bits(0.5f));
  const uint16_t big_alpha = format::float_to_half_bits(0.9f);
  const k::Half2Bits taken = k::blend_half2(near, pair(big_alpha, big_alpha), pair(red, red), 0u, 0u);
  CHECK(lane(taken, 0) == 0);
  CHECK(lane(near.T, 0) == (format::float_to_half_bits(2e-4f) | 0x8000u));
  CHECK(lane(near.r, 0) == 0);
  CHECK(lane(taken, 1) != 0);
  CHECK(k::half_pair_live(near));
}

TEST_CASE("colour windows: a binary16 sum drops late contributions, windows closed into FP32 keep them") {
  // A pixel behind an opaque-ish front: one Gaussian of α 0.6, then 200 faint ones of α 0.004, every colour
  // 0.9. Each faint weight is 0.004·T (T ≥ 0.17 after 200 of them), so each adds c·w ≈ 1.4e-3..3.6e-4 to a
  // colour sum near 0.54..0.75, whose binary16 half unit is 2^−12 ≈ 2.4e-4 there: summed in one window, the
  // roundings of 200 such additions pile up; in windows of kColourWindowEntries they do not. The exact colour
  // sums the same binary16 weights in double.
  const uint16_t colour = format::float_to_half_bits(0.9f);
  const auto run = [&](int window) {
    k::HalfPixelPair s;
    double exact = 0;
    for (int i = 0; i < 201; ++i) {
      const uint16_t alpha = format::float_to_half_bits(i == 0 ? 0.6f : 0.004f);
      const k::Half2Bits w = k::blend_half2(s, pair(alpha, alpha), pair(colour, colour), 0u, 0u);
      exact += k::detail::half_bits_to_double(colour) * k::detail::half_bits_to_double(lane(w, 0));
      if ((i + 1) % window == 0) k::close_colour_window(s);
    }
    return std::pair<double, double>(k::half_pixel_colour(s, 0, 0), exact);
  };
  const auto [single, exact_single] = run(1 << 30);  // one window: the plain binary16 sum
  const auto [windowed, exact_windowed] = run(k::kColourWindowEntries);
  CHECK(exact_single == exact_windowed);  // the weights do not depend on the windows
  MESSAGE("one window: " << single << ", windows of " << k::kColourWindowEntries << ": " << windowed
                         << ", exact " << exact_windowed);
  // Deterministic arithmetic: one window is off by 2.09e-3, more than half an 8-bit level (0.5 / 255); the
  // windows by 1.0e-4.
  CHECK(std::abs(single - exact_single) > 0.5 / 255);
  CHECK(std::abs(windowed - exact_windowed) < 2e-4);
  // Closing a window is exact bookkeeping: the pixel's colour does not change at the close itself.
  k::HalfPixelPair s;
  s.r = pair(format::float_to_half_bits(0.3f), format::float_to_half_bits(0.7f));
  s.C[0][0] = 0.125f, s.C[1][0] = 0.25f;
  const float before[2] = {k::half_pixel_colour(s, 0, 0), k::half_pixel_colour(s, 1, 0)};
  k::close_colour_window(s);
  CHECK(s.r == 0u);
  CHECK(k::half_pixel_colour(s, 0, 0) == before[0]);
  CHECK(k::half_pixel_colour(s, 1, 0) == before[1]);
}

}  // namespace
}  // namespace rgs::test
