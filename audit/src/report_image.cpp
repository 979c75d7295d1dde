#include "internal_report_image.h"

#include <zlib.h>

#include <algorithm>
#include <cstdlib>
#include <vector>

namespace rgs::audit::detail {

namespace {

// matplotlib's _cm_listed.py, inferno (CC0, Nathaniel J. Smith, Stefan van der Walt), 8-bit RGB.
constexpr const char kInfernoHex[] =
    "00000401000501010601010802010a02020c02020e03021004031204031405041706041907051b08051d09061f0a07220b07240c0826"
    "0d08290e092b10092d110a30120a32140b34150b37160b39180c3c190c3e1b0c411c0c431e0c451f0c48210c4a230c4c240c4f260c51"
    "280b53290b552b0b572d0b592f0a5b310a5c320a5e340a5f3609613809623909633b09643d09653e0966400a67420a68440a68450a69"
    "470b6a490b6a4a0c6b4c0c6b4d0d6c4f0d6c510e6c520e6d540f6d550f6d57106e59106e5a116e5c126e5d126e5f136e61136e62146e"
    "64156e65156e67166e69166e6a176e6c186e6d186e6f196e71196e721a6e741a6e751b6e771c6d781c6d7a1d6d7c1d6d7d1e6d7f1e6c"
    "801f6c82206c84206b85216b87216b88226a8a226a8c23698d23698f24699025689225689326679526679727669827669a28659b2964"
    "9d29649f2a63a02a63a22b62a32c61a52c60a62d60a82e5fa92e5eab2f5ead305dae305cb0315bb1325ab3325ab43359b63458b73557"
    "b93556ba3655bc3754bd3853bf3952c03a51c13a50c33b4fc43c4ec63d4dc73e4cc83f4bca404acb4149cc4248ce4347cf4446d04545"
    "d24644d34743d44842d54a41d74b3fd84c3ed94d3dda4e3cdb503bdd513ade5238df5337e05536e15635e25734e35933e45a31e55c30"
    "e65d2fe75e2ee8602de9612bea632aeb6429eb6628ec6726ed6925ee6a24ef6c23ef6e21f06f20f1711ff1731df2741cf3761bf37819"
    "f47918f57b17f57d15f67e14f68013f78212f78410f8850ff8870ef8890cf98b0bf98c0af98e09fa9008fa9207fa9407fb9606fb9706"
    "fb9906fb9b06fb9d07fc9f07fca108fca309fca50afca60cfca80dfcaa0ffcac11fcae12fcb014fcb216fcb418fbb61afbb81dfbba1f"
    "fbbc21fbbe23fac026fac228fac42afac62df9c72ff9c932f9cb35f8cd37f8cf3af7d13df7d340f6d543f6d746f5d949f5db4cf4dd4f"
    "f4df53f4e156f3e35af3e55df2e661f2e865f2ea69f1ec6df1ed71f1ef75f1f179f2f27df2f482f3f586f3f68af4f88ef5f992f6fa96"
    "f8fb9af9fc9dfafda1fcffa4";

int hex_digit(char c) { return c <= '9' ? c - '0' : c - 'a' + 10; }

void put_u32(std::string& out, uint32_t v) {
  for (int shift = 24; shift >= 0; shift -= 8) out.push_back(char((v >> shift) & 0xFF));
}

void put_chunk(std::string& png, const char* type, const std::string& data) {
  put_u32(png, uint32_t(data.size()));
  const std::string body = std::string(type, 4) + data;
  png += body;
  put_u32(png, uint32_t(crc32(crc32(0L, Z_NULL, 0), reinterpret_cast<const Bytef*>(body.data()), uInt(body.size()))));
}

std::string base64(const std::string& bytes) {
  static const char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const size_t n = std::min<size_t>(3, bytes.size() - i);
    uint32_t v = 0;
    for (size_t k = 0; k < 3; ++k) v = v << 8 | (k < n ? uint8_t(bytes[i + k]) : 0u);
    for (size_t k = 0; k < 4; ++k) out.push_back(k <= n ? kAlphabet[(v >> (18 - 6 * k)) & 63] : '=');
  }
  return out;
}

int paeth(int a, int b, int c) {
  const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  return pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
}

/// Writes `row` (`stride` bytes, `bpp` per pixel; `up` the row above it, nullptr for the first) into `out` as its
/// filter type byte and filtered bytes: of None, Sub, Up, Average and Paeth (PNG specification §6.2), the one whose
/// bytes read as signed have the smallest sum of magnitudes, the specification's heuristic for deflate.
void filter_row(const uint8_t* row, const uint8_t* up, size_t stride, size_t bpp, uint8_t* out) {
  std::vector<uint8_t> filtered[5];
  long best_cost = -1;
  for (int f = 0; f < 5; ++f) {
    filtered[f].resize(stride);
    long cost = 0;
    for (size_t i = 0; i < stride; ++i) {
      const int a = i >= bpp ? row[i - bpp] : 0, b = up ? up[i] : 0, cc = up && i >= bpp ? up[i - bpp] : 0;
      const int predicted = f == 0 ? 0 : f == 1 ? a : f == 2 ? b : f == 3 ? (a + b) / 2 : paeth(a, b, cc);
      filtered[f][i] = uint8_t(row[i] - predicted);
      cost += std::abs(int(int8_t(filtered[f][i])));
    }
    if (best_cost < 0 || cost < best_cost) {
      best_cost = cost;
      out[0] = uint8_t(f);
    }
  }
  std::copy(filtered[out[0]].begin(), filtered[out[0]].end(), out + 1);
}

}  // namespace

