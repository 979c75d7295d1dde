// image_write.h: PFM, the dispatch by extension, and PNG and EXR through
// OpenImageIO where the build has it (RGS_WITH_OPENIMAGEIO: 1 or 0, set by CMake for this file only).
#include "image_write.h"

#include <cstring>

#include "cli_common.h"
#include "rgs/audit/audit_report.h"
#include "rgs/format/file_io.h"

#if RGS_WITH_OPENIMAGEIO
#include <OpenImageIO/imageio.h>
#endif

namespace rgs::tools {

namespace {

/// What every PNG/EXR request gets in a build without OpenImageIO: the PPM/PFM alternative.
Status no_openimageio_error(const std::string& path, const std::string& what) {
  return Status(StatusCode::kUnsupportedFeature,
                path + ": " + what + " needs OpenImageIO, and this build has none (RGS_WITH_OPENIMAGEIO=OFF); "
                "write PPM/PGM (8-bit) or PFM (float) instead");
}

/// Writes `data` ([H, W, channels] uint8 or float32; a 4th channel is alpha) through OpenImageIO's
/// `format_name` writer into `files` (staged in the run's format::OutputTransaction, or a temporary renamed over `path`): the
/// format is chosen by name rather than by the temporary's extension. Without OpenImageIO, kUnsupportedFeature
/// for `what` ("PNG output").
#if RGS_WITH_OPENIMAGEIO
Status write_oiio(format::FileSink& files, const std::string& path, const char* format_name, const char* /*what*/,
                  uint32_t width, uint32_t height, uint32_t channels, bool is_float, const void* data) {
  const OIIO::TypeDesc type = is_float ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8;
  OIIO::ImageSpec spec(int(width), int(height), int(channels), type);
  if (channels == 4) spec.alpha_channel = 3;
  return files.write_by_name(path, [&](const std::string& temp) -> Status {
    auto out = OIIO::ImageOutput::create(format_name);
    if (!out) {
      return Status(StatusCode::kIoError,
                    path + ": OpenImageIO has no " + format_name + " writer: " + OIIO::geterror());
    }
    if (!out->open(temp, spec)) return Status(StatusCode::kIoError, path + ": cannot write: " + out->geterror());
    const bool written = out->write_image(type, data);
    const bool closed = out->close();
    if (!written || !closed) return Status(StatusCode::kIoError, path + ": write failed: " + out->geterror());
    return Status::ok_status();
  });
}
#else
Status write_oiio(format::FileSink&, const std::string& path, const char*, const char* what, uint32_t, uint32_t,
                  uint32_t, bool, const void*) {
  return no_openimageio_error(path, what);
}
#endif

/// An 8-bit PNG of [H, W, channels] pixels (channels 1 or 3).
Status write_png8(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height,
                  uint32_t channels, const std::vector<uint8_t>& pixels) {
  RGS_RETURN_ERROR_IF(width == 0 || height == 0 || (channels != 1 && channels != 3) ||
                          pixels.size() != size_t{width} * height * channels,
                      StatusCode::kInvalidArgument, path + ": image size does not match its pixel buffer");
  return write_oiio(files, path, "png", "PNG output", width, height, channels, false, pixels.data());
}

}  // namespace

bool have_openimageio() { return RGS_WITH_OPENIMAGEIO != 0; }

Status write_exr_rgba(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height,
                      const std::vector<float>& rgba) {
  RGS_RETURN_ERROR_IF(width == 0 || height == 0 || rgba.size() != size_t{width} * height * 4,
                      StatusCode::kInvalidArgument, path + ": image size does not match its pixel buffer");
  return write_oiio(files, path, "openexr", "EXR output", width, height, 4, true, rgba.data());
}

Status write_pfm_rgb(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height,
                     const std::vector<float>& rgb) {
  const size_t row = size_t{width} * 3;
  RGS_RETURN_ERROR_IF(width == 0 || height == 0 || rgb.size() != row * height, StatusCode::kInvalidArgument,
                      path + ": " + std::to_string(rgb.size()) + " floats given for a " + std::to_string(width) +
                          "x" + std::to_string(height) + " RGB image");
  static_assert(sizeof(float) == 4, "PFM stores IEEE float32");
  // Scale −1.0 declares little-endian samples: written byte by byte, whatever the host's order.
  std::string bytes = "PF\n" + std::to_string(width) + " " + std::to_string(height) + "\n-1.0\n";
  size_t at = bytes.size();
  bytes.resize(at + rgb.size() * 4);
  for (uint32_t y = 0; y < height; ++y) {  // PFM rows run bottom to top
    const float* src = rgb.data() + (height - 1 - y) * row;
    for (size_t i = 0; i < row; ++i) {
      uint32_t u;
      std::memcpy(&u, &src[i], 4);
      for (int b = 0; b < 4; ++b) bytes[at++] = static_cast<char>((u >> (8 * b)) & 0xffu);
    }
  }
  return files.write(path, bytes.data(), bytes.size());
}

Status check_image8_path(const std::string& path, uint32_t channels) {
  const std::string ext = converter::extension_of(path);
  if (ext == ".png") return have_openimageio() ? Status::ok_status() : no_openimageio_error(path, "PNG output");
  if (ext == ".ppm") return Status::ok_status();
  if (ext == ".pgm") {
    RGS_RETURN_ERROR_IF(channels != 1, StatusCode::kInvalidArgument,
                        path + ": PGM holds grey images; write a " + std::to_string(channels) +
                            "-channel image as .ppm" + (have_openimageio() ? " or .png" : ""));
    return Status::ok_status();
  }
  return Status(StatusCode::kInvalidArgument,
                path + ": unknown image extension '" + ext + "' (use " +
                    (have_openimageio() ? ".png, " : "") + ".ppm or .pgm)");
}

Status write_image8(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height,
                    uint32_t channels, const std::vector<uint8_t>& pixels) {
  RGS_RETURN_IF_ERROR(check_image8_path(path, channels));
  const std::string ext = converter::extension_of(path);
  if (ext == ".png") return write_png8(files, path, width, height, channels, pixels);
  if (ext == ".pgm" || channels == 3) return audit::write_netpbm(path, {width, height, channels, pixels}, files);
  // .ppm of a grey image: repeat the grey into RGB.
  RGS_RETURN_ERROR_IF(channels != 1 || pixels.size() != size_t{width} * height, StatusCode::kInvalidArgument,
                      path + ": image size does not match its pixel buffer");
  std::vector<uint8_t> rgb(pixels.size() * 3);
  for (size_t i = 0; i < pixels.size(); ++i) rgb[i * 3] = rgb[i * 3 + 1] = rgb[i * 3 + 2] = pixels[i];
  return audit::write_netpbm(path, {width, height, 3, std::move(rgb)}, files);
}

}  // namespace rgs::tools
