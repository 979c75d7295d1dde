// libFuzzer custom mutator for .rgs inputs (linked only into the libFuzzer build of fuzz_rgs_read).
//
// Byte-level mutations of an .rgs file almost always stop at the header or section XXH64 (SPEC §2.3,
// §3.1). This mutator edits the file as a container instead: header fields, table entry fields, the raw
// bytes of a section (decompressed and recompressed when the section is a zstd frame), the section list
// (drop, duplicate, swap, add an unknown section, switch codec), the Gaussian count and the SH degree, and
// then rewrites the layout and every checksum. One mutation in eight keeps the stale checksums, so the
// checksum checks themselves stay covered.
#include <zstd.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <random>
#include <vector>

#include "rgs_container.h"

extern "C" size_t LLVMFuzzerMutate(uint8_t* data, size_t size, size_t max_size);

namespace {

using rgs::fuzz::LooseContainer;
using rgs::fuzz::LooseSection;
namespace hf = rgs::fuzz::header_field;
namespace ef = rgs::fuzz::entry_field;

// Decoded sections are kept small so that every execution stays fast.
constexpr size_t kMaxRawBytes = 1 << 20;
constexpr uint32_t kIdMetadata = 1, kIdMeans = 16, kIdSh = 20;

using Rng = std::minstd_rand;

size_t pick(Rng& rng, size_t n) { return n == 0 ? 0 : rng() % n; }

// Values that sit on the edges of the checks: zero, one, powers of two, all ones, sizes of this file.
uint64_t interesting_value(Rng& rng, size_t bytes, uint64_t current, uint64_t file_size) {
  const uint64_t mask = bytes >= 8 ? ~uint64_t{0} : (uint64_t{1} << (8 * bytes)) - 1;
  switch (pick(rng, 12)) {
    case 0: return 0;
    case 1: return 1;
    case 2: return (current + 1) & mask;
    case 3: return (current - 1) & mask;
    case 4: return mask;
    case 5: return mask >> 1;
    case 6: return (uint64_t{1} << pick(rng, 8 * bytes)) & mask;
    case 7: return file_size & mask;
    case 8: return (current * 2) & mask;
    case 9: return (current / 2) & mask;
    case 10: return (current + 256) & mask;
    default: return (current ^ (uint64_t{1} << pick(rng, 8 * bytes))) & mask;
  }
}

// IEEE bit patterns that value checks treat specially (NaN, infinities, signed zero, subnormals, f16 max).
void write_interesting_typed(Rng& rng, std::vector<uint8_t>& raw) {
  if (raw.empty()) return;
  static constexpr uint32_t kF32[] = {0x7fc00000u, 0x7f800000u, 0xff800000u, 0x80000000u, 0x00000001u,
                                      0x7f7fffffu, 0x3f800000u, 0xbf800000u, 0x3f800001u, 0x00000000u};
  static constexpr uint16_t kF16[] = {0x7e00, 0x7c00, 0xfc00, 0x8000, 0x0001, 0x7bff,
                                      0x3c00, 0x3c01, 0xbc00, 0x0000, 0x4c00, 0xfbff};
  static constexpr uint8_t kI8[] = {0x80, 0x7f, 0x81, 0x00, 0xff};
  switch (pick(rng, 3)) {
    case 0: {
      if (raw.size() < 4) return;
      const size_t at = pick(rng, raw.size() / 4) * 4;
      rgs::fuzz::store_le(&raw[at], 4, kF32[pick(rng, std::size(kF32))]);
      break;
    }
    case 1: {
      if (raw.size() < 2) return;
      const size_t at = pick(rng, raw.size() / 2) * 2;
      rgs::fuzz::store_le(&raw[at], 2, kF16[pick(rng, std::size(kF16))]);
      break;
    }
    default:
      raw[pick(rng, raw.size())] = kI8[pick(rng, std::size(kI8))];
      break;
  }
}

bool decompress(const std::vector<uint8_t>& frame, std::vector<uint8_t>* raw) {
  const unsigned long long n = ZSTD_getFrameContentSize(frame.data(), frame.size());
  if (n == ZSTD_CONTENTSIZE_ERROR || n == ZSTD_CONTENTSIZE_UNKNOWN || n > kMaxRawBytes) return false;
  raw->resize(static_cast<size_t>(n));
  const size_t got = ZSTD_decompress(raw->data(), raw->size(), frame.data(), frame.size());
  return !ZSTD_isError(got) && got == n;
}

// SPEC §3.1 frame: content size and content checksum, no dictionary, a small window.
std::vector<uint8_t> compress(const std::vector<uint8_t>& raw) {
  std::vector<uint8_t> frame(ZSTD_compressBound(raw.size()));
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_compressionLevel, 1);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 1);
  const size_t n = ZSTD_compress2(cctx, frame.data(), frame.size(), raw.data(), raw.size());
  ZSTD_freeCCtx(cctx);
  frame.resize(ZSTD_isError(n) ? 0 : n);
  return frame;
}

