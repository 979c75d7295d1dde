// Decoders of the archive codecs: Draco means (SPEC §3.3.1) and quantized sections (§3.3.2).
#include <zstd.h>

#include <cmath>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

#include <draco/compression/decode.h>
#include <draco/core/decoder_buffer.h>
#include <draco/point_cloud/point_cloud.h>

#include "internal_archive.h"
#include "internal_bytes.h"
#include "internal_sections.h"
#include "internal_xz.h"
#include "rgs/format/encoded_scene.h"
#include "rgs/format/gaussian_cloud.h"
#include "rgs/format/half.h"

namespace rgs::format::detail {

namespace {

/// §3.3.1 Draco bitstream header: "DRACO", version 2.3, encoder type 0 (point cloud), method 1 (kd-tree),
/// flags u16 (0: no metadata), then the kd-tree geometry starts with an int32 point count.
constexpr uint8_t kDracoMagic[5] = {'D', 'R', 'A', 'C', 'O'};
constexpr size_t kDracoHeaderSize = 11;

uint32_t code_width(uint32_t bits) { return (bits + 7) / 8; }

/// Expected transform, component count and parameter count of a quantized section (§3.3.2 table).
bool quantized_layout(SectionId id, uint32_t components, QuantizedTransform* transform, uint32_t* params) {
  switch (id) {
    case SectionId::kRotations: *transform = QuantizedTransform::kSmallestThree; *params = 0; return components == 4;
    case SectionId::kScales: *transform = QuantizedTransform::kLogUniform; *params = 6; return components == 3;
    case SectionId::kOpacities: *transform = QuantizedTransform::kUniform; *params = 0; return components == 1;
    case SectionId::kSh: *transform = QuantizedTransform::kShMultiplier; *params = 4; return components % 3 == 0;
    default: return false;
  }
}

uint32_t read_code(const uint8_t* plane, uint32_t width, uint64_t n, uint64_t i) {
  uint32_t code = 0;
  for (uint32_t b = 0; b < width; ++b) code |= static_cast<uint32_t>(plane[b * n + i]) << (8 * b);
  return code;
}

}  // namespace

bool archive_codec_allowed(SectionId id, Codec codec) {
  if (codec == Codec::kDraco) return id == SectionId::kMeans;
  if (codec == Codec::kQuantized) {
    return id == SectionId::kRotations || id == SectionId::kScales || id == SectionId::kOpacities ||
           id == SectionId::kSh;
  }
  return false;
}

Status check_draco_header(const uint8_t* src, size_t size, uint64_t n) {
  RGS_RETURN_ERROR_IF(size < kDracoHeaderSize + 4, StatusCode::kCorruptData,
                      "Draco stream of " + dec(size) + " bytes is shorter than its " + dec(kDracoHeaderSize + 4) +
                          "-byte header");
  RGS_RETURN_ERROR_IF(std::memcmp(src, kDracoMagic, 5) != 0, StatusCode::kCorruptData,
                      "Draco stream does not start with \"DRACO\"");
  RGS_RETURN_ERROR_IF(src[5] != 2 || src[6] != 3, StatusCode::kCorruptData,
                      "Draco bitstream version " + dec(src[5]) + "." + dec(src[6]) + ", expected 2.3");
  RGS_RETURN_ERROR_IF(src[7] != 0 || src[8] != 1, StatusCode::kCorruptData,
                      "Draco encoder type " + dec(src[7]) + " method " + dec(src[8]) +
                          ", expected a kd-tree point cloud (0, 1)");
  const uint16_t flags = load_u16_le(src + 9);
  RGS_RETURN_ERROR_IF(flags != 0, StatusCode::kCorruptData, "Draco header flags " + dec(flags) + ", expected 0");
  const uint32_t points = load_u32_le(src + kDracoHeaderSize);
  RGS_RETURN_ERROR_IF(points != n, StatusCode::kCorruptData,
                      "Draco stream holds " + dec(points) + " points, expected " + dec(n));
  return Status();
}

Status decode_draco_means(const uint8_t* src, size_t size, uint64_t n, uint8_t* dst, size_t raw_size) {
  RGS_RETURN_ERROR_IF(raw_size != n * 12, StatusCode::kInvalidArgument,
                      "means buffer of " + dec(raw_size) + " bytes for " + dec(n) + " Gaussians");
  // The point count is checked before Draco allocates anything from it.
  RGS_RETURN_IF_ERROR(check_draco_header(src, size, n));
  return catch_bad_alloc([&]() -> Status {
    draco::DecoderBuffer buffer;
    buffer.Init(reinterpret_cast<const char*>(src), size);
    draco::Decoder decoder;
    auto decoded = decoder.DecodePointCloudFromBuffer(&buffer);
    RGS_RETURN_ERROR_IF(!decoded.ok(), StatusCode::kCorruptData,
                        "Draco refuses the stream: " + decoded.status().error_msg_string());
    const std::unique_ptr<draco::PointCloud> pc = std::move(decoded).value();
    RGS_RETURN_ERROR_IF(pc->num_points() != n, StatusCode::kCorruptData,
                        "Draco decoded " + dec(pc->num_points()) + " points, expected " + dec(n));
    RGS_RETURN_ERROR_IF(pc->num_attributes() != 1, StatusCode::kCorruptData,
                        "Draco stream has " + dec(static_cast<uint64_t>(pc->num_attributes())) +
                            " attributes, expected 1 (positions)");
    const draco::PointAttribute* att = pc->GetNamedAttribute(draco::GeometryAttribute::POSITION);
    RGS_RETURN_ERROR_IF(att == nullptr || att->num_components() != 3, StatusCode::kCorruptData,
                        "Draco stream has no 3-component position attribute");
    for (uint64_t i = 0; i < n; ++i) {
      float xyz[3];
      const draco::AttributeValueIndex value = att->mapped_index(draco::PointIndex(static_cast<uint32_t>(i)));
      const bool converted = att->ConvertValue<float, 3>(value, xyz);
      RGS_RETURN_ERROR_IF(!converted, StatusCode::kCorruptData,
                          "Draco position " + dec(i) + " cannot be read as float32");
      for (int a = 0; a < 3; ++a) store_f32_le(dst + i * 12 + a * 4, xyz[a]);
    }
    return Status();
  }, [&] { return "out of memory decoding " + dec(n) + " Draco positions"; });
}

namespace {

struct QuantizedHeader {
  QuantizedTransform transform{};
  uint32_t bits = 0;
  uint32_t components = 0;
  float params[6] = {};
  uint32_t param_count = 0;
  const uint8_t* frame = nullptr;
  size_t frame_size = 0;
  uint64_t codes_size = 0;     ///< decoded frame size: n x components x code width (codebook: §3.3.3)
  uint64_t codebook_size = 0;  ///< K, transform 5 only
  bool xz = false;             ///< the codes are an .xz stream (1.5), not a zstd frame
};

Status parse_quantized(SectionId id, const uint8_t* src, size_t size, uint64_t n, uint32_t components,
                       QuantizedHeader* h) {
  RGS_RETURN_ERROR_IF(size < kQuantizedHeaderSize, StatusCode::kCorruptData,
                      "quantized section of " + dec(size) + " bytes is shorter than its 8-byte header");
  QuantizedTransform want{};
  uint32_t want_params = 0;
  if (!quantized_layout(id, components, &want, &want_params)) {
    return Status(StatusCode::kCorruptData, "the quantized codec does not apply to " + dec(components) +
                                                "-component section " + section_name(id));
  }
  h->transform = static_cast<QuantizedTransform>(src[0]);
  h->bits = src[1];
  h->param_count = load_u16_le(src + 2);
  h->components = load_u32_le(src + 4);
  // §3.3.2 The sh section takes transform 4, the colour differences of transform 6 (same codes, same
  // parameters) or the codebook transform 5 (§3.3.3, degree >= 1).
  const bool codebook = id == SectionId::kSh && h->transform == QuantizedTransform::kShCodebook;
  if (id == SectionId::kSh && h->transform == QuantizedTransform::kShColourDifferences) {
    want = QuantizedTransform::kShColourDifferences;
  }
  if (codebook) {
    want = QuantizedTransform::kShCodebook;
    want_params = 4;
    RGS_RETURN_ERROR_IF(components < 12, StatusCode::kCorruptData,
                        "SH codebook transform on a " + dec(components) + "-value section (needs SH degree >= 1)");
  }
  RGS_RETURN_ERROR_IF(h->transform != want, StatusCode::kCorruptData,
                      "quantized transform " + dec(src[0]) + ", expected " + dec(static_cast<uint8_t>(want)) +
                          (id == SectionId::kSh ? ", 5 or 6" : "") + " for section " + section_name(id));
  const bool sh = want == QuantizedTransform::kShMultiplier || want == QuantizedTransform::kShColourDifferences;
  if (codebook) {
    RGS_RETURN_ERROR_IF(h->bits < 1 || h->bits > 24, StatusCode::kCorruptData,
                        "SH codebook index bits " + dec(h->bits) + " outside 1..24");
  } else {
    RGS_RETURN_ERROR_IF(sh ? h->bits != 8 : (h->bits < 4 || h->bits > 16), StatusCode::kCorruptData,
                        "quantized code bits " + dec(h->bits) + " outside " + (sh ? "8..8" : "4..16"));
  }
  RGS_RETURN_ERROR_IF(h->param_count != want_params, StatusCode::kCorruptData,
                      "quantized parameter count " + dec(h->param_count) + ", expected " + dec(want_params));
  RGS_RETURN_ERROR_IF(h->components != components, StatusCode::kCorruptData,
                      "quantized component count " + dec(h->components) + ", expected " + dec(components));
  const size_t header = quantized_header_bytes(h->param_count, codebook);
  RGS_RETURN_ERROR_IF(size < header, StatusCode::kCorruptData,
                      "quantized section of " + dec(size) + " bytes is shorter than its " + dec(header) +
                          "-byte header");
  for (uint32_t p = 0; p < h->param_count; ++p) {
    h->params[p] = load_f32_le(src + kQuantizedHeaderSize + 4 * p);
    RGS_RETURN_ERROR_IF(!std::isfinite(h->params[p]), StatusCode::kCorruptData,
                        "quantized parameter " + dec(p) + " is not finite");
  }
  if (want == QuantizedTransform::kLogUniform) {
    for (int a = 0; a < 3; ++a) {
      RGS_RETURN_ERROR_IF(!(h->params[3 + a] >= 0.0f), StatusCode::kCorruptData,
                          "log-scale step " + dec(a) + " is negative");
    }
  }
  if (codebook) {
    h->codebook_size = load_u32_le(src + kQuantizedHeaderSize + 4 * size_t{h->param_count});
    RGS_RETURN_ERROR_IF(h->codebook_size < 1 || h->codebook_size > (uint64_t{1} << h->bits) ||
                            h->codebook_size > n,
                        StatusCode::kCorruptData,
                        "SH codebook of " + dec(h->codebook_size) + " entries: expected 1..min(2^" + dec(h->bits) +
                            ", N = " + dec(n) + ")");
  }
  if (sh || codebook) {
    for (int d = 0; d < 4; ++d) {
      const float m = h->params[d];
      RGS_RETURN_ERROR_IF(!(m >= 1.0f && m <= 127.0f && m == std::floor(m)), StatusCode::kCorruptData,
                          "SH step multiplier of degree " + dec(d) + " is not an integer in 1..127");
    }
  }
  uint64_t codes = 0;
  bool fits = false;
  if (codebook) {
    // K entries of C - 3 rest codes, N x 3 DC codes, N indices of w bytes. K <= N and C >= 12, so this
    // is at most N x (C + 3) <= 1.25 x the raw size (§3.3.4).
    uint64_t entries = 0, per_gaussian = 3 + code_width(h->bits);
    fits = checked_mul(h->codebook_size, components - 3, &entries) && checked_mul(n, per_gaussian, &codes) &&
           checked_add(codes, entries, &codes);
  } else {
    fits = checked_mul(n, components, &codes) && checked_mul(codes, code_width(h->bits), &codes);
  }
  RGS_RETURN_ERROR_IF(!fits, StatusCode::kCorruptData, "quantized code size overflows 64 bits");
  h->codes_size = codes;
  h->frame = src + header;
  h->frame_size = size - header;
  h->xz = is_xz_stream(h->frame, h->frame_size);
  Status s = h->xz ? check_xz_stream(h->frame, h->frame_size, codes)
                   : check_zstd_frame_header(h->frame, h->frame_size, codes);
  return s.ok() ? s : s.prepend("codes");
}

}  // namespace

Status check_quantized_header(SectionId id, const uint8_t* src, size_t size, uint64_t n, uint32_t components,
                              bool* xz) {
  QuantizedHeader h;
  RGS_RETURN_IF_ERROR(parse_quantized(id, src, size, n, components, &h));
  if (xz != nullptr) *xz = h.xz;
  return Status();
}

bool quantized_codes_are_xz(const uint8_t* src, size_t size) {
  if (size < kQuantizedHeaderSize) return false;
  const bool codebook = src[0] == static_cast<uint8_t>(QuantizedTransform::kShCodebook);
  const size_t header = quantized_header_bytes(load_u16_le(src + 2), codebook);
  return size >= header && is_xz_stream(src + header, size - header);
}

namespace {

/// A quantized section's codes after its frame is decoded, with the header that says how to read them.
struct QuantizedCodes {
  const QuantizedHeader& h;
  std::vector<uint8_t> codes;
  uint64_t n;
  uint32_t width;     ///< Bytes per code in the planar transforms.
  uint32_t max_code;  ///< 2^bits - 1.

