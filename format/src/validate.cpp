// Full validation of .rgs bytes (SPEC.md §5) and the metadata and value rules the writer shares.
#include <zstd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include "internal_bytes.h"
#include "internal_sections.h"
#include "rgs/format/half.h"
#include "rgs/format/reader.h"

namespace rgs::format {
namespace detail {
namespace {

std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

std::string triple(const float v[3]) { return "(" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + ")"; }

std::string gaussian(uint64_t index) { return "Gaussian " + dec(index) + ": "; }

bool half_is_finite(uint16_t bits) { return (bits & 0x7c00u) != 0x7c00u; }

}  // namespace

Status check_metadata(const SceneMetadata& m) {
  auto unsupported = [](const char* what, unsigned value, const char* known) {
    return Status(StatusCode::kUnsupportedFeature,
                  std::string(what) + " " + std::to_string(value) + " is unknown (this reader knows " + known + ")");
  };
  if (m.frame != CoordinateFrame::kColmap)
    return unsupported("coordinate frame", static_cast<unsigned>(m.frame), "1 = colmap");
  if (m.quaternion_order != QuaternionOrder::kWxyz) {
    return unsupported("quaternion order", static_cast<unsigned>(m.quaternion_order), "1 = wxyz");
  }
  if (m.scale_encoding != ScaleEncoding::kLinear && m.scale_encoding != ScaleEncoding::kLog) {
    return unsupported("scale encoding", static_cast<unsigned>(m.scale_encoding), "1 = linear, 2 = log");
  }
  if (m.opacity_encoding != OpacityEncoding::kSigmoid) {
    return unsupported("opacity encoding", static_cast<unsigned>(m.opacity_encoding), "1 = sigmoid");
  }
  if (m.sh_layout != ShLayout::kCoefficientMajor) {
    return unsupported("SH layout", static_cast<unsigned>(m.sh_layout), "1 = coefficient-major");
  }
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
  // §4.1.1 The sphere must contain every mean; the slack absorbs float32 rounding in whichever way the
  // writer computed the distance.
  double d2 = 0, c_max = 0;
  for (int a = 0; a < 3; ++a) {
    const double d = static_cast<double>(xyz[a]) - static_cast<double>(b.sphere_center[a]);
    d2 += d * d;
    c_max = std::fmax(c_max, std::fabs(static_cast<double>(b.sphere_center[a])));
  }
  const double r = b.sphere_radius;
  const double distance = std::sqrt(d2);
  RGS_RETURN_ERROR_IF(distance > r + 1e-6 * (r + c_max), StatusCode::kCorruptData,
                      gaussian(index) + "mean " + triple(xyz) + " is " + num(distance) + " from the sphere centre " +
                          triple(b.sphere_center) + ", outside the radius " + num(r));
  return Status();
}

Status check_rotation(const uint16_t q[4], uint64_t index) {
  bool non_zero = false;
  for (int a = 0; a < 4; ++a) {
    RGS_RETURN_ERROR_IF(!half_is_finite(q[a]), StatusCode::kCorruptData,
                        gaussian(index) + "rotation component " + dec(static_cast<uint64_t>(a)) + " is " +
                            num(half_bits_to_float(q[a])));
    non_zero = non_zero || (q[a] & 0x7fffu) != 0;
  }
  RGS_RETURN_ERROR_IF(!non_zero, StatusCode::kCorruptData, gaussian(index) + "rotation quaternion is zero");
  return Status();
}

Status check_scale(const uint16_t s[3], uint64_t index, ScaleEncoding encoding) {
  for (int a = 0; a < 3; ++a) {
    const float v = half_bits_to_float(s[a]);
    RGS_RETURN_ERROR_IF(!half_is_finite(s[a]), StatusCode::kCorruptData,
                        gaussian(index) + "scale component " + dec(static_cast<uint64_t>(a)) + " is " + num(v));
    // A log scale must stay finite once exponentiated (SPEC §4.5): f16 allows ln-values up to 65504.
    RGS_RETURN_ERROR_IF(encoding == ScaleEncoding::kLog && !std::isfinite(std::exp(v)), StatusCode::kCorruptData,
                        gaussian(index) + "log scale component " + dec(static_cast<uint64_t>(a)) + " is " + num(v) +
                            ", whose exp overflows float32");
    // Zero is legal in linear encoding: FP16 underflow of a scale below 2^-25 (SPEC §4.5).
    RGS_RETURN_ERROR_IF(encoding == ScaleEncoding::kLinear && v < 0.0f, StatusCode::kCorruptData,
                        gaussian(index) + "linear scale component " + dec(static_cast<uint64_t>(a)) + " is " +
                            num(v) + ", negative");
  }
  return Status();
}

Status check_opacity(uint16_t opacity, uint64_t index) {
  const float v = half_bits_to_float(opacity);
  RGS_RETURN_ERROR_IF(!(v >= 0.0f && v <= 1.0f), StatusCode::kCorruptData,
                      gaussian(index) + "opacity " + num(v) + " is outside [0, 1]");
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

}  // namespace detail

namespace {

using detail::dec;

/// Checks the values of whole records (one Gaussian each) of a runtime section's raw bytes.
class ValueChecker {
 public:
  ValueChecker(SectionId id, const SceneMetadata& metadata, size_t record_size)
      : id_(id), metadata_(metadata), record_size_(record_size) {}