std::array<uint8_t, 3> inferno(uint8_t level) {
  const char* p = kInfernoHex + 6 * size_t(level);
  std::array<uint8_t, 3> rgb{};
  for (int c = 0; c < 3; ++c) rgb[c] = uint8_t(hex_digit(p[2 * c]) * 16 + hex_digit(p[2 * c + 1]));
  return rgb;
}

Result<std::string> png_data_uri(const Image8& image, bool heat) {
  const size_t w = image.width, h = image.height, c = image.channels;
  RGS_RETURN_ERROR_IF(c != 1 && c != 3, StatusCode::kInvalidArgument,
                      "report image: 1 or 3 channels, not " + std::to_string(c));
  RGS_RETURN_ERROR_IF(w == 0 || h == 0 || image.pixels.size() != w * h * c, StatusCode::kInvalidArgument,
                      "report image: " + std::to_string(image.pixels.size()) + " bytes for " + std::to_string(w) +
                          "x" + std::to_string(h) + "x" + std::to_string(c));
  const size_t out_c = heat && c == 1 ? 3 : c, stride = w * out_c;
  std::vector<uint8_t> pixels(stride * h);  // as stored: the heatmaps coloured
  for (size_t i = 0; i < w * h; ++i) {
    const std::array<uint8_t, 3> heat_rgb = out_c != c ? inferno(image.pixels[i]) : std::array<uint8_t, 3>{};
    for (size_t k = 0; k < out_c; ++k) pixels[i * out_c + k] = out_c == c ? image.pixels[i * c + k] : heat_rgb[k];
  }
  std::vector<uint8_t> rows((stride + 1) * h);
  for (size_t y = 0; y < h; ++y) filter_row(pixels.data() + y * stride, y ? pixels.data() + (y - 1) * stride : nullptr,
                                             stride, out_c, rows.data() + y * (stride + 1));
  uLongf packed_size = compressBound(uLong(rows.size()));
  std::string packed(packed_size, '\0');
  const int z = compress2(reinterpret_cast<Bytef*>(packed.data()), &packed_size, rows.data(), uLong(rows.size()), 9);
  RGS_RETURN_ERROR_IF(z != Z_OK, StatusCode::kOutOfMemory, "report image: zlib compress2 failed (" +
                                                               std::to_string(z) + ")");
  packed.resize(packed_size);
  std::string header;
  put_u32(header, uint32_t(w));
  put_u32(header, uint32_t(h));
  header += std::string{8, char(out_c == 3 ? 2 : 0), 0, 0, 0};  // 8 bits, RGB or grey, deflate, filters, no interlace
  std::string png = "\x89PNG\r\n\x1a\n";
  put_chunk(png, "IHDR", header);
  put_chunk(png, "IDAT", packed);
  put_chunk(png, "IEND", "");
  return "data:image/png;base64," + base64(png);
}

}  // namespace rgs::audit::detail
