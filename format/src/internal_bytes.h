// Bounds-checked little-endian field I/O and overflow-safe size arithmetic (CONTRIBUTING.md#format-changes). Every .rgs
// field goes through ByteReader/ByteWriter one scalar at a time; no struct is ever copied as bytes.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <string>

#include "rgs/format/little_endian.h"

namespace rgs::format::detail {

#if defined(__BYTE_ORDER__) && defined(__ORDER_BIG_ENDIAN__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
inline constexpr bool kHostLittleEndian = false;
#else
inline constexpr bool kHostLittleEndian = true;
#endif

/// Smallest multiple of `alignment` (a power of two) that is >= value; false on overflow.
[[nodiscard]] inline bool checked_align_up(uint64_t value, uint64_t alignment, uint64_t* out) {
  uint64_t sum = 0;
  if (!checked_add(value, alignment - 1, &sum)) return false;
  *out = sum & ~(alignment - 1);
  return true;
}

/// Reads little-endian scalars from a byte range. A read past the end returns false, leaves the
/// output untouched and does not move the position.
class ByteReader {
 public:
  ByteReader(const uint8_t* data, size_t size) : data_(data), size_(size) {}

  size_t remaining() const { return size_ - pos_; }

  [[nodiscard]] bool read_u8(uint8_t* out) { return read_with(1, out, [](const uint8_t* p) { return *p; }); }
  [[nodiscard]] bool read_u16(uint16_t* out) { return read_with(2, out, load_u16_le); }
  [[nodiscard]] bool read_u32(uint32_t* out) { return read_with(4, out, load_u32_le); }
  [[nodiscard]] bool read_u64(uint64_t* out) { return read_with(8, out, load_u64_le); }
  [[nodiscard]] bool read_f32(float* out) { return read_with(4, out, load_f32_le); }
  /// Points *out at the next n bytes (no copy) and advances past them.
  [[nodiscard]] bool read_view(size_t n, const uint8_t** out) {
    if (remaining() < n) return false;
    *out = data_ + pos_;
    pos_ += n;
    return true;
  }
  [[nodiscard]] bool skip(size_t n) {
    if (remaining() < n) return false;
    pos_ += n;
    return true;
  }

 private:
  template <typename T, typename Load>
  bool read_with(size_t n, T* out, Load load) {
    if (remaining() < n) return false;
    *out = load(data_ + pos_);
    pos_ += n;
    return true;
  }

  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

/// Writes little-endian scalars into a caller-sized byte range. A write past the end is dropped (the writer
/// sizes its buffers exactly: the golden files catch a layout that does not fit).
class ByteWriter {
 public:
  ByteWriter(uint8_t* data, size_t size) : data_(data), size_(size) {}

  void put_u8(uint8_t v) { put_bytes(&v, 1); }
  void put_u16(uint16_t v) { put_with(2, v, store_u16_le); }
  void put_u32(uint32_t v) { put_with(4, v, store_u32_le); }
  void put_u64(uint64_t v) { put_with(8, v, store_u64_le); }
  void put_f32(float v) { put_with(4, v, store_f32_le); }
  void put_zeros(size_t n) {
    if (uint8_t* p = claim(n)) std::memset(p, 0, n);
  }
  void put_bytes(const void* src, size_t n) {
    if (n == 0) return;
    if (uint8_t* p = claim(n)) std::memcpy(p, src, n);
  }

 private:
  template <typename T, typename Store>
  void put_with(size_t n, T v, Store store) {
    if (uint8_t* p = claim(n)) store(p, v);
  }
  uint8_t* claim(size_t n) {
    if (size_ - pos_ < n) return nullptr;
    uint8_t* p = data_ + pos_;
    pos_ += n;
    return p;
  }

  uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

/// "0x" followed by 16 lowercase hex digits, for checksums in messages.
inline std::string hex64(uint64_t v) {
  static const char kDigits[] = "0123456789abcdef";
  std::string s = "0x";
  for (int shift = 60; shift >= 0; shift -= 4) s += kDigits[(v >> shift) & 0xf];
  return s;
}

/// "0x" followed by 8 lowercase hex digits, for flags and 32-bit magics in messages.
inline std::string hex32(uint32_t v) { return "0x" + hex64(v).substr(10); }

/// Decimal string of an unsigned 64-bit value.
inline std::string dec(uint64_t v) { return std::to_string(v); }

/// A value in messages, to float32's 9 significant digits.
inline std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

}  // namespace rgs::format::detail
