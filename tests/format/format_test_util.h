// Scenes and byte-patching helpers shared by the format tests.
#pragma once

#include <xxhash.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include <doctest/doctest.h>

#include "rgs/format/encoded_scene.h"
#include "rgs/format/half.h"
#include "rgs/format/reader.h"
#include "rgs/format/spec.h"
#include "test_data.h"

namespace rgs::test {

/// Whole file as bytes; empty (and a failed CHECK) when it cannot be read.
inline std::vector<uint8_t> read_file_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  CHECK_MESSAGE(in.good(), "cannot read " << path);
  return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

/// Path of a golden or must-fail file under tests/data.
inline std::string data_path(const std::string& relative) { return repo_path("tests/data/" + relative); }

// Little-endian field access for patching files in tests.
inline uint64_t get_u64(const std::vector<uint8_t>& b, size_t at) {
  uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | b[at + i];
  return v;
}
inline uint32_t get_u32(const std::vector<uint8_t>& b, size_t at) {
  return static_cast<uint32_t>(b[at] | (b[at + 1] << 8) | (b[at + 2] << 16) | (static_cast<uint32_t>(b[at + 3]) << 24));
}
inline uint16_t get_u16(const std::vector<uint8_t>& b, size_t at) {
  return static_cast<uint16_t>(b[at] | (b[at + 1] << 8));
}
inline void put_u64(std::vector<uint8_t>& b, size_t at, uint64_t v) {
  for (int i = 0; i < 8; ++i) b[at + i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void put_u32(std::vector<uint8_t>& b, size_t at, uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = static_cast<uint8_t>(v >> (8 * i));
}
inline void put_u16(std::vector<uint8_t>& b, size_t at, uint16_t v) {
  b[at] = static_cast<uint8_t>(v);
  b[at + 1] = static_cast<uint8_t>(v >> 8);
}

/// Byte offset of section-table entry i (SPEC §3).
inline size_t entry_at(size_t i) { return format::kHeaderSize + format::kSectionEntrySize * i; }

/// Recomputes the header checksum (SPEC §2) over header bytes [0, 56) and the table, as far as the file
/// holds it.
inline void fix_header_checksum(std::vector<uint8_t>& b) {
  if (b.size() < format::kHeaderSize) return;
  const uint64_t count = get_u32(b, 32);
  uint64_t table_end = format::kHeaderSize + format::kSectionEntrySize * count;
  if (table_end > b.size()) table_end = b.size();
  std::vector<uint8_t> covered(b.begin(), b.begin() + 56);
  covered.insert(covered.end(), b.begin() + format::kHeaderSize, b.begin() + static_cast<long>(table_end));
  put_u64(b, 56, XXH64(covered.data(), covered.size(), 0));
}

/// Recomputes section i's XXH64 (when its bytes lie inside the file) and then the header checksum.
inline void fix_section_checksum(std::vector<uint8_t>& b, size_t i) {
  const uint64_t offset = get_u64(b, entry_at(i) + 24);
  const uint64_t stored = get_u64(b, entry_at(i) + 32);
  if (offset <= b.size() && stored <= b.size() - offset) {
    put_u64(b, entry_at(i) + 48, XXH64(b.data() + offset, static_cast<size_t>(stored), 0));
  }
  fix_header_checksum(b);
}

/// Recomputes every checksum a file declares, so a patch is judged by the checks behind them.
inline void fix_all_checksums(std::vector<uint8_t>& b) {
  if (b.size() < format::kHeaderSize) return;
  const uint64_t count = get_u32(b, 32);
  for (uint64_t i = 0; i < count && entry_at(i) + format::kSectionEntrySize <= b.size(); ++i) {
    fix_section_checksum(b, static_cast<size_t>(i));
  }
  fix_header_checksum(b);
}

/// Offset in the file of the codes of quantized section i (SPEC §3.3.2: after its 8-byte header, 4 bytes a
/// parameter, and for SH transform 5 the codebook size).
inline uint64_t quantized_codes_at(const std::vector<uint8_t>& b, size_t i) {
  const uint64_t offset = get_u64(b, entry_at(i) + 24);
  return offset + 8 + 4 * uint64_t{get_u16(b, static_cast<size_t>(offset) + 2)} + (b[offset] == 5 ? 4 : 0);
}

/// How many quantized sections of the file store their codes as an .xz stream (magic FD 37 7A 58 5A 00).
inline uint32_t count_xz_sections(const std::vector<uint8_t>& b) {
  static const uint8_t magic[6] = {0xFD, '7', 'z', 'X', 'Z', 0x00};
  uint32_t count = 0;
  for (size_t i = 0; i < get_u32(b, 32); ++i) {
    if (get_u16(b, entry_at(i) + 4) != static_cast<uint16_t>(format::Codec::kQuantized)) continue;
    const uint64_t at = quantized_codes_at(b, i);
    if (at + 6 <= b.size() && std::equal(magic, magic + 6, b.begin() + static_cast<long>(at))) ++count;
  }
  return count;
}

inline const uint16_t kQuats[4][4] = {
    {0x3C00, 0, 0, 0}, {0, 0x3C00, 0, 0}, {0x3800, 0x3800, 0x3800, 0x3800}, {0x3800, 0xB800, 0x3800, 0xB800}};

/// The scene of tests/data/v1.0/small_sh3.rgs (make_rgs_corpus.py small_sh3(); keep them in step).
inline format::EncodedScene make_small_sh3() {
  format::EncodedScene s;
  const uint64_t n = 21;
  const uint32_t degree = 3, k = 16;
  s.count = n;
  for (uint64_t i = 0; i < n; ++i) {
    s.means.push_back(static_cast<float>(i % 7) * 0.5f - 1.5f);
    s.means.push_back(static_cast<float>(i % 5) * 0.25f - 0.5f);
    s.means.push_back(static_cast<float>(i) * 0.125f + 2.0f);
    for (uint16_t q : kQuats[i % 4]) s.rotations.push_back(q);
    for (uint64_t a = 0; a < 3; ++a) {
      uint16_t bits = static_cast<uint16_t>(0x1C00 + ((i * 3 + a) * 97) % 0x1000);
      if (i == 5 && a == 2) bits = 0x0000;
      if (i == 6 && a == 0) bits = 0x0001;
      s.scales.push_back(bits);
    }
    s.opacities.push_back(static_cast<uint16_t>(i == n - 1 ? 0x3C00 : (i * 421) % 0x3C01));
    for (uint64_t kk = 0; kk < k; ++kk) {
      for (uint64_t c = 0; c < 3; ++c) s.sh.push_back(static_cast<int8_t>(static_cast<int>((i * 31 + kk * 7 + c * 3) % 255) - 127));
    }
  }
  auto& m = s.metadata;
  m.sh_degree = degree;
  m.scale_encoding = format::ScaleEncoding::kLinear;
  const float lo[3] = {-1.5f, -0.5f, 2.0f}, hi[3] = {1.5f, 0.5f, 4.5f}, c[3] = {0.0f, 0.0f, 3.25f};
  for (int a = 0; a < 3; ++a) {
    m.bounds.aabb_min[a] = lo[a];
    m.bounds.aabb_max[a] = hi[a];
    m.bounds.sphere_center[a] = c[a];
  }
  m.bounds.sphere_radius = 2.125f;
  for (uint32_t d = 0; d < 4; ++d) {
    for (uint32_t ch = 0; ch < 3; ++ch) {
      m.sh_quantization.scales[d][ch] = d <= degree ? static_cast<float>(ch + 1) * std::ldexp(1.0f, -static_cast<int>(d + 3)) : 0.0f;
    }
  }
  s.provenance = {{"source", "synthetic small_sh3 (tests/data/make_rgs_corpus.py)"},
                  {"converter", "make_rgs_corpus.py 1.0"},
                  {"options", "sh_degree=3 scale_encoding=linear codec=none"},
                  {"utf8", "Gau\xc3\x9f" "ian \xe2\x9c\x93"}};
  return s;
}

/// The scene of tests/data/v1.2/small_sh0_dc_residual.rgs (make_rgs_corpus.py small_sh0_dc_residual()).
inline format::EncodedScene make_small_sh0_dc_residual();

/// The scene of tests/data/v1.0/small_sh0_zstd.rgs (make_rgs_corpus.py small_sh0_zstd()).
inline format::EncodedScene make_small_sh0_zstd() {
  format::EncodedScene s;
  const uint64_t n = 64;
  s.count = n;
  for (uint64_t i = 0; i < n; ++i) {
    s.means.push_back(static_cast<float>(i % 8) * 0.5f - 2.0f);
    s.means.push_back(static_cast<float>(i / 8) * 0.5f - 2.0f);
    s.means.push_back(1.0f + static_cast<float>(i % 3) * 0.25f);
    for (uint16_t q : kQuats[(i / 3) % 4]) s.rotations.push_back(q);
    for (uint64_t a = 0; a < 3; ++a) {
      s.scales.push_back(static_cast<uint16_t>(i < 32 ? 0xC000 + ((i * 3 + a) * 53) % 0x800 : 0));
    }
    s.opacities.push_back(static_cast<uint16_t>(0x3800 + i * 8));
    for (uint64_t c = 0; c < 3; ++c) s.sh.push_back(static_cast<int8_t>(static_cast<int>((i * 13 + c * 5) % 255) - 127));
  }
  auto& m = s.metadata;
  m.sh_degree = 0;
  m.scale_encoding = format::ScaleEncoding::kLog;
  const float lo[3] = {-2.0f, -2.0f, 1.0f}, hi[3] = {1.5f, 1.5f, 1.5f}, c[3] = {-0.25f, -0.25f, 1.25f};
  for (int a = 0; a < 3; ++a) {
    m.bounds.aabb_min[a] = lo[a];
    m.bounds.aabb_max[a] = hi[a];
    m.bounds.sphere_center[a] = c[a];
  }
  m.bounds.sphere_radius = 2.5f;
  for (uint32_t ch = 0; ch < 3; ++ch) m.sh_quantization.scales[0][ch] = static_cast<float>(ch + 1) * 0.125f;
  s.provenance = {{"source", "synthetic small_sh0_zstd (tests/data/make_rgs_corpus.py)"},
                  {"options", "sh_degree=0 scale_encoding=log codec=zstd (raw and RLE blocks)"}};
  return s;
}

inline format::EncodedScene make_small_sh0_dc_residual() {
  format::EncodedScene s = make_small_sh0_zstd();
  for (uint64_t i = 0; i < s.count; ++i) {
    for (uint64_t c = 0; c < 3; ++c) {
      s.sh_dc_residual.push_back(static_cast<int8_t>(static_cast<int>((i * 3 + c) * 4 % 256) - 128 + int(i % 4)));
    }
  }
  s.provenance = {{"source", "synthetic small_sh0_dc_residual (tests/data/make_rgs_corpus.py)"},
                  {"options", "sh_degree=0 scale_encoding=log codec=none sh_dc_residual"}};
  return s;
}

/// A random but valid scene: means in a box with exact bounds, normalized FP16 quaternions, scales
/// (linear or log), opacities in [0, 1], INT8 SH in [-127, 127] with positive scales up to `degree`.
inline format::EncodedScene make_random_scene(uint64_t n, uint32_t degree, uint32_t seed,
                                              format::ScaleEncoding encoding = format::ScaleEncoding::kLinear) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-50.0f, 50.0f), unit(0.0f, 1.0f), normal(-1.0f, 1.0f),
      log_scale(-12.0f, 1.0f), sh_scale(0.001f, 2.0f);
  std::uniform_int_distribution<int> q8(-127, 127);
  format::EncodedScene s;
  s.count = n;
  s.metadata.sh_degree = degree;
  s.metadata.scale_encoding = encoding;
  const uint32_t k = format::sh_coefficient_count(degree);
  for (uint64_t i = 0; i < n; ++i) {
    for (int a = 0; a < 3; ++a) s.means.push_back(pos(rng) + static_cast<float>(a) * 100.0f);
    float q[4], norm = 0;
    do {
      norm = 0;
      for (float& v : q) {
        v = normal(rng);
        norm += v * v;
      }
    } while (norm < 0.01f);
    for (float v : q) s.rotations.push_back(format::float_to_half_bits(v / std::sqrt(norm)));
    for (int a = 0; a < 3; ++a) {
      const float l = log_scale(rng);
      s.scales.push_back(format::float_to_half_bits(encoding == format::ScaleEncoding::kLog ? l : std::exp(l)));
    }
    s.opacities.push_back(format::float_to_half_bits(unit(rng)));
    for (uint32_t j = 0; j < 3 * k; ++j) s.sh.push_back(static_cast<int8_t>(q8(rng)));
  }
  auto& b = s.metadata.bounds;
  for (int a = 0; a < 3; ++a) {
    b.aabb_min[a] = n ? INFINITY : 0.0f;
    b.aabb_max[a] = n ? -INFINITY : 0.0f;
    for (uint64_t i = 0; i < n; ++i) {
      b.aabb_min[a] = std::fmin(b.aabb_min[a], s.means[i * 3 + a]);
      b.aabb_max[a] = std::fmax(b.aabb_max[a], s.means[i * 3 + a]);
    }
    b.sphere_center[a] = 0.5f * (b.aabb_min[a] + b.aabb_max[a]);
  }
  double r = 0;
  for (uint64_t i = 0; i < n; ++i) {
    double d2 = 0;
    for (int a = 0; a < 3; ++a) {
      const double d = static_cast<double>(s.means[i * 3 + a]) - b.sphere_center[a];
      d2 += d * d;
    }
    r = std::fmax(r, std::sqrt(d2));
  }
  b.sphere_radius = std::nextafter(static_cast<float>(r), INFINITY);
  for (uint32_t d = 0; d <= degree; ++d) {
    for (int c = 0; c < 3; ++c) s.metadata.sh_quantization.scales[d][c] = sh_scale(rng);
  }
  s.provenance = {{"source", "random scene seed " + std::to_string(seed)}, {"empty value", ""}};
  return s;
}

/// Bitwise float equality (tells -0 from 0, NaN equal to itself).
inline bool same_bits(float a, float b) { return std::memcmp(&a, &b, 4) == 0; }

/// CHECKs that two scenes hold identical content, bit for bit.
inline void check_same_scene(const format::EncodedScene& a, const format::EncodedScene& b) {
  CHECK(a.count == b.count);
  const auto& ma = a.metadata;
  const auto& mb = b.metadata;
  CHECK(ma.sh_degree == mb.sh_degree);
  CHECK(ma.frame == mb.frame);
  CHECK(ma.quaternion_order == mb.quaternion_order);
  CHECK(ma.scale_encoding == mb.scale_encoding);
  CHECK(ma.opacity_encoding == mb.opacity_encoding);
  CHECK(ma.sh_layout == mb.sh_layout);
  for (int i = 0; i < 3; ++i) {
    CHECK(same_bits(ma.bounds.aabb_min[i], mb.bounds.aabb_min[i]));
    CHECK(same_bits(ma.bounds.aabb_max[i], mb.bounds.aabb_max[i]));
    CHECK(same_bits(ma.bounds.sphere_center[i], mb.bounds.sphere_center[i]));
  }
  CHECK(same_bits(ma.bounds.sphere_radius, mb.bounds.sphere_radius));
  CHECK(ma.sh_quantization.bits == mb.sh_quantization.bits);
  CHECK(same_bits(ma.sh_quantization.clip_percentile, mb.sh_quantization.clip_percentile));
  for (int d = 0; d < 4; ++d) {
    for (int c = 0; c < 3; ++c) CHECK(same_bits(ma.sh_quantization.scales[d][c], mb.sh_quantization.scales[d][c]));
  }
  CHECK(a.provenance == b.provenance);
  REQUIRE(a.means.size() == b.means.size());
  CHECK((a.means.empty() || std::memcmp(a.means.data(), b.means.data(), a.means.size() * 4) == 0));
  CHECK(a.rotations == b.rotations);
  CHECK(a.scales == b.scales);
  CHECK(a.opacities == b.opacities);
  CHECK(a.sh == b.sh);
  CHECK(a.sh_dc_residual == b.sh_dc_residual);
}

/// SPEC §4.9 The checksum of Gaussians [first, first + count) of `s`, computed here from the scene's arrays (the
/// host is little-endian, so they are the raw bytes): means, rotations, scales, opacities, sh, sh_dc_residual.
inline uint64_t range_checksum(const format::EncodedScene& s, uint64_t first, uint64_t count) {
  const size_t k3 = 3 * format::sh_coefficient_count(s.metadata.sh_degree);
  XXH64_state_t* state = XXH64_createState();
  XXH64_reset(state, 0);
  XXH64_update(state, s.means.data() + first * 3, count * 12);
  XXH64_update(state, s.rotations.data() + first * 4, count * 8);
  XXH64_update(state, s.scales.data() + first * 3, count * 6);
  XXH64_update(state, s.opacities.data() + first, count * 2);
  XXH64_update(state, s.sh.data() + first * k3, count * k3);
  if (!s.sh_dc_residual.empty()) XXH64_update(state, s.sh_dc_residual.data() + first * 3, count * 3);
  const uint64_t digest = XXH64_digest(state);
  XXH64_freeState(state);
  return digest;
}

}  // namespace rgs::test
