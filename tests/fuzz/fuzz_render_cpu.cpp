// Fuzz target: the CPU reference renderer on tiny scenes and images, to find crashes and undefined
// behaviour in projection, EWA covariance, radius, tile rectangle, AccuTile, key math and the half blend's walk.
//
// The input is read as a camera, render switches and up to 64 Gaussians in the .rgs runtime profile
// (FP16 rotations, scales and opacities, INT8 SH with per-degree scales), forced into the value ranges
// validate() accepts (SPEC §4.3-§4.7) and then dequantized, so every scene rendered here is one a valid
// .rgs file can hold. Images are at most 48 x 48 pixels and rendered with one thread. The orbit cameras
// rgs-render makes for the scene's bounds must pass validate_camera().
#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>

#include "fuzz_check.h"
#include "rgs/converter/quantize.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/half.h"
#include "rgs/runtime/camera.h"
#include "rgs/runtime/cpu_renderer.h"

namespace {

// Reads little-endian values from the input; past its end every value is 0.
class ByteSource {
 public:
  ByteSource(const uint8_t* data, size_t size) : data_(data), size_(size) {}
  uint64_t next(size_t bytes) {
    uint64_t v = 0;
    for (size_t i = 0; i < bytes; ++i) v |= uint64_t{pos_ < size_ ? data_[pos_++] : uint8_t{0}} << (8 * i);
    return v;
  }
  uint8_t u8() { return static_cast<uint8_t>(next(1)); }
  uint16_t u16() { return static_cast<uint16_t>(next(2)); }
  float f32() {
    const uint32_t bits = static_cast<uint32_t>(next(4));
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  }
  float finite_f32() {
    const float f = f32();
    return std::isfinite(f) ? f : 0.f;
  }
  size_t left() const { return pos_ < size_ ? size_ - pos_ : 0; }

