// Little-endian scalar loads and stores and overflow-checked size arithmetic: the format's byte order, shared by
// the .rgs reader and writer and the converter's readers and writers of other formats.
#pragma once

#include <cstdint>
#include <cstring>

namespace rgs::format {

/// a + b into *out; false (and *out untouched) when the sum does not fit in 64 bits.
[[nodiscard]] inline bool checked_add(uint64_t a, uint64_t b, uint64_t* out) {
  if (a > UINT64_MAX - b) return false;
  *out = a + b;
  return true;
}

/// a * b into *out; false (and *out untouched) when the product does not fit in 64 bits.
[[nodiscard]] inline bool checked_mul(uint64_t a, uint64_t b, uint64_t* out) {
  if (a != 0 && b > UINT64_MAX / a) return false;
  *out = a * b;
  return true;
}

/// The unsigned integer or float32 (its IEEE 754 bits) stored little-endian at `p`.
inline uint16_t load_u16_le(const uint8_t* p) { return static_cast<uint16_t>(p[0] | (p[1] << 8)); }
inline uint32_t load_u32_le(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) | (static_cast<uint32_t>(p[1]) << 8) |
         (static_cast<uint32_t>(p[2]) << 16) | (static_cast<uint32_t>(p[3]) << 24);
}
inline uint64_t load_u64_le(const uint8_t* p) {
  return static_cast<uint64_t>(load_u32_le(p)) | (static_cast<uint64_t>(load_u32_le(p + 4)) << 32);
}
inline float load_f32_le(const uint8_t* p) {
  const uint32_t bits = load_u32_le(p);
  float f;
  std::memcpy(&f, &bits, 4);  // a scalar bit cast, not a struct copy
  return f;
}
/// Stores `v` little-endian at `p` (a float32 as its IEEE 754 bits).
inline void store_u16_le(uint8_t* p, uint16_t v) {
  for (int i = 0; i < 2; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void store_u32_le(uint8_t* p, uint32_t v) {
  for (int i = 0; i < 4; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void store_u64_le(uint8_t* p, uint64_t v) {
  for (int i = 0; i < 8; ++i) p[i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void store_f32_le(uint8_t* p, float v) {
  uint32_t bits;
  std::memcpy(&bits, &v, 4);
  store_u32_le(p, bits);
}

}  // namespace rgs::format
