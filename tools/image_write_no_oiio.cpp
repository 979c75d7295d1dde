// image_write.h in a build without OpenImageIO (RGS_WITH_OPENIMAGEIO=OFF): PNG and EXR requests fail with a
// message that names the option and the PPM/PFM alternative.
#include "image_write.h"

namespace rgs::tools {

bool have_openimageio() { return false; }

Status write_png8(format::FileSink&, const std::string& path, uint32_t, uint32_t, uint32_t, const std::vector<uint8_t>&) {
  return no_openimageio_error(path, "PNG output");
}

Status write_exr_rgba(format::FileSink&, const std::string& path, uint32_t, uint32_t, const std::vector<float>&,
                      const std::vector<float>&) {
  return no_openimageio_error(path, "EXR output");
}

}  // namespace rgs::tools
