// SPZ constants and per-value codecs shared by the reader and the writer (private to rgs_converter).
// Learned from the nianticlabs/spz README and src/cc (load-spz.cc, splat-utils.h); converter/INTEROP.md.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <string>

#include "rgs/format/little_endian.h"

namespace rgs::converter::detail {

constexpr uint32_t kSpzMagic = 0x5053474eu;  // "NGSP" in file order
constexpr size_t kSpzV4HeaderBytes = 32;
constexpr size_t kSpzLegacyHeaderBytes = 16;
constexpr uint8_t kSpzFlagAntialiased = 0x1;
constexpr uint8_t kSpzFlagExtensions = 0x2;
/// SPZ_ADOBE_coordinate_system: payload u32, 1..8 = LDB RDB LUB RUB LDF RDF LUF RUF, 9..16 rotated.
constexpr uint32_t kSpzExtCoordinateSystem = 0xADBE0003u;
/// Positions are 24-bit signed integers; more fractional bits than 23 leave no integer part at all.
constexpr uint32_t kSpzMaxFractionalBits = 23;
/// DC colour scale of SPZ: c = f_dc · 0.15 · 255 + 127.5 (not the SH constant 0.282, leaving headroom).
constexpr float kSpzColorScale = 0.15f;

/// Attribute arrays in file order (both containers).
enum SpzStream : int { kSpzPositions, kSpzAlphas, kSpzColors, kSpzScales, kSpzRotations, kSpzSh, kSpzStreamCount };
inline constexpr const char* kSpzStreamNames[kSpzStreamCount] = {"positions", "alphas",    "colors",
                                                                  "scales",    "rotations", "sh"};

/// SH rest bytes per Gaussian: ((degree + 1)² − 1) coefficients × 3 channels.
constexpr uint64_t spz_sh_bytes(uint32_t degree) { return (uint64_t{degree + 1} * (degree + 1) - 1) * 3; }

/// Three-letter name of SPZ coordinate-system value 1..8 (bit 0: R, bit 1: U, bit 2: F, of value − 1).
inline std::string spz_frame_name(uint32_t value) {
  const uint32_t b = value - 1;
  std::string s;
  s += (b & 1) ? 'R' : 'L';
  s += (b & 2) ? 'U' : 'D';
  s += (b & 4) ? 'F' : 'B';
  return s;
}

inline std::string hex32(uint32_t v) {
  char s[9];
  std::snprintf(s, sizeof(s), "%08X", static_cast<unsigned>(v));
  return s;
}

// ---- decoding -------------------------------------------------------------------------------------

inline float spz_decode_position(const uint8_t* p, int fractional_bits) {
  int32_t v = static_cast<int32_t>(p[0] | (p[1] << 8) | (p[2] << 16));
  if (v & 0x800000) v -= 0x1000000;  // sign of the 24-bit value
  return std::ldexp(static_cast<float>(v), -fractional_bits);
}
inline float spz_decode_alpha(uint8_t a) { return static_cast<float>(a) / 255.0f; }
inline float spz_decode_color(uint8_t c) { return (static_cast<float>(c) / 255.0f - 0.5f) / kSpzColorScale; }
inline float spz_decode_scale(uint8_t b) {
  return static_cast<float>(std::exp(static_cast<double>(b) / 16.0 - 10.0));
}
inline float spz_decode_sh(uint8_t b) { return (static_cast<float>(b) - 128.0f) / 128.0f; }

/// Version 2: x, y, z as b/127.5 − 1, w = sqrt(max(0, 1 − |xyz|²)). Output (x, y, z, w).
inline void spz_decode_first_three(const uint8_t* r, float xyzw[4]) {
  double n2 = 0;
  for (int a = 0; a < 3; ++a) {
    xyzw[a] = static_cast<float>(r[a]) / 127.5f - 1.0f;
    n2 += static_cast<double>(xyzw[a]) * xyzw[a];
  }
  xyzw[3] = static_cast<float>(std::sqrt(std::max(0.0, 1.0 - n2)));
}

/// Versions 3+: a little-endian u32; bits 31..30 index the largest component of (x, y, z, w), which is
/// non-negative and implied by unit norm; the other three follow in ascending index order from bit 29
/// down, each 10 bits: sign (bit 9) and magnitude m (9 bits) with |q_i| = m/511 · sqrt(1/2).
inline void spz_decode_smallest_three(const uint8_t* r, float xyzw[4]) {
  uint32_t comp = format::load_u32_le(r);
  const int largest = static_cast<int>(comp >> 30);
  double sum = 0;
  for (int i = 3; i >= 0; --i) {
    if (i == largest) continue;
    const uint32_t mag = comp & 511u;
    const bool negative = (comp >> 9) & 1u;
    comp >>= 10;
    const double v = 0.70710678118654752440 * static_cast<double>(mag) / 511.0;
    xyzw[i] = static_cast<float>(negative ? -v : v);
    sum += v * v;
  }
  xyzw[largest] = static_cast<float>(std::sqrt(std::max(0.0, 1.0 - sum)));
}

// ---- encoding -------------------------------------------------------------------------------------

inline uint8_t spz_clamp_byte(double v, bool* clamped) {
  const double r = std::round(v);  // half away from zero, as the spz library rounds
  if (r < 0 || r > 255) {
    *clamped = true;
    return r < 0 ? 0 : 255;
  }
  return static_cast<uint8_t>(r);
}

}  // namespace rgs::converter::detail
