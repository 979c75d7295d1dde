// Frame images: JPEG through libturbojpeg, WebP through libwebp, and the compare mode's metrics and heatmap.
#include "rgs/view/image_codec.h"

#include <turbojpeg.h>
#include <webp/encode.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <memory>
#include <string>

#include "rgs/parallel/worker_pool.h"

namespace rgs::view {

namespace {

constexpr uint32_t kMaxWebpSide = 16383;  // WEBP_MAX_DIMENSION

// 4:4:4 at high quality: colour edges (the compare mode's split line, thin splats) stay sharp.
int jpeg_subsampling(int quality) { return jpeg_subsamples_chroma(quality) ? TJSAMP_420 : TJSAMP_444; }

Result<std::vector<uint8_t>> encode_jpeg(const uint8_t* rgb, uint32_t width, uint32_t height, uint32_t channels,
                                         int quality) {
  std::unique_ptr<void, int (*)(tjhandle)> handle(tjInitCompress(), tjDestroy);
  RGS_RETURN_ERROR_IF(handle == nullptr, StatusCode::kOutOfMemory, "JPEG: tjInitCompress failed");
  unsigned char* out = nullptr;
  unsigned long size = 0;
  const int subsampling = jpeg_subsampling(quality);
  const int result = tjCompress2(handle.get(), rgb, int(width), int(width * channels), int(height),
                                 channels == 4 ? TJPF_RGBX : TJPF_RGB, &out, &size, subsampling, quality,
                                 TJFLAG_FASTDCT);
  std::unique_ptr<unsigned char, void (*)(unsigned char*)> owned(out, tjFree);
  RGS_RETURN_ERROR_IF(result != 0, StatusCode::kInvalidArgument,
                      std::string("JPEG: tjCompress2 failed: ") + tjGetErrorStr2(handle.get()));
  return std::vector<uint8_t>(out, out + size);
}

/// The parts of a baseline JPEG as libturbojpeg writes it: the marker segments before SOS, the SOS segment, and
/// the entropy-coded data up to EOI. False for a stream of another shape.
struct JpegParts {
  size_t sof = 0;       ///< offset of the SOF0 marker (its height field is 5 bytes on)
  size_t sos = 0;       ///< offset of the SOS marker
  size_t data = 0;      ///< first byte of the entropy-coded data
  size_t data_end = 0;  ///< offset of the EOI marker
};
bool split_jpeg(const std::vector<uint8_t>& j, JpegParts* parts) {
  size_t at = 2;  // after SOI
  while (at + 4 <= j.size() && j[at] == 0xFF) {
    const uint8_t marker = j[at + 1];
    const size_t length = size_t(j[at + 2]) << 8 | j[at + 3];
    if (marker == 0xC0) parts->sof = at;
    if (marker == 0xDA) {
      parts->sos = at;
      parts->data = at + 2 + length;
      parts->data_end = j.size() - 2;
      return parts->sof != 0 && parts->data <= parts->data_end && j[j.size() - 2] == 0xFF && j.back() == 0xD9;
    }
    at += 2 + length;
  }
  return false;
}

/// Encodes `rgb` on the pool's workers: the image cut into strips of whole MCU rows, each encoded alone by
/// libturbojpeg with the same quantization and (standard) Huffman tables, then joined into one baseline JPEG
/// whose restart interval (DRI) is one strip. A restart marker resets the DC predictions as the start of a scan
/// does (ITU-T T.81, F.1.2.1 and F.1.4.4), and each strip's data ends padded to a byte as data before a marker
/// must, so the strips' entropy-coded data join unchanged; the blocks, and so the decoded pixels, are the
/// one-thread encoding's. Empty when the strips do not share their tables (the caller encodes in one thread).
Result<std::vector<uint8_t>> encode_jpeg_strips(const uint8_t* rgb, uint32_t width, uint32_t height,
                                                uint32_t channels, int quality, uint32_t strip_rows,
                                                parallel::WorkerPool& workers) {
  const uint32_t strips = (height + strip_rows - 1) / strip_rows;
  std::vector<std::vector<uint8_t>> parts(strips);
  RGS_RETURN_IF_ERROR(workers.run(strips, strips, [&](unsigned, uint64_t i) {
    const uint32_t y0 = uint32_t(i) * strip_rows;
    auto part = encode_jpeg(rgb + size_t(y0) * width * channels, width, std::min(strip_rows, height - y0), channels,
                            quality);
    if (part.ok()) parts[i] = std::move(*part);  // an empty part: the join below gives up
  }));
  std::vector<JpegParts> at(strips);
  for (uint32_t i = 0; i < strips; ++i) {
    // Every strip's tables and scan header equal the first's (only the SOF's height may differ).
    if (!split_jpeg(parts[i], &at[i]) || at[i].data != at[0].data ||
        std::memcmp(parts[i].data(), parts[0].data(), at[0].sof + 5) != 0 ||
        std::memcmp(parts[i].data() + at[0].sof + 7, parts[0].data() + at[0].sof + 7, at[0].data - at[0].sof - 7) != 0) {
      return std::vector<uint8_t>{};
    }
  }
  const uint32_t mcu_w = uint32_t(tjMCUWidth[jpeg_subsampling(quality)]);
  const uint32_t mcu_h = uint32_t(tjMCUHeight[jpeg_subsampling(quality)]);
  const uint32_t interval = (width + mcu_w - 1) / mcu_w * (strip_rows / mcu_h);
  std::vector<uint8_t> out(parts[0].begin(), parts[0].begin() + at[0].sos);
  out[at[0].sof + 5] = uint8_t(height >> 8);
  out[at[0].sof + 6] = uint8_t(height & 0xFF);
  const uint8_t dri[6] = {0xFF, 0xDD, 0x00, 0x04, uint8_t(interval >> 8), uint8_t(interval & 0xFF)};
  out.insert(out.end(), dri, dri + 6);
  out.insert(out.end(), parts[0].begin() + at[0].sos, parts[0].begin() + at[0].data);
  for (uint32_t i = 0; i < strips; ++i) {
    if (i > 0) out.insert(out.end(), {0xFF, uint8_t(0xD0 + (i - 1) % 8)});  // RST0..RST7 in turn
    out.insert(out.end(), parts[i].begin() + at[i].data, parts[i].begin() + at[i].data_end);
  }
  out.insert(out.end(), {0xFF, 0xD9});
  return out;
}

/// Rows per strip for `workers`: whole MCU rows, at least 4 of them, each strip's MCUs within DRI's 16 bits; 0
/// when the frame is too small to split.
uint32_t jpeg_strip_rows(uint32_t width, uint32_t height, int quality, unsigned workers) {
  const uint32_t mcu_w = uint32_t(tjMCUWidth[jpeg_subsampling(quality)]);
  const uint32_t mcu_h = uint32_t(tjMCUHeight[jpeg_subsampling(quality)]);
  const uint32_t mcu_rows = (height + mcu_h - 1) / mcu_h, mcus_per_row = (width + mcu_w - 1) / mcu_w;
  constexpr uint32_t kMinMcuRows = 4;
  const uint32_t strips = std::min<uint32_t>(workers, mcu_rows / kMinMcuRows);
  if (strips < 2) return 0;
  const uint32_t rows = std::min((mcu_rows + strips - 1) / strips, 65535 / mcus_per_row);
  return rows * mcu_h;
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
                                        int quality, uint32_t channels, parallel::WorkerPool* workers) {
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
    case Encoding::kJpeg: {
      const uint32_t rows = workers != nullptr ? jpeg_strip_rows(width, height, quality, workers->workers()) : 0;
      if (rows != 0) {
        RGS_ASSIGN_OR_RETURN(std::vector<uint8_t> joined,
                             encode_jpeg_strips(rgb, width, height, channels, quality, rows, *workers));
        if (!joined.empty()) return joined;
      }
      return encode_jpeg(rgb, width, height, channels, quality);
    }
    case Encoding::kWebp: return encode_webp(rgb, width, height, channels, false, quality);
    case Encoding::kLossless: return encode_webp(rgb, width, height, channels, true, quality);
  }
  return Status(StatusCode::kInvalidArgument, "encode_rgb: unknown encoding");
}

bool jpeg_subsamples_chroma(int quality) { return quality < 90; }

std::string jpeg_encoder_name(unsigned workers) {
  return workers > 1 ? "JPEG: libjpeg-turbo on " + std::to_string(workers) +
                           " threads, in strips joined by restart markers"
                     : "JPEG: libjpeg-turbo in one thread";
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
