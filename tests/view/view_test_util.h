// Helpers shared by the viewer suite's tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include <doctest/doctest.h>
#include <webp/decode.h>

namespace rgs::test {

/// A WebP file decoded by libwebp to [h, w, 3] uint8 RGB (its size in *w, *h); fails the test when it does not decode.
inline std::vector<uint8_t> decode_webp(const std::vector<uint8_t>& bytes, int* w, int* h) {
  uint8_t* out = WebPDecodeRGB(bytes.data(), bytes.size(), w, h);
  REQUIRE(out != nullptr);
  std::vector<uint8_t> rgb(out, out + size_t(*w) * size_t(*h) * 3);
  WebPFree(out);
  return rgb;
}

}  // namespace rgs::test
