// half.h against an independent exact reference: every binary16 value, every rounding boundary, and
// the compiler's own _Float16 conversion where available.
#include <doctest/doctest.h>

#include <cfloat>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <ios>
#include <random>

#include "rgs/format/half.h"

namespace {

using rgs::format::float_to_half_bits;
using rgs::format::half_bits_to_float;

uint32_t bits_of(float f) {
  uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}
float float_of(uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}

/// Value of a binary16 from its fields (IEEE 754-2008 §3.4), computed in double.
double reference_half_value(uint16_t h) {
  const int sign = h >> 15, exponent = (h >> 10) & 0x1f, mantissa = h & 0x3ff;
  double v;
  if (exponent == 0x1f) {
    v = mantissa ? NAN : INFINITY;
  } else if (exponent == 0) {
    v = std::ldexp(mantissa, -24);
  } else {
    v = std::ldexp(1024 + mantissa, exponent - 25);
  }
  return sign ? -v : v;
}

/// Round-to-nearest-even float -> binary16 done with exact double arithmetic: scale to units of the
/// target ulp (a power of two, so exact), round with nearbyint (ties to even), rebuild the bits.
uint16_t reference_float_to_half(float f) {
  const uint16_t sign = std::signbit(f) ? 0x8000 : 0;
  if (std::isnan(f)) return static_cast<uint16_t>(sign | 0x7e00);
  const double a = std::fabs(static_cast<double>(f));
  if (a >= 65520.0) return static_cast<uint16_t>(sign | 0x7c00);  // halfway to 2^16 and beyond: inf
  if (a < std::ldexp(1.0, -14)) {
    const double q = std::nearbyint(a * std::ldexp(1.0, 24));  // units of 2^-24; 1024 is the first normal
    return static_cast<uint16_t>(sign | static_cast<uint16_t>(q));
  }
  int e2 = 0;
  (void)std::frexp(a, &e2);  // a = m * 2^e2, m in [0.5, 1): a in [2^(e2-1), 2^e2)
  const int e = e2 - 1;
  const double q = std::nearbyint(std::ldexp(a, 10 - e));  // in [1024, 2048]
  const uint32_t bits = (static_cast<uint32_t>(e + 15) << 10) + static_cast<uint32_t>(q) - 1024;  // 2048 carries
  return static_cast<uint16_t>(sign | bits);
}

void check_float(float f) {
  const uint16_t got = float_to_half_bits(f);
  const uint16_t want = reference_float_to_half(f);
  if (got != want) {
    // One message per failure, with the bits that matter.
    FAIL_CHECK("float 0x" << std::hex << bits_of(f) << " (" << f << "): got half 0x" << got << ", want 0x" << want);
  }
}

}  // namespace

TEST_CASE("half: every binary16 value widens exactly and narrows back to itself") {
  int nans = 0;
  for (uint32_t h = 0; h <= 0xffff; ++h) {
    const auto bits = static_cast<uint16_t>(h);
    const float f = half_bits_to_float(bits);
    const double want = reference_half_value(bits);
    if (std::isnan(want)) {
      ++nans;
      REQUIRE(std::isnan(f));
      const uint16_t back = float_to_half_bits(f);
      // NaN stays NaN with its sign; the payload becomes the canonical quiet one.
      CHECK(((back & 0x7c00) == 0x7c00 && (back & 0x3ff) != 0));
      CHECK((back & 0x8000) == (bits & 0x8000));
      continue;
    }
    REQUIRE(static_cast<double>(f) == want);
    REQUIRE(std::signbit(f) == ((bits & 0x8000) != 0));
    REQUIRE(float_to_half_bits(f) == bits);
  }
  CHECK(nans == 2 * 1023);
}

TEST_CASE("half: float -> half rounds to nearest even at every half-way point") {
  // For each pair of adjacent finite halves, probe the midpoint (exact in float: 12 significant bits)
  // and its float neighbours, for both signs; plus each half value and its neighbours.
  for (uint32_t h = 0; h < 0x7c00; ++h) {
    const float lo = half_bits_to_float(static_cast<uint16_t>(h));
    const double hi = h + 1 < 0x7c00 ? reference_half_value(static_cast<uint16_t>(h + 1)) : 65536.0;
    const auto mid = static_cast<float>((static_cast<double>(lo) + hi) / 2);
    REQUIRE(static_cast<double>(mid) == (static_cast<double>(lo) + hi) / 2);
    for (float f : {lo, std::nextafter(lo, INFINITY), std::nextafter(lo, -INFINITY), mid,
                    std::nextafter(mid, INFINITY), std::nextafter(mid, -INFINITY)}) {
      check_float(f);
      check_float(-f);
    }
  }
}

