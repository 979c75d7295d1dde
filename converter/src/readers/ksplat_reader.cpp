// .ksplat reader: GaussianSplats3D's SplatBuffer (header, section headers, bucketed sections of records).
#include "rgs/converter/ksplat_reader.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "../internal_interop.h"
#include "rgs/format/half.h"

namespace rgs::converter {

namespace {

using format::load_f32_le;
using format::load_u16_le;
using format::load_u32_le;

/// What SplatBuffer.js reads for a zero in the header's SH range (Constants.SphericalHarmonics8BitCompressionRange / 2)
/// and in a section's position range (CompressionLevels[1 or 2].ScaleRange).
constexpr float kDefaultShHalfRange = 1.5f;
constexpr uint32_t kDefaultPositionRange = 32767;

/// One section as its header declares it, with the byte offsets its sizes imply.
struct Section {
  uint64_t count = 0, bucket_size = 0, buckets = 0, full_buckets = 0, partial_buckets = 0;
  uint32_t sh_degree = 0, position_range = 0;
  float block_size = 0;
  uint64_t base = 0, record_bytes = 0, centres = 0, records = 0, end = 0;
};

/// Bytes of one Gaussian: 44 (level 0) or 24, then 3 × ((degree + 1)² − 1) SH rest values of 4, 2 or 1 bytes.
uint64_t record_bytes(uint32_t level, uint32_t degree) {
  const uint64_t rest = 3 * (uint64_t{degree + 1} * (degree + 1) - 1);
  return level == 0 ? 44 + 4 * rest : 24 + (level == 1 ? 2 : 1) * rest;
}

std::string section_error(size_t s, const std::string& what) { return "section " + std::to_string(s) + ": " + what; }

/// Reads and checks the section headers against each other and the file size; nothing is allocated from a count
/// before the bytes holding that many Gaussians are known to be in the file.
Status parse_sections(const uint8_t* d, uint64_t size, uint32_t level, uint64_t count, std::vector<Section>* out) {
  uint64_t base = kKsplatHeaderBytes + count * kKsplatSectionHeaderBytes;
  RGS_RETURN_ERROR_IF(base > size, StatusCode::kCorruptData,
                      std::to_string(count) + " section headers end at byte " + std::to_string(base) +
                          " but the file has " + std::to_string(size) + " bytes");
  out->resize(count);
  for (size_t s = 0; s < count; ++s) {
    const uint8_t* h = d + kKsplatHeaderBytes + s * kKsplatSectionHeaderBytes;
    Section& c = (*out)[s];
    c.count = load_u32_le(h + 4);
    c.bucket_size = load_u32_le(h + 8);
    c.buckets = load_u32_le(h + 12);
    c.block_size = load_f32_le(h + 16);
    const uint64_t bucket_bytes = load_u16_le(h + 20);
    c.position_range = load_u32_le(h + 24) != 0 ? load_u32_le(h + 24) : kDefaultPositionRange;
    c.full_buckets = load_u32_le(h + 32);
    c.partial_buckets = load_u32_le(h + 36);
    c.sh_degree = load_u16_le(h + 40);
    RGS_RETURN_ERROR_IF(load_u32_le(h) != c.count, StatusCode::kCorruptData,
                        section_error(s, std::to_string(load_u32_le(h)) + " of " + std::to_string(c.count) +
                                             " Gaussians loaded (a partially written file)"));
    RGS_RETURN_ERROR_IF(c.sh_degree > 3, StatusCode::kUnsupportedFeature,
                        section_error(s, "SH degree " + std::to_string(c.sh_degree) + " (0..3 are read)"));
    c.record_bytes = record_bytes(level, c.sh_degree);
    // Every product of two u32 fields (or a u16 and a u32) fits in 64 bits, and so do their sums. The section's
    // byte count at 28 is not read, as in the JS: the counts decide, and the last section must end at the end.
    c.base = base;
    c.centres = base + 4 * c.partial_buckets;
    c.records = c.centres + bucket_bytes * c.buckets;
    c.end = c.records + c.record_bytes * c.count;
    RGS_RETURN_ERROR_IF(c.end > size, StatusCode::kCorruptData,
                        section_error(s, "ends at byte " + std::to_string(c.end) + " but the file has " +
                                             std::to_string(size) + " bytes"));
    if (level > 0) {
      RGS_RETURN_ERROR_IF(bucket_bytes != 12, StatusCode::kCorruptData,
                          section_error(s, std::to_string(bucket_bytes) + " bytes per bucket centre (12 expected)"));
      RGS_RETURN_ERROR_IF(c.full_buckets + c.partial_buckets != c.buckets, StatusCode::kCorruptData,
                          section_error(s, std::to_string(c.full_buckets) + " full and " +
                                               std::to_string(c.partial_buckets) + " partially filled buckets, but " +
                                               std::to_string(c.buckets) + " buckets"));
      RGS_RETURN_ERROR_IF(!(std::isfinite(c.block_size) && c.block_size > 0), StatusCode::kCorruptData,
                          section_error(s, "bucket block size " + std::to_string(c.block_size) + " (> 0 expected)"));
      uint64_t held = c.full_buckets * c.bucket_size;  // stops past the count: no sum wraps around
      for (uint64_t b = 0; b < c.partial_buckets && held <= c.count; ++b) held += load_u32_le(d + c.base + 4 * b);
      RGS_RETURN_ERROR_IF(held != c.count, StatusCode::kCorruptData,
                          section_error(s, "its buckets hold " + std::to_string(held) + " Gaussians, not " +
                                               std::to_string(c.count)));
    }
    base = c.end;
  }
  RGS_RETURN_ERROR_IF(base != size, StatusCode::kCorruptData,
                      "the sections end at byte " + std::to_string(base) + " but the file has " +
                          std::to_string(size) + " bytes");
  return Status();
}

/// Decodes the section's Gaussians into `cloud` from index `first`. SH values of a band the section lacks stay 0.
void decode_section(const uint8_t* d, const Section& c, uint32_t level, const float sh_range[2],
                    format::GaussianCloud* cloud, uint64_t first) {
  const uint32_t k_cloud = cloud->sh_coefficients();
  // Float arithmetic: a huge block size or centre overflows to inf (refused as non-finite), never out of range.
  const float range = static_cast<float>(c.position_range), step = c.block_size / 2.0f / range;
  auto value = [level](const uint8_t* p, uint64_t i) -> float {  // float i of a record part at p
    return level == 0 ? load_f32_le(p + 4 * i) : format::half_bits_to_float(load_u16_le(p + 2 * i));
  };
  uint64_t j = 0;
  const uint64_t bucket_count = level == 0 ? 1 : c.buckets;
  for (uint64_t b = 0; b < bucket_count; ++b) {
    const uint64_t length = level == 0 ? c.count
                            : b < c.full_buckets ? c.bucket_size
                                                 : load_u32_le(d + c.base + 4 * (b - c.full_buckets));
    for (uint64_t e = 0; e < length; ++e, ++j) {
      const uint8_t* r = d + c.records + j * c.record_bytes;
      const uint64_t i = first + j;
      const uint8_t* part = r + (level == 0 ? 12 : 6);
      for (int a = 0; a < 3; ++a) {
        const float offset = (load_u16_le(r + 2 * a) - range) * step;  // levels 1-2
        cloud->means[i * 3 + a] =
            level == 0 ? load_f32_le(r + 4 * a) : offset + load_f32_le(d + c.centres + 12 * b + 4 * a);
        cloud->scales[i * 3 + a] = value(part, a);
      }
      for (int a = 0; a < 4; ++a) cloud->rotations[i * 4 + a] = value(part, 3 + a);
      const uint8_t* rgba = part + (level == 0 ? 28 : 14);
      for (int ch = 0; ch < 3; ++ch) {
        cloud->sh[i * k_cloud * 3 + ch] = static_cast<float>((rgba[ch] / 255.0 - 0.5) / detail::kShC0);
      }
      cloud->opacities[i] = rgba[3] / 255.0f;
      const uint8_t* sh = rgba + 4;
      uint64_t v = 0;  // index of the stored value: band after band, channel after channel
      for (uint32_t band = 1; band <= c.sh_degree; ++band) {
        for (int ch = 0; ch < 3; ++ch) {
          for (uint32_t m = 0; m < 2 * band + 1; ++m, ++v) {
            const float x = level < 2 ? value(sh, v) : sh_range[0] + sh[v] / 255.0f * (sh_range[1] - sh_range[0]);
            cloud->sh[(i * k_cloud + band * band + m) * 3 + ch] = x;
          }
        }
      }
    }
  }
}

/// The file's header and sections, checked (parse_sections) and added up: what read_buffer allocates for.
struct Layout {
  uint32_t level = 0, sh_degree = 0;
  uint64_t total = 0;
  float sh_range[2] = {0, 0};
  std::vector<Section> sections;
};

Status parse_layout(const uint8_t* d, uint64_t size, const InteropReadOptions& options, Layout* out) {
  RGS_RETURN_ERROR_IF(size < kKsplatHeaderBytes, StatusCode::kCorruptData,
                      std::to_string(size) + " bytes, less than the " + std::to_string(kKsplatHeaderBytes) +
                          "-byte header");
  RGS_RETURN_ERROR_IF(d[0] != 0 || d[1] != 1, StatusCode::kUnsupportedVersion,
                      "version " + std::to_string(d[0]) + "." + std::to_string(d[1]) + " (0.1 is read)");
  out->level = load_u16_le(d + 20);
  RGS_RETURN_ERROR_IF(out->level > 2, StatusCode::kUnsupportedFeature,
                      "compression level " + std::to_string(out->level) + " (0..2 are read)");
  const uint64_t sections = load_u32_le(d + 4), declared = load_u32_le(d + 12);
  RGS_RETURN_ERROR_IF(load_u32_le(d + 8) != sections || load_u32_le(d + 16) != declared, StatusCode::kCorruptData,
                      std::to_string(load_u32_le(d + 8)) + " of " + std::to_string(sections) + " sections and " +
                          std::to_string(load_u32_le(d + 16)) + " of " + std::to_string(declared) +
                          " Gaussians loaded (a partially written file)");
  RGS_RETURN_IF_ERROR(parse_sections(d, size, out->level, sections, &out->sections));
  for (const Section& c : out->sections) {
    out->total += c.count;
    out->sh_degree = std::max(out->sh_degree, c.sh_degree);
  }
  RGS_RETURN_ERROR_IF(out->total != declared, StatusCode::kCorruptData,
                      "the header declares " + std::to_string(declared) + " Gaussians, its sections hold " +
                          std::to_string(out->total));
  RGS_RETURN_IF_ERROR(detail::check_limit("the file holds ", out->total, "Gaussians", options.max_gaussians));
  const float lo = load_f32_le(d + 36), hi = load_f32_le(d + 40);  // JS `x || default`: 0 and NaN take the default
  out->sh_range[0] = lo != 0 && !std::isnan(lo) ? lo : -kDefaultShHalfRange;
  out->sh_range[1] = hi != 0 && !std::isnan(hi) ? hi : kDefaultShHalfRange;
  return Status();
}

Result<InteropScene> read_buffer(const uint8_t* d, uint64_t size, const InteropReadOptions& options) {
  Layout layout;
  Status parsed = parse_layout(d, size, options, &layout);
  if (!parsed.ok()) return parsed.prepend("GaussianSplats3D .ksplat");
  InteropScene scene = detail::rdf_interop_scene("ksplat", size, layout.total, layout.sh_degree, options);
  format::GaussianCloud& cloud = scene.cloud;
  uint64_t first = 0;
  for (const Section& c : layout.sections) {
    decode_section(d, c, layout.level, layout.sh_range, &cloud, first);
    first += c.count;
  }
  RGS_RETURN_IF_ERROR(detail::finish_splat_scene("GaussianSplats3D .ksplat", options, &scene));
  const char* stored[] = {"float32", "float16 with positions as 16-bit offsets from bucket centres",
                          "float16 with positions as 16-bit offsets from bucket centres, SH rest as 8 bits"};
  scene.notes.push_back(".ksplat compression level " + std::to_string(layout.level) + ": " + stored[layout.level] +
                        "; colours and opacity as 8 bits");
  return scene;
}

}  // namespace

bool looks_like_ksplat(const uint8_t* head, size_t n, uint64_t file_size) {
  if (head == nullptr || n < 24 || file_size < kKsplatHeaderBytes) return false;
  const bool version_0_1 = head[0] == 0 && head[1] == 1 && head[2] == 0 && head[3] == 0;
  return version_0_1 && load_u16_le(head + 20) <= 2 && load_u16_le(head + 22) == 0 &&
         kKsplatHeaderBytes + uint64_t{load_u32_le(head + 4)} * kKsplatSectionHeaderBytes <= file_size;
}

Result<InteropScene> read_ksplat(const std::string& path, const InteropReadOptions& options) {
  RGS_ASSIGN_OR_RETURN(auto file, format::MappedFile::open(path));  // its errors name the path
  return read_ksplat_bytes(file->data(), file->size(), path, options);
}

Result<InteropScene> read_ksplat_bytes(const uint8_t* data, size_t size, const std::string& name,
                                       const InteropReadOptions& options) {
  return detail::guarded_bytes<InteropScene>(data, size, name, "decoding the .ksplat file",
                                             [&] { return read_buffer(data, size, options); });
}

}  // namespace rgs::converter
