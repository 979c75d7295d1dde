// .splat reader: 32-byte records of position, linear scale, RGBA8 colour and u8 quaternion.
#include "rgs/converter/splat_reader.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include "../internal_interop.h"

namespace rgs::converter {

namespace {

/// A stored rotation byte as a quaternion component before normalization. Writers store floor(q·128 + 128)
/// (antimatter15's convert.py and splat-transform alike), so b stands for q in [(b − 128)/128, (b − 127)/128):
/// its midpoint (b − 127.5)/128 halves the angle error of (b − 128)/128 (converter/INTEROP.md ".splat").
inline float rotation_component(uint8_t b) { return (static_cast<float>(b) - 127.5f) / 128.0f; }

Result<InteropScene> read_records(const uint8_t* data, size_t size, const InteropReadOptions& options) {
  if (size == 0 || size % kSplatRecordBytes != 0) {
    return Status(StatusCode::kCorruptData, "antimatter15 .splat: the format holds 32-byte records, but this file has " +
                                                std::to_string(size) + " bytes (" +
                                                std::to_string(size % kSplatRecordBytes) +
                                                " left over: truncated, or not a .splat file)");
  }
  const uint64_t n = size / kSplatRecordBytes;
  RGS_RETURN_IF_ERROR(detail::check_limit(".splat file holds ", n, "Gaussians", options.max_gaussians));
  InteropScene scene = detail::rdf_interop_scene("splat", size, n, 0, options);
  format::GaussianCloud& cloud = scene.cloud;
  for (uint64_t i = 0; i < n; ++i) {
    const uint8_t* r = data + i * kSplatRecordBytes;
    for (int a = 0; a < 3; ++a) {
      cloud.means[i * 3 + a] = format::load_f32_le(r + 4 * a);
      cloud.scales[i * 3 + a] = format::load_f32_le(r + 12 + 4 * a);
    }
    for (int c = 0; c < 3; ++c) {
      cloud.sh[i * 3 + c] = static_cast<float>((r[24 + c] / 255.0 - 0.5) / detail::kShC0);
    }
    cloud.opacities[i] = static_cast<float>(r[27]) / 255.0f;
    // Bytes of 127 and 128 only stand for a quaternion within 1/128 of zero: no direction, so the hygiene
    // rules see a zero quaternion.
    const bool no_direction = std::all_of(r + 28, r + 32, [](uint8_t b) { return b == 127 || b == 128; });
    for (int a = 0; a < 4; ++a) cloud.rotations[i * 4 + a] = no_direction ? 0.0f : rotation_component(r[28 + a]);
  }
  RGS_RETURN_IF_ERROR(detail::finish_splat_scene("antimatter15 .splat", options, &scene));
  scene.notes.push_back(".splat carries SH degree 0 only, colours and opacity as 8 bits");
  return scene;
}

bool starts_with(const uint8_t* head, size_t n, const char* s) {
  const size_t len = std::strlen(s);
  return n >= len && std::memcmp(head, s, len) == 0;
}

}  // namespace

bool looks_like_splat(const uint8_t* head, size_t n, uint64_t file_size) {
  if (head == nullptr || file_size == 0 || file_size % kSplatRecordBytes != 0 || n < kSplatRecordBytes) return false;
  if (starts_with(head, n, "ply") || starts_with(head, n, "NGSP") || starts_with(head, n, "glTF") ||
      (head[0] == 0x1f && head[1] == 0x8b) || head[0] == '{' || head[0] == '[') {
    return false;
  }
  const size_t records = std::min<uint64_t>(n, file_size) / kSplatRecordBytes;
  for (size_t i = 0; i < records; ++i) {
    const uint8_t* r = head + i * kSplatRecordBytes;
    for (int a = 0; a < 3; ++a) {
      const float p = format::load_f32_le(r + 4 * a);
      const float s = format::load_f32_le(r + 12 + 4 * a);
      if (!(std::fabs(p) < 1e7f) || !(s >= 0.0f && s < 1e6f)) return false;
    }
    double n2 = 0;
    for (int a = 0; a < 4; ++a) {
      const double q = rotation_component(r[28 + a]);
      n2 += q * q;
    }
    if (n2 < 0.49 || n2 > 1.69) return false;
  }
  return true;
}

Result<InteropScene> read_splat(const std::string& path, const InteropReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(auto file, format::MappedFile::open(path));  // its errors name the path
  return read_splat_bytes(file->data(), file->size(), path, options);
}

Result<InteropScene> read_splat_bytes(const uint8_t* data, size_t size, const std::string& name,
                                      const InteropReadOptions& options) {
  return detail::guarded_bytes<InteropScene>(data, size, name, "decoding the .splat file",
                                             [&] { return read_records(data, size, options); });
}

}  // namespace rgs::converter