  Status visit(const uint8_t* p, size_t records, uint64_t first) const {
    for (size_t j = 0; j < records; ++j, p += record_size_) {
      const uint64_t i = first + j;
      switch (id_) {
        case SectionId::kMeans: {
          const float xyz[3] = {detail::load_f32_le(p), detail::load_f32_le(p + 4), detail::load_f32_le(p + 8)};
          RGS_RETURN_IF_ERROR(detail::check_mean(xyz, i, metadata_.bounds));
          break;
        }
        case SectionId::kRotations: {
          const uint16_t q[4] = {detail::load_u16_le(p), detail::load_u16_le(p + 2), detail::load_u16_le(p + 4),
                                 detail::load_u16_le(p + 6)};
          RGS_RETURN_IF_ERROR(detail::check_rotation(q, i));
          break;
        }
        case SectionId::kScales: {
          const uint16_t s[3] = {detail::load_u16_le(p), detail::load_u16_le(p + 2), detail::load_u16_le(p + 4)};
          RGS_RETURN_IF_ERROR(detail::check_scale(s, i, metadata_.scale_encoding));
          break;
        }
        case SectionId::kOpacities: RGS_RETURN_IF_ERROR(detail::check_opacity(detail::load_u16_le(p), i)); break;
        case SectionId::kSh:
          RGS_RETURN_IF_ERROR(detail::check_sh(reinterpret_cast<const int8_t*>(p), record_size_, i));
          break;
        default: return Status();
      }
    }
    return Status();
  }

