// image_io.h: 8-bit conversion.
#include "rgs/runtime/image_io.h"

#include "rgs/kernels/shared/blend_math.h"

namespace rgs::runtime {

std::vector<uint8_t> to_8bit(const std::vector<float>& rgb) {
  std::vector<uint8_t> out(rgb.size());
  for (size_t i = 0; i < rgb.size(); ++i) {
    out[i] = kernels::unorm8(rgb[i]);
  }
  return out;
}

}  // namespace rgs::runtime
