// image_io.h: 8-bit conversion and PPM output.
#include "rgs/runtime/image_io.h"

#include "rgs/kernels/shared/blend_math.h"

#include <cmath>
#include <cstdio>

namespace rgs::runtime {

std::vector<uint8_t> to_8bit(const std::vector<float>& rgb) {
  std::vector<uint8_t> out(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) {
    out[i] = kernels::unorm8(rgb[i]);
  }
  return out;
}

Status write_ppm(const std::string& path, uint32_t width, uint32_t height, const std::vector<uint8_t>& rgb8) {
  RGS_RETURN_ERROR_IF(width == 0 || height == 0, StatusCode::kInvalidArgument,
                      path + ": image size " + std::to_string(width) + "x" + std::to_string(height) + " is empty");
  RGS_RETURN_ERROR_IF(rgb8.size() != size_t(width) * height * 3, StatusCode::kInvalidArgument,
                      path + ": " + std::to_string(rgb8.size()) + " bytes given for a " + std::to_string(width) +
                          "x" + std::to_string(height) + " RGB image");
  std::FILE* f = std::fopen(path.c_str(), "wb");
  RGS_RETURN_ERROR_IF(f == nullptr, StatusCode::kIoError, path + ": cannot open for writing");
  const std::string header = "P6\n" + std::to_string(width) + " " + std::to_string(height) + "\n255\n";
  bool ok = std::fwrite(header.data(), 1, header.size(), f) == header.size();
  ok = ok && std::fwrite(rgb8.data(), 1, rgb8.size(), f) == rgb8.size();
  ok = (std::fclose(f) == 0) && ok;
  RGS_RETURN_ERROR_IF(!ok, StatusCode::kIoError, path + ": write failed");
  return Status::ok_status();
}

}  // namespace rgs::runtime
