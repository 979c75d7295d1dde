// Fuzz target: INRIA cameras.json text (parse_inria_cameras, behind rgs-render --cameras) with loader options.
// Input: 13 bytes of options (f64 downscale, u16 width, u16 height, u8 every_kth), then the JSON text.
// Any input must give ok or an error Status; every camera returned must pass validate_camera().
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "fuzz_check.h"
#include "rgs/runtime/camera.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  constexpr size_t kOptionBytes = 13;
  if (size < kOptionBytes) return 0;
  rgs::runtime::InriaCameraOptions options;
  std::memcpy(&options.downscale, data, 8);
  options.width = static_cast<uint32_t>(data[8] | (data[9] << 8));
  options.height = static_cast<uint32_t>(data[10] | (data[11] << 8));
  options.every_kth = 1u + data[12] % 4u;
  const std::string text(reinterpret_cast<const char*>(data + kOptionBytes), size - kOptionBytes);

  auto cameras = rgs::runtime::parse_inria_cameras(text, "<fuzz>", options);
  if (!cameras.ok()) return 0;
  for (const rgs::runtime::Camera& camera : *cameras) {
    const rgs::Status valid = rgs::runtime::validate_camera(camera);
    RGS_FUZZ_CHECK(valid.ok(), valid.to_string());
  }
  return 0;
}