  /// Code of component `c` of Gaussian `i` in the planar layout (one byte plane per code byte).
  uint32_t at(uint32_t c, uint64_t i) const { return read_code(codes.data() + c * n * width, width, n, i); }
};

Status bad_code(uint64_t i, uint32_t c, uint32_t code) {
  return Status(StatusCode::kCorruptData,
                "Gaussian " + dec(i) + ": code " + dec(code) + " of component " + dec(c) + " is out of range");
}

/// SH value `code` (an int8) times the multiplier `m` into *out; false when it leaves [-127, 127].
bool sh_value(uint8_t code, int m, uint8_t* out) {
  const int value = static_cast<int8_t>(code) * m;
  *out = static_cast<uint8_t>(static_cast<int8_t>(value));
  return value >= -127 && value <= 127;
}

/// Transform 1: rotations as the smallest three quaternion components, into [N, 4] float16.
Status decode_smallest_three(const QuantizedCodes& q, uint8_t* dst) {
  const uint64_t n = q.n;
  const double scale = std::sqrt(2.0) / q.max_code, lo = -std::sqrt(0.5);
  for (uint64_t i = 0; i < n; ++i) {
    const uint32_t largest = q.at(0, i);
    if (largest > 3) return bad_code(i, 0, largest);
    double quat[4];
    double sum = 0;
    for (uint32_t c = 1, slot = 0; c < 4; ++c, ++slot) {
      if (slot == largest) ++slot;
      const uint32_t code = q.at(c, i);
      if (code > q.max_code) return bad_code(i, c, code);
      quat[slot] = lo + code * scale;
      sum += quat[slot] * quat[slot];
    }
    quat[largest] = std::sqrt(std::max(0.0, 1.0 - sum));
    for (int a = 0; a < 4; ++a) store_u16_le(dst + i * 8 + a * 2, float_to_half_bits(static_cast<float>(quat[a])));
  }
  return Status();
}

/// Transform 2: scales uniform in log space, into [N, 3] float16 in the scene's scale encoding.
Status decode_log_uniform(const QuantizedCodes& q, ScaleEncoding encoding, uint8_t* dst) {
  const uint64_t n = q.n;
  const uint32_t max_code = q.max_code;
  const bool log = encoding == ScaleEncoding::kLog;
  auto scale_of = [&](uint32_t a, uint32_t code) {
    const double v = static_cast<double>(q.h.params[a]) + code * static_cast<double>(q.h.params[3 + a]);
    return float_to_half_bits(static_cast<float>(log ? v : std::exp(v)));
  };
  // With more Gaussians than codes, each code's scale is computed once per axis.
  const uint64_t codes_per_axis = uint64_t{max_code} + 1;
  std::vector<uint16_t> table;
  if (n > codes_per_axis) {
    table.resize(3 * codes_per_axis);
    for (uint32_t a = 0; a < 3; ++a) {
      for (uint32_t code = 0; code <= max_code; ++code) table[a * codes_per_axis + code] = scale_of(a, code);
    }
  }
  for (uint64_t i = 0; i < n; ++i) {
    for (uint32_t a = 0; a < 3; ++a) {
      const uint32_t code = q.at(a, i);
      if (code > max_code) return bad_code(i, a, code);
      store_u16_le(dst + i * 6 + a * 2, table.empty() ? scale_of(a, code) : table[a * codes_per_axis + code]);
    }
  }
  return Status();
}

/// Transform 3: opacities uniform in [0, 1], into [N] float16.
Status decode_uniform(const QuantizedCodes& q, uint8_t* dst) {
  for (uint64_t i = 0; i < q.n; ++i) {
    const uint32_t code = q.at(0, i);
    if (code > q.max_code) return bad_code(i, 0, code);
    store_u16_le(dst + i * 2, float_to_half_bits(static_cast<float>(static_cast<double>(code) / q.max_code)));
  }
  return Status();
}

/// Transform 4: SH int8 codes times a per-degree multiplier, into [N, components] int8.
Status decode_sh_multiplier(const QuantizedCodes& q, uint32_t components, uint8_t* dst) {
  const uint64_t n = q.n;
  for (uint32_t c = 0; c < components; ++c) {
    const int m = static_cast<int>(q.h.params[sh_degree_of_coefficient(c / 3)]);
    // Gaussian-major records, unlike the planes of the other transforms.
    for (uint64_t i = 0; i < n; ++i) {
      const uint8_t code = q.codes[i * components + c];
      if (!sh_value(code, m, &dst[i * components + c])) return bad_code(i, c, code);
    }
  }
  return Status();
}

/// Transform 6: SH colour differences, into [N, components] int8.
Status decode_sh_colour_differences(const QuantizedCodes& q, uint32_t components, uint8_t* dst) {
  const uint64_t n = q.n;
  // The DC triples as three planes of N, then N records of the rest triples; each triple holds
  // (R - G, G, B - G) modulo 256, so R = (R - G) + G modulo 256, read as int8.
  const uint8_t* rest = q.codes.data() + 3 * n;
  const uint32_t rest_values = components - 3;
  for (uint64_t i = 0; i < n; ++i) {
    for (uint32_t c = 0; c < components; c += 3) {
      uint8_t triple[3];
      for (uint32_t k = 0; k < 3; ++k) triple[k] = c == 0 ? q.codes[k * n + i] : rest[i * rest_values + c - 3 + k];
      const uint8_t green = triple[1];
      const uint8_t rgb[3] = {static_cast<uint8_t>(triple[0] + green), green, static_cast<uint8_t>(triple[2] + green)};
      const int m = static_cast<int>(q.h.params[sh_degree_of_coefficient(c / 3)]);
      for (uint32_t k = 0; k < 3; ++k) {
        if (!sh_value(rgb[k], m, &dst[i * components + c + k])) return bad_code(i, c + k, rgb[k]);
      }
    }
  }
  return Status();
}

/// Transform 5: SH rest coefficients through a codebook, DC as transform 4, into [N, components] int8. The
/// codebook entries decode in place of their codes in `q`.
Status decode_sh_codebook(QuantizedCodes& q, uint32_t components, uint8_t* dst) {
  const uint64_t n = q.n;
  const uint32_t rest = components - 3;
  const uint64_t k = q.h.codebook_size;
  const uint8_t* entries = q.codes.data();
  const uint8_t* dc = entries + k * rest;
  const uint8_t* index = dc + n * 3;
  // Entries decode in place of their codes: value = code x m[deg] (checked like transform 4's codes).
  std::vector<uint8_t>& book = q.codes;
  for (uint64_t e = 0; e < k * rest; ++e) {
    const uint32_t j = static_cast<uint32_t>(e % rest);
    const uint8_t code = book[e];
    if (!sh_value(code, static_cast<int>(q.h.params[sh_degree_of_coefficient(1 + j / 3)]), &book[e])) {
      return Status(StatusCode::kCorruptData, "SH codebook entry " + dec(e / rest) + ": code " +
                                                  std::to_string(static_cast<int8_t>(code)) + " of value " +
                                                  dec(j) + " is out of range");
    }
  }
  const int m = static_cast<int>(q.h.params[0]);
  for (uint64_t i = 0; i < n; ++i) {
    for (uint32_t c = 0; c < 3; ++c) {
      const uint8_t code = dc[i * 3 + c];
      if (!sh_value(code, m, &dst[i * components + c])) return bad_code(i, c, code);
    }
    const uint32_t e = read_code(index, q.width, n, i);
    if (e >= k) {
      return Status(StatusCode::kCorruptData, "Gaussian " + dec(i) + ": SH codebook index " + dec(e) +
                                                  " >= codebook size " + dec(k));
    }
    std::memcpy(dst + i * components + 3, entries + uint64_t{e} * rest, rest);
  }
  return Status();
}

}  // namespace

Status decode_quantized(SectionId id, const SceneMetadata& metadata, const uint8_t* src, size_t size, uint64_t n,
                        uint32_t components, uint8_t* dst, size_t raw_size) {
  QuantizedHeader h;
  RGS_RETURN_IF_ERROR(parse_quantized(id, src, size, n, components, &h));
  // [N, components] of float16 (rotations, scales, opacities) or int8 (sh).
  const uint64_t element_bytes = id == SectionId::kSh ? 1 : 2;
  RGS_RETURN_ERROR_IF(raw_size != n * components * element_bytes, StatusCode::kInvalidArgument,
                      std::string(section_name(id)) + " buffer of " + dec(raw_size) + " bytes for " + dec(n) +
                          " Gaussians");
  QuantizedCodes q{h, {}, n, code_width(h.bits), (1u << h.bits) - 1};
  RGS_RETURN_IF_ERROR(catch_bad_alloc([&] { q.codes.resize(static_cast<size_t>(h.codes_size)); return Status(); },
                                      [&] { return "out of memory for " + dec(h.codes_size) + " bytes of codes"; }));
  {
    Status s = h.xz ? decode_xz_stream(h.frame, h.frame_size, q.codes.data(), q.codes.size())
                    : decode_zstd_frame(h.frame, h.frame_size, q.codes.data(), q.codes.size());
    if (!s.ok()) return s.prepend("codes");
  }
  switch (h.transform) {
    case QuantizedTransform::kSmallestThree: return decode_smallest_three(q, dst);
    case QuantizedTransform::kLogUniform: return decode_log_uniform(q, metadata.scale_encoding, dst);
    case QuantizedTransform::kUniform: return decode_uniform(q, dst);
    case QuantizedTransform::kShMultiplier: return decode_sh_multiplier(q, components, dst);
    case QuantizedTransform::kShColourDifferences: return decode_sh_colour_differences(q, components, dst);
    case QuantizedTransform::kShCodebook: return decode_sh_codebook(q, components, dst);
  }
  return Status();
}

}  // namespace rgs::format::detail
