// The metadata and value rules (SPEC.md §4.1, §4.3-§4.7) that the writer and the reader share.
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>

#include "internal_bytes.h"
#include "internal_sections.h"
#include "rgs/format/half.h"

namespace rgs::format {
namespace detail {
namespace {

std::string triple(const float v[3]) { return "(" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + ")"; }

std::string gaussian(uint64_t index) { return "Gaussian " + dec(index) + ": "; }

}  // namespace

Status check_metadata(const SceneMetadata& m) {
  auto unknown = [](const char* what, auto value, const char* known) {
    return Status(StatusCode::kUnsupportedFeature, std::string(what) + " " + dec(static_cast<unsigned>(value)) +
                                                   " is unknown (this reader knows " + known + ")");
  };
  if (m.frame != CoordinateFrame::kColmap) return unknown("coordinate frame", m.frame, "1 = colmap");
  if (m.quaternion_order != QuaternionOrder::kWxyz) return unknown("quaternion order", m.quaternion_order, "1 = wxyz");
  if (m.scale_encoding != ScaleEncoding::kLinear && m.scale_encoding != ScaleEncoding::kLog) {
    return unknown("scale encoding", m.scale_encoding, "1 = linear, 2 = log");
  }
  if (m.opacity_encoding != OpacityEncoding::kSigmoid) {
    return unknown("opacity encoding", m.opacity_encoding, "1 = sigmoid");
  }
  if (m.sh_layout != ShLayout::kCoefficientMajor) return unknown("SH layout", m.sh_layout, "1 = coefficient-major");
  RGS_RETURN_ERROR_IF(m.sh_degree > 3, StatusCode::kUnsupportedFeature,
                      "SH degree " + dec(m.sh_degree) + " is above 3, the highest version 1.0 defines");
  std::string why;
  RGS_RETURN_ERROR_IF(!is_valid_quantization(m.sh_quantization, m.sh_degree, &why), StatusCode::kCorruptData, why);
  const SceneBounds& b = m.bounds;
  for (int a = 0; a < 3; ++a) {
    RGS_RETURN_ERROR_IF(!std::isfinite(b.aabb_min[a]) || !std::isfinite(b.aabb_max[a]) ||
                            !std::isfinite(b.sphere_center[a]),
                        StatusCode::kCorruptData,
                        "bounds are not finite: AABB " + triple(b.aabb_min) + ".." + triple(b.aabb_max) +
                            ", sphere centre " + triple(b.sphere_center));
    RGS_RETURN_ERROR_IF(!(b.aabb_min[a] <= b.aabb_max[a]), StatusCode::kCorruptData,
                        "AABB min " + triple(b.aabb_min) + " exceeds max " + triple(b.aabb_max) + " on axis " +
                            dec(static_cast<uint64_t>(a)));
  }
  RGS_RETURN_ERROR_IF(!std::isfinite(b.sphere_radius) || !(b.sphere_radius >= 0.0f), StatusCode::kCorruptData,
                      "bounding sphere radius " + num(b.sphere_radius) + " is not finite and >= 0");
  return Status();
}

Status check_mean(const float xyz[3], uint64_t index, const SceneBounds& b) {
  RGS_RETURN_ERROR_IF(!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2]),
                      StatusCode::kCorruptData, gaussian(index) + "mean " + triple(xyz) + " is not finite");
  for (int a = 0; a < 3; ++a) {
    RGS_RETURN_ERROR_IF(xyz[a] < b.aabb_min[a] || xyz[a] > b.aabb_max[a], StatusCode::kCorruptData,
                        gaussian(index) + "mean " + triple(xyz) + " lies outside the AABB " + triple(b.aabb_min) +
                            ".." + triple(b.aabb_max));
  }
  // §4.1.1 The sphere must contain every mean.
  const double distance = std::sqrt(distance_squared(xyz, b.sphere_center));
  RGS_RETURN_ERROR_IF(distance > sphere_limit(b.sphere_center, b.sphere_radius), StatusCode::kCorruptData,
                      gaussian(index) + "mean " + triple(xyz) + " is " + num(distance) + " from the sphere centre " +
                          triple(b.sphere_center) + ", outside the radius " + num(b.sphere_radius));
  return Status();
}

Status check_rotation(const uint16_t q[4], uint64_t index) {
  bool non_zero = false;
  for (int a = 0; a < 4; ++a) {
    RGS_RETURN_ERROR_IF(!half_bits_finite(q[a]), StatusCode::kCorruptData,
                        gaussian(index) + "rotation component " + dec(static_cast<uint64_t>(a)) + " is " +
                            num(half_bits_to_float(q[a])));
    non_zero = non_zero || (q[a] & 0x7fffu) != 0;
  }
  RGS_RETURN_ERROR_IF(!non_zero, StatusCode::kCorruptData, gaussian(index) + "rotation quaternion is zero");
  return Status();
}

Status check_scale(const uint16_t s[3], uint64_t index, ScaleEncoding encoding) {
  for (int a = 0; a < 3; ++a) {
    if (scale_component_passes(s[a], encoding)) continue;
    const std::string component = dec(static_cast<uint64_t>(a)) + " is " + num(half_bits_to_float(s[a]));
    if (!half_bits_finite(s[a])) {
      return Status(StatusCode::kCorruptData, gaussian(index) + "scale component " + component);
    }
    if (encoding == ScaleEncoding::kLog) {
      return Status(StatusCode::kCorruptData,
                    gaussian(index) + "log scale component " + component + ", whose exp overflows float32");
    }
    return Status(StatusCode::kCorruptData, gaussian(index) + "linear scale component " + component + ", negative");
  }
  return Status();
}