// The section's raw bytes: its stored bytes, or the decoded frame when it is zstd and decodes.
bool raw_bytes(const LooseSection& s, std::vector<uint8_t>* raw, bool* was_zstd) {
  *was_zstd = s.codec() == 1;
  if (!*was_zstd) {
    *raw = s.stored;
    return true;
  }
  return decompress(s.stored, raw);
}

// Stores `raw` back, recompressing a zstd section; with `consistent`, raw_size and element_count follow
// the new size so that the table checks pass and the payload checks see the bytes.
void store_raw(LooseSection& s, const std::vector<uint8_t>& raw, bool was_zstd, bool consistent) {
  s.stored = was_zstd ? compress(raw) : raw;
  if (!consistent) return;
  s.set(ef::kRawSize, 8, raw.size());
  const uint64_t per_element =
      uint64_t{rgs::fuzz::element_size(static_cast<uint16_t>(s.get(ef::kElementType, 2)))} *
      s.get(ef::kComponents, 4);
  if (per_element != 0) s.set(ef::kElementCount, 8, raw.size() / per_element);
}

void mutate_section_bytes(Rng& rng, LooseSection& s) {
  std::vector<uint8_t> raw;
  bool was_zstd = false;
  if (!raw_bytes(s, &raw, &was_zstd)) {  // an undecodable frame: mutate the frame bytes themselves
    raw = s.stored;
    was_zstd = false;
  }
  if (pick(rng, 2) == 0) {
    write_interesting_typed(rng, raw);
    store_raw(s, raw, was_zstd, false);
    return;
  }
  if (raw.empty()) raw.push_back(static_cast<uint8_t>(rng()));
  const size_t old_size = raw.size();
  const size_t max_size = std::min(kMaxRawBytes, old_size * 2 + 64);
  raw.resize(max_size);
  raw.resize(LLVMFuzzerMutate(raw.data(), old_size, max_size));
  store_raw(s, raw, was_zstd, pick(rng, 4) != 0);
}

// Changes the Gaussian count N and resizes every per-Gaussian section to match (repeating or truncating
// elements), so that the count checks pass and the decoders see more or fewer Gaussians.
void resize_gaussians(Rng& rng, LooseContainer& c) {
  const uint64_t n = c.get(hf::kGaussianCount, 8);
  static constexpr uint64_t kChoices[] = {0, 1, 2, 3};
  uint64_t m = 0;
  switch (pick(rng, 4)) {
    case 0: m = kChoices[pick(rng, std::size(kChoices))]; break;
    case 1: m = n / 2; break;
    case 2: m = n + 1; break;
    default: m = n * 2 + 1; break;
  }
  m = std::min<uint64_t>(m, 4096);  // the header may declare anything; the products below must not wrap
  for (LooseSection& s : c.sections) {
    if (s.id() < kIdMeans || s.id() > kIdSh) continue;
    std::vector<uint8_t> raw;
    bool was_zstd = false;
    if (!raw_bytes(s, &raw, &was_zstd)) continue;
    const uint64_t per = uint64_t{rgs::fuzz::element_size(static_cast<uint16_t>(s.get(ef::kElementType, 2)))} *
                         s.get(ef::kComponents, 4);
    if (per == 0 || per > 4096 || m > kMaxRawBytes / per) continue;
    std::vector<uint8_t> out(m * per);
    for (uint64_t i = 0; i < m && !raw.empty(); ++i) {
      const uint64_t from = (i % std::max<uint64_t>(raw.size() / per, 1)) * per;
      const size_t len = static_cast<size_t>(std::min<uint64_t>(per, raw.size() - std::min(from, raw.size())));
      std::memcpy(&out[i * per], raw.data() + from, len);
    }
    store_raw(s, out, was_zstd, true);
  }
  c.set(hf::kGaussianCount, 8, m);
}

