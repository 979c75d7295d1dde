// Frame images: JPEG through libturbojpeg, WebP through libwebp, and the compare mode's metrics and heatmap.
#include "rgs/view/image_codec.h"

#include <turbojpeg.h>
#include <webp/encode.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <string>

namespace rgs::view {

namespace {

constexpr uint32_t kMaxWebpSide = 16383;  // WEBP_MAX_DIMENSION

Result<std::vector<uint8_t>> encode_jpeg(const uint8_t* rgb, uint32_t width, uint32_t height, uint32_t channels,
                                         int quality) {
  std::unique_ptr<void, int (*)(tjhandle)> handle(tjInitCompress(), tjDestroy);
  RGS_RETURN_ERROR_IF(handle == nullptr, StatusCode::kOutOfMemory, "JPEG: tjInitCompress failed");
  unsigned char* out = nullptr;
  unsigned long size = 0;
  // 4:4:4 at high quality: colour edges (the compare mode's split line, thin splats) stay sharp.
  const int subsampling = quality >= 90 ? TJSAMP_444 : TJSAMP_420;
  const int result = tjCompress2(handle.get(), rgb, int(width), int(width * channels), int(height),
                                 channels == 4 ? TJPF_RGBX : TJPF_RGB, &out, &size, subsampling, quality,
                                 TJFLAG_FASTDCT);
  std::unique_ptr<unsigned char, void (*)(unsigned char*)> owned(out, tjFree);
  RGS_RETURN_ERROR_IF(result != 0, StatusCode::kInvalidArgument,
                      std::string("JPEG: tjCompress2 failed: ") + tjGetErrorStr2(handle.get()));
  return std::vector<uint8_t>(out, out + size);
}

Result<std::vector<uint8_t>> encode_webp(const uint8_t* rgb, uint32_t width, uint32_t height, uint32_t channels,
                                         bool lossless, int quality) {
  RGS_RETURN_ERROR_IF(width > kMaxWebpSide || height > kMaxWebpSide, StatusCode::kInvalidArgument,
                      "WebP: " + std::to_string(width) + " x " + std::to_string(height) +
                          " exceeds WebP's 16383 pixels a side");
  // Interactive settings: the fastest methods (lossless level 1, lossy method 0, a second thread where libwebp
  // can use one); the simple API's defaults spend several times longer on a few per cent fewer bytes.
  WebPConfig config;
  RGS_RETURN_ERROR_IF(!WebPConfigInit(&config), StatusCode::kInvalidArgument, "WebP: library version mismatch");
  if (lossless) {
    WebPConfigLosslessPreset(&config, 1);
    config.exact = 1;
  } else {
    config.quality = static_cast<float>(quality);
    config.method = 0;
  }
  config.thread_level = 1;
  WebPPicture picture;
  RGS_RETURN_ERROR_IF(!WebPPictureInit(&picture), StatusCode::kInvalidArgument, "WebP: library version mismatch");
  picture.use_argb = lossless ? 1 : 0;
  picture.width = int(width);
  picture.height = int(height);
  WebPMemoryWriter writer;
  WebPMemoryWriterInit(&writer);
  picture.writer = WebPMemoryWrite;
  picture.custom_ptr = &writer;
  const bool imported = (channels == 4 ? WebPPictureImportRGBX(&picture, rgb, int(width * 4))
                                       : WebPPictureImportRGB(&picture, rgb, int(width * 3))) != 0;
  const bool encoded = imported && WebPEncode(&config, &picture) != 0;
  const int error = picture.error_code;
  WebPPictureFree(&picture);
  std::vector<uint8_t> out(writer.mem, writer.mem + writer.size);
  WebPMemoryWriterClear(&writer);
  RGS_RETURN_ERROR_IF(!encoded, error == VP8_ENC_ERROR_OUT_OF_MEMORY ? StatusCode::kOutOfMemory
                                                                       : StatusCode::kInvalidArgument,
                      "WebP: encoding " + std::to_string(width) + " x " + std::to_string(height) +
                          " failed (libwebp error " + std::to_string(error) + ")");
  return out;
}

// The turbo colour map (Mikhailov, Google 2019), its published polynomial approximation; t in [0, 1].
void turbo(float t, uint8_t* rgb) {
  const double x = t, x2 = x * x, x3 = x2 * x, x4 = x3 * x, x5 = x4 * x;
  const double r = 0.13572138 + 4.61539260 * x - 42.66032258 * x2 + 132.13108234 * x3 - 152.94239396 * x4 +
                   59.28637943 * x5;
  const double g = 0.09140261 + 2.19418839 * x + 4.84296658 * x2 - 14.18503333 * x3 + 4.27729857 * x4 +
                   2.82956604 * x5;
  const double b = 0.10667330 + 12.64194608 * x - 60.58204836 * x2 + 110.36276771 * x3 - 89.90310912 * x4 +
                   27.34824973 * x5;
  const auto unorm = [](double v) { return uint8_t(std::lround(std::clamp(v, 0.0, 1.0) * 255.0)); };
  rgb[0] = unorm(r);
  rgb[1] = unorm(g);
  rgb[2] = unorm(b);
}

}  // namespace

Result<std::vector<uint8_t>> encode_rgb(const uint8_t* rgb, uint32_t width, uint32_t height, Encoding encoding,
                                        int quality, uint32_t channels) {
  RGS_RETURN_ERROR_IF(rgb == nullptr, StatusCode::kInvalidArgument, "encode_rgb: null image");
  RGS_RETURN_ERROR_IF(channels != 3 && channels != 4, StatusCode::kInvalidArgument,
                      "encode_rgb: " + std::to_string(channels) + " channels (3 or 4)");
  RGS_RETURN_ERROR_IF(width < 1 || height < 1 || width > kMaxWebpSide || height > kMaxWebpSide,
                      StatusCode::kInvalidArgument,
                      "encode_rgb: " + std::to_string(width) + " x " + std::to_string(height) +
                          " is outside 1..16383 pixels a side");
  RGS_RETURN_ERROR_IF(encoding != Encoding::kLossless && (quality < 1 || quality > 100), StatusCode::kInvalidArgument,
                      "encode_rgb: quality " + std::to_string(quality) + " is outside 1..100");
  switch (encoding) {
    case Encoding::kJpeg: return encode_jpeg(rgb, width, height, channels, quality);
    case Encoding::kWebp: return encode_webp(rgb, width, height, channels, false, quality);
    case Encoding::kLossless: return encode_webp(rgb, width, height, channels, true, quality);
  }
  return Status(StatusCode::kInvalidArgument, "encode_rgb: unknown encoding");
}

ImageDifference compare_rgb(const uint8_t* a, const uint8_t* b, uint32_t width, uint32_t height, float diff_scale,
                            std::vector<uint8_t>* heatmap, uint32_t channels) {
  ImageDifference out;
  const size_t pixels = size_t(width) * height;
  if (heatmap != nullptr) heatmap->resize(pixels * 3);
  // The colour of each 8-bit level once: the heatmap of a 4K frame is a table look-up per pixel.
  uint8_t table[256][3];
  if (heatmap != nullptr) {
    for (int d = 0; d < 256; ++d) turbo(std::min(float(d) / diff_scale, 1.f), table[d]);
  }
  uint64_t sum_sq = 0;
  uint32_t max_abs = 0;
  for (size_t p = 0; p < pixels; ++p) {
    int worst = 0;
    for (int c = 0; c < 3; ++c) {
      const int d = std::abs(int(a[p * channels + c]) - int(b[p * channels + c]));
      sum_sq += uint64_t(d * d);
      worst = std::max(worst, d);
    }
    max_abs = std::max(max_abs, uint32_t(worst));
    if (heatmap != nullptr) std::copy(table[worst], table[worst] + 3, heatmap->data() + p * 3);
  }
  out.max_abs = max_abs;
  out.mse = pixels == 0 ? 0.0 : double(sum_sq) / (double(pixels) * 3.0);
  if (out.mse > 0) out.psnr_db = 10.0 * std::log10(255.0 * 255.0 / out.mse);
  return out;
}

}  // namespace rgs::view
