// image_write.h: PNG and EXR through OpenImageIO (built only with RGS_WITH_OPENIMAGEIO).
#include "image_write.h"

#include <OpenImageIO/imageio.h>

#include <memory>

#include "rgs/format/file_io.h"

namespace rgs::tools {

namespace {

/// Writes through FileSink::write_by_name (with atomic_files(), a temporary renamed over `path`, or staged in the run's
/// OutputSet), with the format chosen by name rather than by the temporary's extension.
Status write_image(format::FileSink& files, const std::string& path, const char* format_name, const OIIO::ImageSpec& spec,
                   OIIO::TypeDesc type, const void* data) {
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

}  // namespace

bool have_openimageio() { return true; }

Status write_png8(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height, uint32_t channels,
                  const std::vector<uint8_t>& pixels) {
  RGS_RETURN_ERROR_IF(width == 0 || height == 0 || (channels != 1 && channels != 3) ||
                          pixels.size() != size_t{width} * height * channels,
                      StatusCode::kInvalidArgument, path + ": image size does not match its pixel buffer");
  OIIO::ImageSpec spec(static_cast<int>(width), static_cast<int>(height), static_cast<int>(channels),
                       OIIO::TypeDesc::UINT8);
  return write_image(files, path, "png", spec, OIIO::TypeDesc::UINT8, pixels.data());
}

Status write_exr_rgba(format::FileSink& files, const std::string& path, uint32_t width, uint32_t height, const std::vector<float>& rgb,
                      const std::vector<float>& alpha) {
  const size_t n = size_t{width} * height;
  RGS_RETURN_ERROR_IF(n == 0 || rgb.size() != n * 3 || alpha.size() != n, StatusCode::kInvalidArgument,
                      path + ": image size does not match its pixel buffers");
  std::vector<float> rgba(n * 4);
  for (size_t i = 0; i < n; ++i) {
    rgba[i * 4 + 0] = rgb[i * 3 + 0];
    rgba[i * 4 + 1] = rgb[i * 3 + 1];
    rgba[i * 4 + 2] = rgb[i * 3 + 2];
    rgba[i * 4 + 3] = alpha[i];
  }
  OIIO::ImageSpec spec(static_cast<int>(width), static_cast<int>(height), 4, OIIO::TypeDesc::FLOAT);
  spec.alpha_channel = 3;
  return write_image(files, path, "openexr", spec, OIIO::TypeDesc::FLOAT, rgba.data());
}

}  // namespace rgs::tools