// Changes the SH degree in the metadata and re-shapes the sh section to K' = (d' + 1)^2 coefficients per
// channel, keeping the leading coefficients of each Gaussian.
void change_sh_degree(Rng& rng, LooseContainer& c) {
  LooseSection* meta = nullptr;
  LooseSection* sh = nullptr;
  for (LooseSection& s : c.sections) {
    if (s.id() == kIdMetadata && !meta) meta = &s;
    if (s.id() == kIdSh && !sh) sh = &s;
  }
  if (!meta || !sh) return;
  std::vector<uint8_t> meta_raw, sh_raw;
  bool meta_zstd = false, sh_zstd = false;
  if (!raw_bytes(*meta, &meta_raw, &meta_zstd) || meta_raw.size() < 112) return;
  if (!raw_bytes(*sh, &sh_raw, &sh_zstd)) return;
  const uint32_t d = static_cast<uint32_t>(pick(rng, 4));
  const uint64_t k_new = uint64_t{d + 1} * (d + 1) * 3;
  const uint64_t k_old = sh->get(ef::kComponents, 4);
  const uint64_t n = c.get(hf::kGaussianCount, 8);
  if (k_old == 0 || k_old > 4096 || n > kMaxRawBytes / 48 || sh_raw.size() < n * k_old) return;
  std::vector<uint8_t> out(n * k_new, 0);
  for (uint64_t i = 0; i < n; ++i) {
    std::memcpy(&out[i * k_new], &sh_raw[i * k_old], std::min(k_old, k_new));
  }
  sh->set(ef::kComponents, 4, k_new);
  store_raw(*sh, out, sh_zstd, true);
  rgs::fuzz::store_le(&meta_raw[0], 4, d);
  for (uint32_t row = d + 1; row < 4; ++row) {  // §4.1: sh_scales rows above the degree are 0
    std::fill(meta_raw.begin() + 64 + 12 * row, meta_raw.begin() + 76 + 12 * row, 0);
  }
  if (pick(rng, 2) == 0) {  // and give the new rows a scale so their values matter
    for (uint32_t row = 1; row <= d; ++row) {
      for (uint32_t ch = 0; ch < 3; ++ch) rgs::fuzz::store_le(&meta_raw[64 + 12 * row + 4 * ch], 4, 0x3c000000u);
    }
  }
  store_raw(*meta, meta_raw, meta_zstd, false);
}

