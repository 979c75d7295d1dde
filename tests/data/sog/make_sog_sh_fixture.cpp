// Builds tests/data/sog/guitar_crop_sh3/: guitar_crop/ plus a synthetic SH palette (3 bands), so the SOG
// reader's shN path is tested on a file PlayCanvas splat-transform reads the same way. Built by hand:
//   g++ -O2 -std=c++17 tests/data/sog/make_sog_sh_fixture.cpp -o /tmp/make_sog_sh_fixture -l:libwebp.a -lm
//   /tmp/make_sog_sh_fixture tests/data/sog
// Rule (asserted by tests/converter/test_scene_reader.cpp): palette of kPalette entries; Gaussian i has
// label (i·37) mod kPalette; entry p, coefficient j, channel c holds code (31p + 7j + 101c) mod 256; the
// codebook maps code v to (v − 127.5)/64.
#include <webp/encode.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

constexpr int kPalette = 100;
constexpr int kCoefficients = 15;  // 3 bands
constexpr int kCount = 877;
constexpr int kWidth = 32, kHeight = 28;  // the size of guitar_crop's images (896 >= 877 pixels)

static void write_webp(const std::string& path, const std::vector<uint8_t>& rgba, int w, int h) {
  uint8_t* out = nullptr;
  const size_t n = WebPEncodeLosslessRGBA(rgba.data(), w, h, w * 4, &out);
  if (n == 0) std::exit(1);
  std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(out), static_cast<std::streamsize>(n));
  WebPFree(out);
}

int main(int argc, char** argv) {
  if (argc != 2) return 2;
  const std::string dir = std::string(argv[1]) + "/guitar_crop_sh3";
  const int cw = 64 * kCoefficients, ch = (kPalette + 63) / 64;
  std::vector<uint8_t> centroids(static_cast<size_t>(cw) * ch * 4, 0);
  for (int p = 0; p < kPalette; ++p) {
    for (int j = 0; j < kCoefficients; ++j) {
      uint8_t* px = &centroids[((p / 64) * cw + (p % 64) * kCoefficients + j) * 4];
      for (int c = 0; c < 3; ++c) px[c] = static_cast<uint8_t>((31 * p + 7 * j + 101 * c) % 256);
      px[3] = 255;
    }
  }
  std::vector<uint8_t> labels(kWidth * kHeight * 4, 0);
  for (int i = 0; i < kCount; ++i) {
    const int label = (i * 37) % kPalette;
    labels[i * 4] = static_cast<uint8_t>(label & 255);
    labels[i * 4 + 1] = static_cast<uint8_t>(label >> 8);
    labels[i * 4 + 3] = 255;
  }
  write_webp(dir + "/shN_centroids.webp", centroids, cw, ch);
  write_webp(dir + "/shN_labels.webp", labels, kWidth, kHeight);
  std::ostringstream codebook;
  codebook << std::setprecision(9);
  for (int v = 0; v < 256; ++v) codebook << (v ? "," : "") << (v - 127.5) / 64;
  std::ifstream in(std::string(argv[1]) + "/guitar_crop/meta.json");
  std::string meta((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  meta.pop_back();  // the closing brace
  meta += ",\"shN\":{\"count\":" + std::to_string(kPalette) + ",\"bands\":3,\"codebook\":[" + codebook.str() +
          "],\"files\":[\"shN_centroids.webp\",\"shN_labels.webp\"]}}";
  std::ofstream(dir + "/meta.json") << meta;
  return 0;
}