 private:
  SectionId id_;
  const SceneMetadata& metadata_;
  size_t record_size_;
};

/// Decodes a zstd section in bounded chunks of whole records, checking values as they come. A frame
/// error (corrupt block, content checksum) outranks a value error seen before it, since the values of a
/// corrupt frame mean nothing.
Status stream_zstd(const uint8_t* src, size_t stored_size, uint64_t raw_size, size_t record_size,
                   const ValueChecker* checker) {
  const size_t frame_size = ZSTD_findFrameCompressedSize(src, stored_size);
  if (ZSTD_isError(frame_size)) return detail::zstd_error_status(frame_size, "zstd frame");
  RGS_RETURN_ERROR_IF(frame_size != stored_size, StatusCode::kCorruptData,
                      "zstd frame is " + dec(frame_size) + " bytes but the section stores " + dec(stored_size) +
                          " (trailing data or a second frame)");
  std::unique_ptr<ZSTD_DCtx, size_t (*)(ZSTD_DCtx*)> dctx(ZSTD_createDCtx(), ZSTD_freeDCtx);
  RGS_RETURN_ERROR_IF(!dctx, StatusCode::kOutOfMemory, "cannot create a zstd decompression context");
  // At most 1 MiB of whole records, and no more records than raw_size claims (a section of a few KB needs no
  // 1 MiB buffer; a claim too small is caught below, when the frame decodes to more).
  const uint64_t records = std::min<uint64_t>(raw_size / record_size + (raw_size % record_size != 0),
                                              std::max<size_t>(1, (size_t{1} << 20) / record_size));
  const size_t chunk = record_size * static_cast<size_t>(std::max<uint64_t>(1, records));
  std::vector<uint8_t> buffer(chunk);
  ZSTD_inBuffer in{src, stored_size, 0};
  uint64_t total = 0, index = 0;
  size_t fill = 0;
  Status value_error;
  for (;;) {
    ZSTD_outBuffer out{buffer.data(), chunk, fill};
    const size_t ret = ZSTD_decompressStream(dctx.get(), &out, &in);
    if (ZSTD_isError(ret)) return detail::zstd_error_status(ret, "zstd frame");
    total += out.pos - fill;
    RGS_RETURN_ERROR_IF(total > raw_size, StatusCode::kCorruptData,
                        "zstd frame decodes to more than raw_size " + dec(raw_size) + " bytes");
    const size_t complete = out.pos / record_size * record_size;
    if (checker && value_error.ok() && complete > 0)
      value_error = checker->visit(buffer.data(), complete / record_size, index);
    index += complete / record_size;
    fill = out.pos - complete;
    if (fill > 0) std::memmove(buffer.data(), buffer.data() + complete, fill);
    if (ret == 0) break;
    RGS_RETURN_ERROR_IF(in.pos == in.size && out.pos < out.size, StatusCode::kCorruptData,
                        "zstd frame ends early after " + dec(total) + " of " + dec(raw_size) + " bytes");
  }
  RGS_RETURN_ERROR_IF(total != raw_size || fill != 0, StatusCode::kCorruptData,
                      "zstd frame decoded to " + dec(total) + " bytes, expected " + dec(raw_size));
  return value_error;
}

/// Whether `id` is one of the runtime sections, whose records the value rules check.
bool is_runtime_section(SectionId id) {
  return id == SectionId::kMeans || id == SectionId::kRotations || id == SectionId::kScales ||
         id == SectionId::kOpacities || id == SectionId::kSh;
}

/// The value rules on the raw bytes `data` of section `index` (raw_size bytes), record by record; ok for a
/// section that is not a runtime one. Errors name the file and the section.
Status check_raw_values(const RgsFile& file, size_t index, const uint8_t* data) {
  const SectionEntry& e = file.sections()[index];
  const size_t record_size = static_cast<size_t>(e.components) * element_type_size(e.element_type);
  if (!is_runtime_section(e.id) || record_size == 0 || e.raw_size == 0) return Status();
  const ValueChecker checker(e.id, file.metadata(), record_size);
  Status s = checker.visit(data, static_cast<size_t>(e.raw_size / record_size), 0);
  if (!s.ok()) s.prepend(file.name() + ": " + detail::section_label(index, e.id));
  return s;
}

Status validate_section(const RgsFile& file, size_t index) {
  const SectionEntry& e = file.sections()[index];
  RGS_ASSIGN_OR_RETURN(ByteView stored, file.stored_bytes(e.id));  // message names the file
  const bool archive = is_archive_codec(e.codec);
  if (e.codec != Codec::kNone && e.codec != Codec::kZstd && !archive) return Status();  // unknown section and codec
  if (e.codec == Codec::kNone) return check_raw_values(file, index, stored.data);
  if (archive) {
    // §3.3 Archive sections decode whole (their raw size is bounded by the read limits at open), then
    // their values are checked like any runtime section's.
    std::vector<uint8_t> raw(static_cast<size_t>(e.raw_size));
    return file.decode_verified_section(e.id, raw.data(), raw.size());
  }
  // zstd: runtime sections are checked one Gaussian (record) at a time as the frame streams; others only decode.
  const bool runtime = is_runtime_section(e.id);
  const size_t record_size =
      runtime ? static_cast<size_t>(e.components) * element_type_size(e.element_type) : size_t{1};
  const ValueChecker checker(e.id, file.metadata(), record_size);
  const ValueChecker* active = runtime && record_size > 0 ? &checker : nullptr;
  Status s = stream_zstd(stored.data, stored.size, e.raw_size, record_size > 0 ? record_size : 1, active);
  if (!s.ok()) s.prepend(file.name() + ": " + detail::section_label(index, e.id));
  return s;
}

}  // namespace

Status RgsFile::decode_verified_section(SectionId id, void* dst, size_t dst_size) const {
  RGS_RETURN_IF_ERROR(decode_section(id, dst, dst_size));  // names the file and the section
  const size_t index = static_cast<size_t>(find(id) - sections_.data());
  return check_raw_values(*this, index, static_cast<const uint8_t*>(dst));
}

Status RgsFile::verify_section(SectionId id) const {
  const SectionEntry* e = find(id);
  RGS_RETURN_ERROR_IF(e == nullptr, StatusCode::kInvalidArgument,
                      name_ + ": no section " + section_name(id) + " (id " + dec(static_cast<uint32_t>(id)) + ")");
  try {
    return validate_section(*this, static_cast<size_t>(e - sections_.data()));
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, name_ + ": out of memory checking " + section_name(id));
  }
}

Status validate(const uint8_t* data, size_t size, const ReadLimits& limits, const std::string& name) {
  try {
    ReadOptions options;
    options.limits = limits;
    options.verify_checksums = true;
    RGS_ASSIGN_OR_RETURN(RgsFile file, RgsFile::from_bytes(data, size, options, name));
    for (size_t i = 0; i < file.sections().size(); ++i) RGS_RETURN_IF_ERROR(validate_section(file, i));
    return Status();
  } catch (const std::bad_alloc&) {
    return Status(StatusCode::kOutOfMemory, name + ": out of memory validating the file");
  }
}

}  // namespace rgs::format