void mutate_structure(Rng& rng, LooseContainer& c) {
  auto& v = c.sections;
  switch (pick(rng, 6)) {
    case 0:
      if (!v.empty()) v.erase(v.begin() + static_cast<std::ptrdiff_t>(pick(rng, v.size())));
      break;
    case 1:
      if (!v.empty() && v.size() < 64) v.push_back(v[pick(rng, v.size())]);
      break;
    case 2:
      if (v.size() >= 2) std::swap(v[pick(rng, v.size())], v[pick(rng, v.size())]);
      break;
    case 3: {  // a section of a later minor version: unknown id, any codec and element type
      if (v.size() >= 64) break;
      LooseSection s;
      s.set(ef::kId, 4, 0x8000 + pick(rng, 16));
      s.set(ef::kCodec, 2, pick(rng, 3));
      s.set(ef::kElementType, 2, pick(rng, 5));
      s.set(ef::kComponents, 4, 1 + pick(rng, 4));
      s.stored.assign(pick(rng, 64), static_cast<uint8_t>(rng()));
      s.set(ef::kRawSize, 8, s.stored.size());
      s.set(ef::kElementCount, 8, s.stored.size());
      v.insert(v.begin() + static_cast<std::ptrdiff_t>(pick(rng, v.size() + 1)), s);
      break;
    }
    default: {  // switch a section between codec none and zstd
      if (v.empty()) break;
      LooseSection& s = v[pick(rng, v.size())];
      if (s.codec() == 1) {
        std::vector<uint8_t> raw;
        if (!decompress(s.stored, &raw)) break;
        s.stored = raw;
        s.set(ef::kCodec, 2, 0);
      } else if (s.stored.size() <= kMaxRawBytes) {
        s.set(ef::kRawSize, 8, s.stored.size());
        s.stored = compress(s.stored);
        s.set(ef::kCodec, 2, 1);
      }
      break;
    }
  }
}

size_t byte_mutation(Rng& rng, uint8_t* data, size_t size, size_t max_size) {
  size = LLVMFuzzerMutate(data, size, max_size);
  if (pick(rng, 8) != 0) rgs::fuzz::fix_checksums(data, size);
  return size;
}

}  // namespace

extern "C" size_t LLVMFuzzerCustomMutator(uint8_t* data, size_t size, size_t max_size, unsigned int seed) {
  Rng rng(seed);
  LooseContainer c;
  const size_t op = pick(rng, 16);
  if (op < 3 || !rgs::fuzz::parse_loose(data, size, &c)) return byte_mutation(rng, data, size, max_size);

  if (op < 7) {  // one header or table field, edited in place: the layout stays as the input had it
    std::vector<uint8_t> bytes(data, data + size);
    static constexpr size_t kHeader[][2] = {
        {hf::kMajor, 2},          {hf::kMinor, 2},        {hf::kHeaderSize, 4},  {hf::kRequiredFlags, 4},
        {hf::kOptionalFlags, 4},  {hf::kGaussianCount, 8}, {hf::kSectionCount, 4}, {hf::kReserved, 4},
        {hf::kTableOffset, 8},    {hf::kFileSize, 8}};
    static constexpr size_t kEntry[][2] = {
        {ef::kId, 4},           {ef::kCodec, 2},  {ef::kElementType, 2}, {ef::kComponents, 4},
        {ef::kReserved, 4},     {ef::kElementCount, 8}, {ef::kOffset, 8}, {ef::kStoredSize, 8},
        {ef::kRawSize, 8},      {ef::kReserved2, 8}};
    size_t at = 0, len = 0;
    if (op < 4 || c.sections.empty()) {
      const auto& f = kHeader[pick(rng, std::size(kHeader))];
      at = f[0];
      len = f[1];
    } else {
      const auto& f = kEntry[pick(rng, std::size(kEntry))];
      at = 64 + 64 * pick(rng, c.sections.size()) + f[0];
      len = f[1];
    }
    rgs::fuzz::store_le(&bytes[at], len,
                        interesting_value(rng, len, rgs::fuzz::load_le(&bytes[at], len), size));
    if (pick(rng, 8) != 0) rgs::fuzz::fix_checksums(bytes.data(), bytes.size());
    std::memcpy(data, bytes.data(), size);
    return size;
  }

  if (op < 12) {
    if (c.sections.empty()) return byte_mutation(rng, data, size, max_size);
    mutate_section_bytes(rng, c.sections[pick(rng, c.sections.size())]);
  } else if (op < 14) {
    mutate_structure(rng, c);
  } else if (op < 15) {
    resize_gaussians(rng, c);
  } else {
    change_sh_degree(rng, c);
  }
  const std::vector<uint8_t> out = rgs::fuzz::serialize_loose(c);
  if (out.size() > max_size) return byte_mutation(rng, data, size, max_size);
  std::memcpy(data, out.data(), out.size());
  return out.size();
}
