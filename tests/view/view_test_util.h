// Helpers shared by the viewer suite's tests.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include <doctest/doctest.h>
#include <turbojpeg.h>
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

/// A JPEG of `w` × `h` decoded by libjpeg-turbo to [h, w, 3] uint8 RGB; fails the test when it does not decode.
inline std::vector<uint8_t> decode_jpeg(const std::vector<uint8_t>& jpeg, uint32_t w, uint32_t h) {
  tjhandle d = tjInitDecompress();
  std::vector<uint8_t> out(size_t(w) * h * 3);
  const int r = tjDecompress2(d, jpeg.data(), jpeg.size(), out.data(), int(w), int(w) * 3, int(h), TJPF_RGB, 0);
  const std::string error = r == 0 ? "" : tjGetErrorStr2(d);
  tjDestroy(d);
  REQUIRE_MESSAGE(r == 0, error);
  return out;
}

}  // namespace rgs::test
