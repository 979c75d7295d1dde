// Small .rgs files that claim far more memory than their bytes hold (tests/data/bad/memory/), built
// field by field as SPEC.md §2-§4 lays them out. The zstd frames are written by hand (RFC 8878 §3.1) from
// RLE blocks: 4 stored bytes per 128 KiB of decoded bytes, zstd's largest expansion (SPEC §3.1).
#pragma once

#include <xxhash.h>

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "rgs/format/spec.h"

namespace rgs::test {

namespace memory_corpus_detail {

inline void append_le(std::vector<uint8_t>& b, uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) b.push_back(static_cast<uint8_t>(v >> (8 * i)));
}

inline void pad_to(std::vector<uint8_t>& b, size_t size) {
  if (b.size() < size) b.resize(size, 0);
}

/// XXH64 of `size` bytes that all equal `value`, streamed through a 1 MiB buffer.
inline uint64_t xxh64_repeated(uint8_t value, uint64_t size) {
  std::vector<uint8_t> chunk(size_t{1} << 20, value);
  XXH64_state_t* state = XXH64_createState();
  XXH64_reset(state, 0);
  for (uint64_t done = 0; done < size;) {
    const size_t n = static_cast<size_t>(std::min<uint64_t>(chunk.size(), size - done));
    XXH64_update(state, chunk.data(), n);
    done += n;
  }
  const uint64_t h = XXH64_digest(state);
  XXH64_freeState(state);
  return h;
}

constexpr uint64_t kBlockBytes = uint64_t{1} << 17;  // 128 KiB, the largest zstd block

/// Frame header: magic, descriptor (8-byte content size, window descriptor, content checksum, no
/// dictionary), a 128 KiB window (exponent 7), the content size.
inline void append_frame_header(std::vector<uint8_t>& b, uint64_t raw_size) {
  append_le(b, 0xFD2FB528u, 4);
  b.push_back(0xC4);
  b.push_back(7 << 3);
  append_le(b, raw_size, 8);
}

/// One RLE block of `count` (1..128 Ki) copies of `value`.
inline void append_rle_block(std::vector<uint8_t>& b, uint8_t value, uint64_t count, bool last) {
  append_le(b, (count << 3) | (uint64_t{1} << 1) | (last ? 1u : 0u), 3);
  b.push_back(value);
}

/// A valid frame decoding to `raw_size` copies of `value`.
inline std::vector<uint8_t> rle_frame(uint8_t value, uint64_t raw_size) {
  std::vector<uint8_t> f;
  append_frame_header(f, raw_size);
  for (uint64_t done = 0; done < raw_size;) {
    const uint64_t n = std::min(kBlockBytes, raw_size - done);
    done += n;
    append_rle_block(f, value, n, done == raw_size);
  }
  append_le(f, xxh64_repeated(value, raw_size) & 0xFFFFFFFFu, 4);
  return f;
}

/// A frame whose header claims `raw_size` bytes: one good RLE block, then a block of the reserved type
/// (a decoding error), padded with 0xFF to the fewest bytes that may claim raw_size (32768:1).
inline std::vector<uint8_t> bogus_frame(uint64_t raw_size) {
  std::vector<uint8_t> f;
  append_frame_header(f, raw_size);
  append_rle_block(f, 0, kBlockBytes, false);
  const uint64_t least = (raw_size + 32767) / 32768;
  f.resize(static_cast<size_t>(std::max<uint64_t>(least, f.size() + 3)), 0xFF);
  return f;
}

}  // namespace memory_corpus_detail