 private:
  const uint8_t* data_;
  size_t size_;
  size_t pos_ = 0;
};

// SPEC §4.4-§4.6 ranges: finite f16 (no exponent 31), opacity in [0, 1], linear scale not negative.
uint16_t finite_half(uint16_t bits) { return (bits & 0x7c00) == 0x7c00 ? static_cast<uint16_t>(bits & 0x83ff) : bits; }

rgs::runtime::Camera read_camera(ByteSource& in) {
  rgs::runtime::Camera camera;
  camera.width = 1 + in.u8() % 48;
  camera.height = 1 + in.u8() % 48;
  // Rotation from a quaternion (any non-zero one; a fixed one otherwise).
  double q[4];
  double norm = 0;
  for (double& c : q) {
    c = static_cast<int16_t>(in.u16());
    norm += c * c;
  }
  if (norm == 0) {
    q[0] = 1;
    norm = 1;
  }
  norm = std::sqrt(norm);
  for (double& c : q) c /= norm;
  const double w = q[0], x = q[1], y = q[2], z = q[3];
  const double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                       2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                       2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
  for (int i = 0; i < 9; ++i) camera.rotation[i] = static_cast<float>(r[i]);
  for (float& t : camera.translation) t = in.finite_f32();
  const float fov_scale = 0.05f + static_cast<float>(in.u8()) / 16.f;  // focal from about 0.05 to 16 widths
  camera.fx = fov_scale * static_cast<float>(camera.width);
  camera.fy = fov_scale * static_cast<float>(camera.height) * (0.5f + static_cast<float>(in.u8()) / 128.f);
  camera.cx = static_cast<float>(camera.width) / 2;
  camera.cy = static_cast<float>(camera.height) / 2;
  if (in.u8() & 1) camera.near_plane = std::max(1e-6f, std::fabs(in.finite_f32()));
  return camera;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  ByteSource in(data, size);
  const uint8_t switches = in.u8();
  rgs::runtime::RenderOptions options;
  options.num_threads = 1;
  options.roofgs.key32 = switches & 1;
  options.roofgs.snugbox_accutile = switches & 2;
  options.roofgs.folded_coefficients = switches & 4;
  options.roofgs.fast_exp = switches & 8;
  options.roofgs.depth_order = switches & 16;
  options.roofgs.accutile_within_baseline_rect = !(switches & 32);
  // Half blending (with folded coefficients and the fast exp) walks the GPU's lists in colour windows; bit 128
  // adds long tiles in chunks of the smallest size.
  options.roofgs.half_blend = switches & 64;
  options.roofgs.tile_chunk_pairs = (switches & 128) ? 1 : 0;
  const rgs::runtime::Camera camera = read_camera(in);
  if (!rgs::runtime::validate_camera(camera).ok()) return 0;  // float rounding of an odd quaternion

  rgs::format::EncodedScene scene;
  scene.metadata.sh_degree = (switches >> 6) & 3;
  scene.metadata.scale_encoding =
      (in.u8() & 1) ? rgs::format::ScaleEncoding::kLog : rgs::format::ScaleEncoding::kLinear;
  for (uint32_t d = 0; d <= scene.metadata.sh_degree; ++d) {
    for (float& s : scene.metadata.sh_quantization.scales[d]) s = std::fabs(in.finite_f32());
  }
  const uint32_t k = rgs::format::sh_coefficient_count(scene.metadata.sh_degree);
  const size_t per_gaussian = 12 + 8 + 6 + 2 + 3 * k;
  const uint64_t n = std::min<uint64_t>(in.left() / per_gaussian, 64);
  scene.count = n;
  for (uint64_t i = 0; i < n; ++i) {
    for (int c = 0; c < 3; ++c) scene.means.push_back(in.finite_f32());
    bool nonzero = false;
    for (int c = 0; c < 4; ++c) {
      const uint16_t h = finite_half(in.u16());
      nonzero = nonzero || (h & 0x7fff) != 0;
      scene.rotations.push_back(h);
    }
    if (!nonzero) scene.rotations[i * 4] = 0x3c00;
    for (int c = 0; c < 3; ++c) {
      uint16_t h = finite_half(in.u16());
      if (scene.metadata.scale_encoding == rgs::format::ScaleEncoding::kLinear) h &= 0x7fff;
      scene.scales.push_back(h);
    }
    const float opacity = static_cast<float>(in.u16()) / 65535.f;
    scene.opacities.push_back(rgs::format::float_to_half_bits(opacity));
    for (uint32_t j = 0; j < 3 * k; ++j) {
      const int8_t q = static_cast<int8_t>(in.u8());
      scene.sh.push_back(q == -128 ? int8_t{-127} : q);
    }
  }
  auto cloud = rgs::format::dequantize(scene);
  RGS_FUZZ_CHECK(cloud.ok(), cloud.status().to_string());
  options.scene_bounds = rgs::converter::compute_bounds(*cloud);
  // orbit_cameras() (rgs-render --orbit) on the same bounds: whatever it returns must be renderable.
  auto orbit = rgs::runtime::orbit_cameras(*options.scene_bounds, 2, camera.width, camera.height);
  if (orbit.ok()) {
    for (const rgs::runtime::Camera& c : *orbit) {
      const rgs::Status valid = rgs::runtime::validate_camera(c);
      RGS_FUZZ_CHECK(valid.ok(), valid.to_string());
    }
  }

  auto image = rgs::runtime::render_cpu(*cloud, camera, options);
  if (!image.ok()) {
    // The only documented refusal for a consistent cloud and a valid camera at this size: key32 needs a
    // finite bounding sphere, and means near the float range give an infinite radius.
    const rgs::format::SceneBounds& b = *options.scene_bounds;
    const bool sphere_finite = std::isfinite(b.sphere_radius) && std::isfinite(b.sphere_center[0]) &&
                               std::isfinite(b.sphere_center[1]) && std::isfinite(b.sphere_center[2]);
    RGS_FUZZ_CHECK(options.roofgs.key32 && !sphere_finite, image.status().to_string());
    return 0;
  }
  const size_t pixels = size_t{camera.width} * camera.height;
  RGS_FUZZ_CHECK(image->rgb.size() == pixels * 3 && image->alpha.size() == pixels && image->depth.size() == pixels,
                 "render_cpu returned images of the wrong size");
  // Blending keeps the transmittance T in (0, 1], so alpha = 1 - T is in [0, 1] whatever the Gaussians.
  for (size_t p = 0; p < pixels; ++p) {
    RGS_FUZZ_CHECK(image->alpha[p] >= 0.f && image->alpha[p] <= 1.f,
                   "pixel " + std::to_string(p) + " alpha " + std::to_string(image->alpha[p]));
  }
  return 0;
}
