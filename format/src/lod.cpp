// The level-of-detail index (SPEC.md §4.9): its record, its structural rules and the checks of one range.
#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "internal_bytes.h"
#include "internal_lod.h"
#include "internal_sections.h"
#include "rgs/format/half.h"

namespace rgs::format::detail {

namespace {

std::string level_label(uint32_t level, uint32_t chunk) {
  return "lod chunk " + dec(chunk) + " level " + dec(level);
}

/// exp of every binary16 value, in double: the largest linear scale of a log-scale Gaussian (§4.5) by lookup.
const double* exp_of_halves() {
  static const std::vector<double> table = [] {
    std::vector<double> t(65536);
    for (uint32_t b = 0; b < t.size(); ++b) t[b] = std::exp(static_cast<double>(half_bits_to_float(uint16_t(b))));
    return t;
  }();
  return table.data();
}

/// A key whose order is the value order of finite binary16 values (−0 below +0), and back to the bits.
uint16_t half_order(uint16_t b) {
  return (b & 0x8000u) ? static_cast<uint16_t>(~b) : static_cast<uint16_t>(b | 0x8000u);
}
uint16_t half_of_order(uint16_t key) {
  return (key & 0x8000u) ? static_cast<uint16_t>(key & 0x7fffu) : static_cast<uint16_t>(~key);
}

/// §4.5 The linear scale a stored (finite) scale component `bits` stands for, in double.
double linear_scale(uint16_t bits, ScaleEncoding encoding, const double* exp_table) {
  return encoding == ScaleEncoding::kLog ? exp_table[bits] : static_cast<double>(half_bits_to_float(bits));
}

/// §4.9 The terms of how far the 3σ extent of the Gaussian with mean bytes `m` and (finite) scale bytes `s`
/// reaches from the chunk centre: its squared distance and its largest linear scale (the largest stored value
/// gives it: both encodings are monotonic).
struct ReachTerms {
  double distance2;
  double largest_scale;
};
ReachTerms reach_terms(const LodChunk& k, const uint8_t* m, const uint8_t* s, ScaleEncoding encoding,
                       const double* exp_table) {
  const float mean[3] = {load_f32_le(m), load_f32_le(m + 4), load_f32_le(m + 8)};
  uint16_t largest_bits = load_u16_le(s);
  for (int a = 1; a < 3; ++a) {
    const uint16_t b = load_u16_le(s + 2 * a);
    if (half_order(b) > half_order(largest_bits)) largest_bits = b;
  }
  return {distance_squared(mean, k.center), linear_scale(largest_bits, encoding, exp_table)};
}

/// §4.9 How far the 3σ extent reaches from the chunk centre.
double reach(const ReachTerms& t) { return std::sqrt(t.distance2) + 3.0 * t.largest_scale; }

}  // namespace

Status check_lod_structure(const LodIndex& index, uint64_t gaussian_count) {
  const uint32_t c_count = index.chunk_count;
  const uint32_t l_count = index.level_count;
  RGS_RETURN_ERROR_IF(c_count == 0 || c_count > gaussian_count, StatusCode::kCorruptData,
                      "lod: " + dec(c_count) + " chunks, must be 1.." + dec(gaussian_count) +
                          " (each chunk holds at least one Gaussian)");
  RGS_RETURN_ERROR_IF(l_count == 0 || l_count > kMaxLodLevels, StatusCode::kCorruptData,
                      "lod: " + dec(l_count) + " levels, must be 1.." + dec(kMaxLodLevels));
  RGS_RETURN_ERROR_IF(index.chunks.size() != c_count || index.levels.size() != uint64_t{c_count} * l_count,
                      StatusCode::kCorruptData,
                      "lod: " + dec(index.chunks.size()) + " chunk records and " + dec(index.levels.size()) +
                          " level records for " + dec(c_count) + " chunks of " + dec(l_count) + " levels");
  for (uint32_t c = 0; c < c_count; ++c) {
    const LodChunk& k = index.chunks[c];
    RGS_RETURN_ERROR_IF(!std::isfinite(k.center[0]) || !std::isfinite(k.center[1]) || !std::isfinite(k.center[2]) ||
                            !std::isfinite(k.radius) || !(k.radius >= 0.0f),
                        StatusCode::kCorruptData,
                        "lod chunk " + dec(c) + ": centre (" + num(k.center[0]) + ", " + num(k.center[1]) + ", " +
                            num(k.center[2]) + ") or radius " + num(k.radius) +
                            " is not finite (radius >= 0)");
  }
  uint64_t first = 0;
  for (uint32_t l = 0; l < l_count; ++l) {
    for (uint32_t c = 0; c < c_count; ++c) {
      const LodLevel& v = index.at(l, c);
      const std::string label = level_label(l, c);
      RGS_RETURN_ERROR_IF(v.count == 0, StatusCode::kCorruptData, label + ": no Gaussians");
      RGS_RETURN_ERROR_IF(v.first != first, StatusCode::kCorruptData,
                          label + ": starts at Gaussian " + dec(v.first) + ", expected " + dec(first) +
                              " (ranges tile the sections in record order)");
      RGS_RETURN_ERROR_IF(v.count > gaussian_count - first, StatusCode::kCorruptData,
                          label + ": " + dec(v.count) + " Gaussians from " + dec(first) + " pass the file's " +
                              dec(gaussian_count));
      first += v.count;
      RGS_RETURN_ERROR_IF(!std::isfinite(v.error) || !(v.error >= 0.0f), StatusCode::kCorruptData,
                          label + ": error " + num(v.error) + " is not finite and >= 0");
      if (l == 0) {
        RGS_RETURN_ERROR_IF(v.error != 0.0f, StatusCode::kCorruptData,
                            label + ": error " + num(v.error) + ", level 0 (the full detail) must have 0");
      } else {
        const LodLevel& finer = index.at(l - 1, c);
        RGS_RETURN_ERROR_IF(v.count > finer.count, StatusCode::kCorruptData,
                            label + ": " + dec(v.count) + " Gaussians, more than level " + dec(l - 1) + "'s " +
                                dec(finer.count));
        RGS_RETURN_ERROR_IF(v.error < finer.error, StatusCode::kCorruptData,
                            label + ": error " + num(v.error) + " below level " + dec(l - 1) + "'s " +
                                num(finer.error));
      }
    }
  }
  RGS_RETURN_ERROR_IF(first != gaussian_count, StatusCode::kCorruptData,
                      "lod: the levels hold " + dec(first) + " Gaussians, the file " + dec(gaussian_count));
  return Status();
}

std::vector<uint8_t> encode_lod(const LodIndex& index) {
  std::vector<uint8_t> raw(static_cast<size_t>(index.section_bytes()), 0);
  uint8_t* p = raw.data();
  store_u32_le(p, index.chunk_count);
  store_u32_le(p + 4, index.level_count);
  p += kLodHeadSize;  // bytes 8..15 reserved
  for (const LodChunk& k : index.chunks) {
    for (int a = 0; a < 3; ++a) store_f32_le(p + 4 * a, k.center[a]);
    store_f32_le(p + 12, k.radius);
    p += kLodChunkRecordSize;
  }
  for (const LodLevel& v : index.levels) {
    store_u64_le(p, v.count);
    store_f32_le(p + 8, v.error);  // bytes 12..15 reserved
    store_u64_le(p + 16, v.checksum);
    p += kLodLevelRecordSize;
  }
  return raw;
}

Status decode_lod(const uint8_t* raw, size_t size, uint64_t gaussian_count, LodIndex* out) {
  RGS_RETURN_ERROR_IF(size < kLodHeadSize, StatusCode::kCorruptData,
                      "lod: " + dec(size) + " bytes, shorter than its " + dec(kLodHeadSize) + "-byte head");
  LodIndex index;
  index.chunk_count = load_u32_le(raw);
  index.level_count = load_u32_le(raw + 4);
  RGS_RETURN_ERROR_IF(load_u64_le(raw + 8) != 0, StatusCode::kCorruptData, "lod: reserved head bytes are not 0");
  // Sizes first, from the two counts alone (u32 each: no overflow in 64 bits), so nothing below is sized by an
  // unchecked count.
  const uint64_t expected = kLodHeadSize + kLodChunkRecordSize * index.chunk_count +
                            kLodLevelRecordSize * uint64_t{index.chunk_count} * index.level_count;
  RGS_RETURN_ERROR_IF(size != expected, StatusCode::kCorruptData,
                      "lod: " + dec(size) + " bytes, " + dec(index.chunk_count) + " chunks of " +
                          dec(index.level_count) + " levels take " + dec(expected));
  RGS_RETURN_ERROR_IF(index.chunk_count == 0 || index.chunk_count > gaussian_count || index.level_count == 0 ||
                          index.level_count > kMaxLodLevels,
                      StatusCode::kCorruptData,
                      "lod: " + dec(index.chunk_count) + " chunks of " + dec(index.level_count) +
                          " levels (1.." + dec(gaussian_count) + " chunks, 1.." + dec(kMaxLodLevels) + " levels)");
  const uint8_t* p = raw + kLodHeadSize;
  index.chunks.resize(index.chunk_count);
  for (LodChunk& k : index.chunks) {
    for (int a = 0; a < 3; ++a) k.center[a] = load_f32_le(p + 4 * a);
    k.radius = load_f32_le(p + 12);
    p += kLodChunkRecordSize;
  }
  index.levels.resize(static_cast<size_t>(uint64_t{index.chunk_count} * index.level_count));
  uint64_t first = 0;
  for (size_t r = 0; r < index.levels.size(); ++r) {
    LodLevel& v = index.levels[r];
    v.count = load_u64_le(p);
    v.error = load_f32_le(p + 8);
    RGS_RETURN_ERROR_IF(load_u32_le(p + 12) != 0, StatusCode::kCorruptData,
                        level_label(static_cast<uint32_t>(r / index.chunk_count),
                                    static_cast<uint32_t>(r % index.chunk_count)) +
                            ": reserved bytes are not 0");
    v.checksum = load_u64_le(p + 16);
    v.first = first;
    if (!checked_add(first, v.count, &first)) first = UINT64_MAX;
    p += kLodLevelRecordSize;
  }
  RGS_RETURN_IF_ERROR(check_lod_structure(index, gaussian_count));
  *out = std::move(index);
  return Status();
}

LodRangeView lod_range_view(const std::array<const uint8_t*, 6>& parts, uint64_t first, uint64_t count,
                            uint32_t sh_degree) {
  const uint64_t record[6] = {12, 8, 6, 2, uint64_t{3} * sh_coefficient_count(sh_degree), 3};
  LodRangeView view;
  view.first = first;
  view.count = count;
  ByteView* views[6] = {&view.means, &view.rotations, &view.scales, &view.opacities, &view.sh, &view.sh_dc_residual};
  for (int a = 0; a < 6; ++a) {
    if (parts[a] != nullptr) *views[a] = ByteView{parts[a] + first * record[a], static_cast<size_t>(count * record[a])};
  }
  return view;
}

uint64_t lod_range_checksum(const LodRangeView& range) {
  XXH64_state_t* state = XXH64_createState();
  XXH64_reset(state, 0);
  for (const ByteView* v : {&range.means, &range.rotations, &range.scales, &range.opacities, &range.sh,
                            &range.sh_dc_residual}) {
    if (v->size > 0) XXH64_update(state, v->data, v->size);
  }
  const uint64_t digest = XXH64_digest(state);
  XXH64_freeState(state);
  return digest;
}

Status check_lod_checksum(const LodIndex& index, uint32_t level, uint32_t chunk, const LodRangeView& range) {
  const LodLevel& v = index.at(level, chunk);
  const uint64_t computed = lod_range_checksum(range);
  RGS_RETURN_ERROR_IF(computed != v.checksum, StatusCode::kChecksumMismatch,
                      level_label(level, chunk) + ": checksum " + hex64(v.checksum) + " does not match the computed " +
                          hex64(computed));
  return Status();
}

Status check_lod_values(const LodIndex& index, uint32_t level, uint32_t chunk, const LodRangeView& range,
                        const SceneMetadata& metadata) {
  const std::string label = level_label(level, chunk);
  const uint64_t n = range.count;
  const size_t k3 = 3 * sh_coefficient_count(metadata.sh_degree);
  struct Part {
    SectionId id;
    const ByteView* bytes;
    size_t record;
  };
  for (const Part& part : {Part{SectionId::kMeans, &range.means, 12}, Part{SectionId::kRotations, &range.rotations, 8},
                           Part{SectionId::kScales, &range.scales, 6}, Part{SectionId::kOpacities, &range.opacities, 2},
                           Part{SectionId::kSh, &range.sh, k3}}) {
    Status s = check_records(part.id, metadata, part.bytes->data, static_cast<size_t>(n), part.record, range.first);
    if (!s.ok()) return s.prepend(label + ": " + section_name(part.id));
  }
  // §4.9 Each Gaussian's 3σ extent inside the chunk's sphere, with §4.1.1's float32 slack. A Gaussian is
  // inside, however the roundings of reach() fall, when its distance squared is below `inner` squared, with
  // inner = limit − 3σ less a margin far above those roundings. Three passes, each over what the one before
  // could not clear: blocks of 32 Gaussians tested against the block's largest σ (one lookup, then loops with
  // no branch and no square root); the Gaussians of a block that fails, each against its own σ and then the
  // exact rule with reach(); and, when one is outside, a loop that names the first.
  const LodChunk& k = index.chunks[chunk];
  const double limit = sphere_limit(k.center, k.radius);
  const double margin = 1e-12 * limit;
  const double* exp_table = exp_of_halves();
  auto terms = [&](uint64_t j) {
    return reach_terms(k, range.means.data + 12 * j, range.scales.data + 6 * j, metadata.scale_encoding, exp_table);
  };
  auto clear = [&](const ReachTerms& t) {
    const double inner = limit - 3.0 * t.largest_scale - margin;
    return (inner > 0) & (t.distance2 <= inner * inner);
  };
  const uint8_t* means = range.means.data;
  const uint8_t* scales = range.scales.data;
  bool inside = true;
  constexpr uint64_t kBlock = 32;
  for (uint64_t b = 0; b < n; b += kBlock) {
    const uint64_t e = std::min(n, b + kBlock);
    uint16_t key = 0;  // half_order of the block's largest scale component
    for (uint64_t j = 6 * b; j < 6 * e; j += 2) key = std::max(key, half_order(load_u16_le(scales + j)));
    const double inner = limit - 3.0 * linear_scale(half_of_order(key), metadata.scale_encoding, exp_table) - margin;
    const double inner2 = inner > 0 ? inner * inner : -1.0;
    unsigned far = 0;
    for (uint64_t j = b; j < e; ++j) {
      const uint8_t* m = means + 12 * j;
      const float mean[3] = {load_f32_le(m), load_f32_le(m + 4), load_f32_le(m + 8)};
      far |= !(distance_squared(mean, k.center) <= inner2);
    }
    if (far == 0) continue;
    for (uint64_t j = b; j < e; ++j) {
      const ReachTerms t = terms(j);
      inside &= clear(t) || reach(t) <= limit;
    }
  }
  if (inside) return Status();
  for (uint64_t j = 0; j < n; ++j) {
    const double r = reach(terms(j));
    RGS_RETURN_ERROR_IF(!(r <= limit), StatusCode::kCorruptData,
                        label + ": Gaussian " + dec(range.first + j) + " reaches " + num(r) +
                            " from the chunk centre, outside its radius " + num(k.radius));
  }
  return Status();
}

Status check_lod_range(const LodIndex& index, uint32_t level, uint32_t chunk, const LodRangeView& range,
                       const SceneMetadata& metadata, bool verify_checksum) {
  if (verify_checksum) RGS_RETURN_IF_ERROR(check_lod_checksum(index, level, chunk, range));
  return check_lod_values(index, level, chunk, range, metadata);
}

}  // namespace rgs::format::detail
