#include "internal_webp.h"

#include <webp/decode.h>
#include <webp/encode.h>

#include <new>

#include "internal_interop.h"

namespace rgs::converter::detail {

Status read_webp_size(const uint8_t* data, size_t size, const std::string& name, uint32_t* width, uint32_t* height) {
  // RIFF header: "RIFF" <u32 payload size> "WEBP"; the payload follows the first 8 bytes.
  if (size < 12 || std::string(reinterpret_cast<const char*>(data), 4) != "RIFF" ||
      std::string(reinterpret_cast<const char*>(data) + 8, 4) != "WEBP") {
    return Status(StatusCode::kCorruptData,
                  name + ": not a WebP image (" + std::to_string(size) + " bytes, no RIFF/WEBP header)");
  }
  const uint64_t riff_bytes = uint64_t{format::load_u32_le(data + 4)} + 8;
  if (riff_bytes > size) {
    return Status(StatusCode::kCorruptData, name + ": WebP image is truncated: its RIFF header declares " +
                                                std::to_string(riff_bytes) + " bytes, the file has " +
                                                std::to_string(size));
  }
  WebPBitstreamFeatures features;
  const VP8StatusCode got = WebPGetFeatures(data, static_cast<size_t>(riff_bytes), &features);
  if (got != VP8_STATUS_OK) {
    return Status(StatusCode::kCorruptData,
                  name + ": invalid WebP header (libwebp status " + std::to_string(static_cast<int>(got)) + ")");
  }
  if (features.has_animation) {
    return Status(StatusCode::kCorruptData, name + ": animated WebP images are not SOG attribute images");
  }
  if (features.width <= 0 || features.height <= 0) {
    return Status(StatusCode::kCorruptData, name + ": WebP image has no pixels (" + std::to_string(features.width) +
                                                " x " + std::to_string(features.height) + ")");
  }
  *width = static_cast<uint32_t>(features.width);
  *height = static_cast<uint32_t>(features.height);
  return Status();
}

Status decode_webp_rgba(const uint8_t* data, size_t size, uint64_t max_pixels, const std::string& name,
                        RgbaImage* out) {
  uint32_t width = 0, height = 0;
  RGS_RETURN_IF_ERROR(read_webp_size(data, size, name, &width, &height));
  const size_t riff_bytes = static_cast<size_t>(uint64_t{format::load_u32_le(data + 4)} + 8);
  const uint64_t pixels = uint64_t{width} * height;
  const std::string dims = std::to_string(width) + " x " + std::to_string(height);
  RGS_RETURN_IF_ERROR(check_limit(name + ": WebP image is " + dims + " = ", pixels, "pixels", max_pixels));
  out->width = width;
  out->height = height;
  const uint64_t bytes = pixels * 4;
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&] { out->rgba.resize(static_cast<size_t>(bytes)); return Status(); }, [&] {
    return name + ": cannot allocate " + std::to_string(bytes) + " bytes for the decoded WebP image";
  }));
  const int stride = static_cast<int>(width) * 4;
  if (WebPDecodeRGBAInto(data, riff_bytes, out->rgba.data(), out->rgba.size(), stride) == nullptr) {
    return Status(StatusCode::kCorruptData, name + ": WebP image data is corrupt or truncated (" + dims + ", " +
                                                std::to_string(riff_bytes) + " bytes)");
  }
  return Status();
}

Result<std::vector<uint8_t>> encode_webp_lossless(const RgbaImage& image, const std::string& name) {
  RGS_RETURN_ERROR_IF(image.width == 0 || image.height == 0 || image.width > WEBP_MAX_DIMENSION ||
                          image.height > WEBP_MAX_DIMENSION || image.rgba.size() != image.pixels() * 4,
                      StatusCode::kInvalidArgument,
                      name + ": cannot encode a " + std::to_string(image.width) + " x " +
                          std::to_string(image.height) + " WebP image (1.." + std::to_string(WEBP_MAX_DIMENSION) +
                          " pixels a side)");
  WebPConfig config;
  WebPPicture picture;
  if (!WebPConfigInit(&config) || !WebPPictureInit(&picture)) {
    return Status(StatusCode::kIoError, name + ": libwebp version mismatch");
  }
  config.lossless = 1;
  config.exact = 1;  // SOG images are data: RGB under a zero alpha is a value too
  // Low effort: SOG images are dense data, on which libwebp's deeper searches (method 4, quality 75) take 3-9x
  // the time for files within 0.5 % of the size, often larger (docs/BENCHMARKS.md "SOG output").
  config.quality = 50;
  config.method = 1;
  picture.use_argb = 1;
  picture.width = static_cast<int>(image.width);
  picture.height = static_cast<int>(image.height);
  WebPMemoryWriter writer;
  WebPMemoryWriterInit(&writer);
  picture.writer = WebPMemoryWrite;
  picture.custom_ptr = &writer;
  const bool imported = WebPPictureImportRGBA(&picture, image.rgba.data(), static_cast<int>(image.width) * 4) != 0;
  const bool encoded = imported && WebPEncode(&config, &picture) != 0;
  const int error = static_cast<int>(picture.error_code);
  WebPPictureFree(&picture);
  std::vector<uint8_t> out;
  if (encoded) out.assign(writer.mem, writer.mem + writer.size);
  WebPMemoryWriterClear(&writer);
  if (!encoded) {
    return Status(StatusCode::kIoError, name + ": WebP encoding failed (libwebp error " + std::to_string(error) + ")");
  }
  return out;
}

}  // namespace rgs::converter::detail