TEST_CASE("half: hand-checked cases") {
  CHECK(float_to_half_bits(0.0f) == 0x0000);
  CHECK(float_to_half_bits(-0.0f) == 0x8000);
  CHECK(float_to_half_bits(1.0f) == 0x3c00);
  CHECK(float_to_half_bits(-2.0f) == 0xc000);
  CHECK(float_to_half_bits(65504.0f) == 0x7bff);               // largest finite half
  CHECK(float_to_half_bits(65519.99609375f) == 0x7bff);        // just below the half-way point
  CHECK(float_to_half_bits(65520.0f) == 0x7c00);               // tie between 65504 and 2^16: even = inf
  CHECK(float_to_half_bits(1e6f) == 0x7c00);
  CHECK(float_to_half_bits(-1e6f) == 0xfc00);
  CHECK(float_to_half_bits(INFINITY) == 0x7c00);
  CHECK(float_to_half_bits(-INFINITY) == 0xfc00);
  const uint16_t nan = float_to_half_bits(NAN);
  CHECK((nan & 0x7c00) == 0x7c00);
  CHECK((nan & 0x03ff) != 0);
  CHECK(std::isnan(half_bits_to_float(nan)));
  CHECK(float_to_half_bits(std::ldexp(1.0f, -14)) == 0x0400);  // smallest normal
  CHECK(float_to_half_bits(std::ldexp(1.0f, -24)) == 0x0001);  // smallest subnormal
  CHECK(float_to_half_bits(std::ldexp(1.0f, -25)) == 0x0000);  // tie between 0 and 2^-24: even = 0
  CHECK(float_to_half_bits(std::nextafter(std::ldexp(1.0f, -25), 1.0f)) == 0x0001);
  CHECK(float_to_half_bits(3 * std::ldexp(1.0f, -25)) == 0x0002);  // tie between 1 and 2 ulps: even = 2
  CHECK(float_to_half_bits(std::ldexp(1.0f, -14) - std::ldexp(1.0f, -25)) == 0x0400);  // tie: 0x3ff/0x400
  CHECK(float_to_half_bits(1.0f + std::ldexp(1.0f, -11)) == 0x3c00);      // tie: even mantissa 0
  CHECK(float_to_half_bits(1.0f + 3 * std::ldexp(1.0f, -11)) == 0x3c02);  // tie: even mantissa 2
  CHECK(float_to_half_bits(1.0f + std::ldexp(1.0f, -10)) == 0x3c01);
  CHECK(float_to_half_bits(FLT_MIN) == 0x0000);
  CHECK(float_to_half_bits(-FLT_MIN) == 0x8000);
  CHECK(half_bits_to_float(0x7bff) == 65504.0f);
  CHECK(half_bits_to_float(0x0001) == std::ldexp(1.0f, -24));
  CHECK(half_bits_to_float(0x03ff) == std::ldexp(1023.0f, -24));
  CHECK(half_bits_to_float(0xfc00) == -INFINITY);
}

TEST_CASE("half: random float bit patterns match the reference") {
  std::mt19937 rng(12345);
  for (int i = 0; i < 2000000; ++i) check_float(float_of(static_cast<uint32_t>(rng())));
  // Concentrate on the half range, where all the rounding happens.
  std::uniform_int_distribution<uint32_t> in_range(0x33000000u - 0x100000u, 0x47800000u + 0x100000u);
  for (int i = 0; i < 2000000; ++i) {
    const uint32_t u = in_range(rng) | (rng() & 1u ? 0x80000000u : 0u);
    check_float(float_of(u));
  }
}

#if defined(__FLT16_MAX__)
TEST_CASE("half: agrees with the compiler's _Float16 conversion") {
  // An implementation written by others (libgcc or F16C), so both ours and the reference are checked.
  std::mt19937 rng(777);
  for (int i = 0; i < 4000000; ++i) {
    const float f = float_of(static_cast<uint32_t>(rng()));
    if (std::isnan(f)) continue;
    const auto h = static_cast<_Float16>(f);
    uint16_t want;
    std::memcpy(&want, &h, 2);
    REQUIRE(float_to_half_bits(f) == want);
  }
}
#endif