/// A .rgs 1.0 file of `n` Gaussians at SH degree 0, every runtime section one zstd frame. With
/// `bogus_frames` false the file is valid (all means 0, rotations (1.059, 1.059, 1.059, 1.059), linear
/// scales 0, opacities 0, SH 0) and about n / 1000 bytes; with true, every runtime frame fails to decode
/// after its first block and the file is about n / 1000 bytes too.
inline std::vector<uint8_t> make_zstd_memory_bomb(uint64_t n, bool bogus_frames) {
  using namespace memory_corpus_detail;
  struct Section {
    format::SectionId id;
    format::Codec codec;
    format::ElementType type;
    uint32_t components;
    uint64_t elements;
    uint64_t raw_size;
    std::vector<uint8_t> stored;
  };
  std::vector<uint8_t> metadata;
  append_le(metadata, 0, 4);                   // sh_degree 0
  for (int i = 0; i < 5; ++i) metadata.push_back(1);  // colmap, wxyz, linear, sigmoid, coefficient-major
  pad_to(metadata, 56);                         // reserved, bounds all 0
  append_le(metadata, 8, 4);                    // sh_bits
  append_le(metadata, 0x42C80000u, 4);          // sh_clip_percentile 100.0f
  pad_to(metadata, format::kMetadataSize);      // SH scales 0, reserved
  std::vector<Section> sections;
  sections.push_back({format::SectionId::kMetadata, format::Codec::kNone, format::ElementType::kBytes, 1,
                      format::kMetadataSize, format::kMetadataSize, metadata});
  const struct {
    format::SectionId id;
    format::ElementType type;
    uint32_t components, element_bytes;
    uint8_t value;
  } runtime[] = {{format::SectionId::kMeans, format::ElementType::kFloat32, 3, 4, 0x00},
                 {format::SectionId::kRotations, format::ElementType::kFloat16, 4, 2, 0x3C},
                 {format::SectionId::kScales, format::ElementType::kFloat16, 3, 2, 0x00},
                 {format::SectionId::kOpacities, format::ElementType::kFloat16, 1, 2, 0x00},
                 {format::SectionId::kSh, format::ElementType::kInt8, 3, 1, 0x00}};
  for (const auto& r : runtime) {
    const uint64_t raw = n * r.components * r.element_bytes;
    sections.push_back({r.id, format::Codec::kZstd, r.type, r.components, n, raw,
                        bogus_frames ? bogus_frame(raw) : rle_frame(r.value, raw)});
  }
  const uint64_t table_end = format::kHeaderSize + format::kSectionEntrySize * sections.size();
  std::vector<uint8_t> body;  // bytes from table_end on
  std::vector<uint64_t> offsets;
  uint64_t end = table_end;
  for (const Section& s : sections) {
    const uint64_t offset = (end + 255) / 256 * 256;
    pad_to(body, static_cast<size_t>(offset - table_end));
    offsets.push_back(offset);
    body.insert(body.end(), s.stored.begin(), s.stored.end());
    end = offset + s.stored.size();
  }
  std::vector<uint8_t> table;
  for (size_t i = 0; i < sections.size(); ++i) {
    const Section& s = sections[i];
    append_le(table, static_cast<uint32_t>(s.id), 4);
    append_le(table, static_cast<uint16_t>(s.codec), 2);
    append_le(table, static_cast<uint16_t>(s.type), 2);
    append_le(table, s.components, 4);
    append_le(table, 0, 4);
    append_le(table, s.elements, 8);
    append_le(table, offsets[i], 8);
    append_le(table, s.stored.size(), 8);
    append_le(table, s.raw_size, 8);
    append_le(table, XXH64(s.stored.data(), s.stored.size(), 0), 8);
    append_le(table, 0, 8);
  }
  std::vector<uint8_t> file(format::kMagic, format::kMagic + 8);
  append_le(file, format::kFormatMajor, 2);
  append_le(file, 0, 2);  // a version 1.0 file
  append_le(file, format::kHeaderSize, 4);
  append_le(file, 0, 4);  // required flags
  append_le(file, 0, 4);  // optional flags
  append_le(file, n, 8);
  append_le(file, sections.size(), 4);
  append_le(file, 0, 4);
  append_le(file, format::kHeaderSize, 8);
  append_le(file, end, 8);  // file size
  std::vector<uint8_t> covered(file.begin(), file.end());
  covered.insert(covered.end(), table.begin(), table.end());
  append_le(file, XXH64(covered.data(), covered.size(), 0), 8);
  file.insert(file.end(), table.begin(), table.end());
  file.insert(file.end(), body.begin(), body.end());
  return file;
}

/// File names under tests/data/bad/memory/ and the Gaussian counts they declare.
inline constexpr uint64_t kRleBombGaussians = uint64_t{1} << 26;
inline constexpr uint64_t kBogusFrameGaussians = uint64_t{1} << 28;
inline const char* const kRleBombFile = "bad/memory/zstd_rle_2p26_gaussians.rgs";
inline const char* const kBogusFrameFile = "bad/memory/zstd_bogus_frames_2p28_gaussians.rgs";

}  // namespace rgs::test