Status check_opacity(uint16_t opacity, uint64_t index) {
  RGS_RETURN_ERROR_IF(!opacity_passes(opacity), StatusCode::kCorruptData,
                      gaussian(index) + "opacity " + num(half_bits_to_float(opacity)) + " is outside [0, 1]");
  return Status();
}

Status check_sh(const int8_t* q, size_t count, uint64_t index) {
  for (size_t j = 0; j < count; ++j) {
    RGS_RETURN_ERROR_IF(q[j] == -128, StatusCode::kCorruptData,
                        gaussian(index) + "SH value -128 (coefficient " + dec(j / 3) + ", channel " + dec(j % 3) +
                            ") is outside the symmetric range [-127, 127]");
  }
  return Status();
}

namespace {

/// True when pred holds for each of the `count` little-endian u16 values at `p`: one flat loop with no branch
/// per value, which the compiler vectorizes (the values of a section are read as one stream, whatever their
/// record).
template <typename Pred>
bool all_u16(const uint8_t* p, size_t count, Pred pred) {
  unsigned failed = 0;
  for (size_t j = 0; j < count; ++j) failed |= !pred(load_u16_le(p + 2 * j));
  return failed == 0;
}

}  // namespace

bool records_pass(SectionId id, const SceneMetadata& metadata, const uint8_t* p, size_t records, size_t record_size) {
  switch (id) {
    case SectionId::kMeans: {
      // check_mean's tests, in the same arithmetic. Square roots are taken only when some mean lies near the
      // sphere: below `inner` squared, the distance is below the limit however sqrt rounds.
      const SceneBounds& b = metadata.bounds;
      const double limit = sphere_limit(b.sphere_center, b.sphere_radius);
      const double inner = limit * (1.0 - 1e-12);
      const double inner2 = limit > 0 ? inner * inner : -1.0;
      unsigned failed = 0, near = 0;
      for (size_t j = 0; j < records; ++j) {
        const float xyz[3] = {load_f32_le(p + 12 * j), load_f32_le(p + 12 * j + 4), load_f32_le(p + 12 * j + 8)};
        for (int a = 0; a < 3; ++a) {
          failed |= !std::isfinite(xyz[a]) | (xyz[a] < b.aabb_min[a]) | (xyz[a] > b.aabb_max[a]);
        }
        near |= !(distance_squared(xyz, b.sphere_center) <= inner2);
      }
      if (failed != 0 || near == 0) return failed == 0;
      for (size_t j = 0; j < records; ++j) {
        const float xyz[3] = {load_f32_le(p + 12 * j), load_f32_le(p + 12 * j + 4), load_f32_le(p + 12 * j + 8)};
        failed |= std::sqrt(distance_squared(xyz, b.sphere_center)) > limit;
      }
      return failed == 0;
    }
    case SectionId::kRotations: {
      unsigned zero = 0;  // the zero quaternion: ±0 in each of its 4 binary16
      for (size_t j = 0; j < records; ++j) zero |= (load_u64_le(p + 8 * j) & 0x7fff7fff7fff7fffull) == 0;
      return zero == 0 && all_u16(p, 4 * records, half_bits_finite);
    }
    case SectionId::kScales:
      if (metadata.scale_encoding == ScaleEncoding::kLog) {
        return all_u16(p, 3 * records, [](uint16_t v) { return scale_component_passes(v, ScaleEncoding::kLog); });
      }
      return all_u16(p, 3 * records, [](uint16_t v) { return scale_component_passes(v, ScaleEncoding::kLinear); });
    case SectionId::kOpacities: return all_u16(p, records, opacity_passes);
    case SectionId::kSh: return records == 0 || std::memchr(p, 0x80, records * record_size) == nullptr;  // -128
    default: return true;
  }
}

Status check_records(SectionId id, const SceneMetadata& metadata, const uint8_t* p, size_t records,
                     size_t record_size, uint64_t first) {
  if (records_pass(id, metadata, p, records, record_size)) return Status();
  // Some record fails: find and name the first one.
  for (size_t j = 0; j < records; ++j, p += record_size) {
    const uint64_t i = first + j;
    switch (id) {
      case SectionId::kMeans: {
        const float xyz[3] = {load_f32_le(p), load_f32_le(p + 4), load_f32_le(p + 8)};
        RGS_RETURN_IF_ERROR(check_mean(xyz, i, metadata.bounds));
        break;
      }
      case SectionId::kRotations: {
        const uint16_t q[4] = {load_u16_le(p), load_u16_le(p + 2), load_u16_le(p + 4), load_u16_le(p + 6)};
        RGS_RETURN_IF_ERROR(check_rotation(q, i));
        break;
      }
      case SectionId::kScales: {
        const uint16_t s[3] = {load_u16_le(p), load_u16_le(p + 2), load_u16_le(p + 4)};
        RGS_RETURN_IF_ERROR(check_scale(s, i, metadata.scale_encoding));
        break;
      }
      case SectionId::kOpacities: RGS_RETURN_IF_ERROR(check_opacity(load_u16_le(p), i)); break;
      case SectionId::kSh: RGS_RETURN_IF_ERROR(check_sh(reinterpret_cast<const int8_t*>(p), record_size, i)); break;
      default: return Status();
    }
  }
  return Status();
}

}  // namespace detail
}  // namespace rgs::format
