// The archive's SH transforms and the coding of its codes: the colour differences of transform 6 (SPEC §3.3.2:
// its byte layout, exactly transform 4's values, its flag and version) and the codebook of transform 5 (§3.3.3:
// round trip, determinism),
// and the must-fail files tests/data/bad/archive/*.rgs (transform 6 without its flag, in a 1.3 file, the flag
// without it, a code out of range; for the codebook a truncated frame, wrong sizes, an index or an entry code out
// of range; for codes in an .xz stream the flag and version, the check, the filters, the dictionary, the sizes,
// a check mismatch, a second stream and a truncated one). The files are made here from small archive-coded
// scenes; RGS_WRITE_BAD_ARCHIVE=1 rewrites them, otherwise the committed files are checked. Also .xz codes that
// follow SPEC §3.3.2 read back as the zstd frame's.
#include <doctest/doctest.h>
#include <lzma.h>
#include <zstd.h>

#include <array>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

#include "format_test_util.h"
#include "rgs/format/archive.h"
#include "rgs/format/reader.h"
#include "rgs/format/writer.h"

namespace {

using namespace rgs;
using namespace rgs::test;

format::WriteOptions codebook_options(uint32_t size) {
  format::WriteOptions o;
  o.profile = format::StorageProfile::kArchive;
  o.archive.sh_codebook_size = size;
  o.archive.xz = false;  // these tests read and edit the zstd frames of SPEC §3.3.2
  return o;
}

/// A random scene whose rest vectors come from `patterns` distinct vectors.
format::EncodedScene patterned_scene(uint64_t n, uint32_t degree, uint32_t patterns, uint32_t seed) {
  format::EncodedScene s = make_random_scene(n, degree, seed);
  const uint32_t values = 3 * format::sh_coefficient_count(degree), rest = values - 3;
  std::mt19937 rng(seed + 1);
  std::uniform_int_distribution<int> q8(-127, 127);
  std::vector<int8_t> table(size_t{patterns} * rest);
  for (int8_t& v : table) v = static_cast<int8_t>(q8(rng));
  for (uint64_t i = 0; i < n; ++i) {
    const uint32_t p = static_cast<uint32_t>(rng() % patterns);
    for (uint32_t j = 0; j < rest; ++j) s.sh[i * values + 3 + j] = table[size_t{p} * rest + j];
  }
  return s;
}

/// The value transform 4 decodes for runtime value q with multiplier m (SPEC §3.3.2).
int transform4(int q, uint32_t m) {
  const int mi = static_cast<int>(m);
  const int code = std::min((std::abs(q) + mi / 2) / mi, 127 / mi);
  return (q < 0 ? -code : code) * mi;
}

size_t entry_of(const std::vector<uint8_t>& b, format::SectionId id) {
  for (size_t i = 0; i < get_u32(b, 32); ++i) {
    if (get_u32(b, entry_at(i)) == static_cast<uint32_t>(id)) return i;
  }
  return SIZE_MAX;
}

/// The sh section's frame decoded, a function applied, and the frame re-coded in place of the old one
/// (the file keeps its layout: the new frame is padded to the old stored size only when it fits, which
/// the tests below ensure by editing bytes, not sizes).
struct ShFrame {
  size_t entry = 0;
  uint64_t offset = 0, stored = 0;
  size_t header = 0;  // 8 bytes, 4 multipliers, and for transform 5 the codebook size
  std::vector<uint8_t> content;
};

ShFrame read_sh_frame(const std::vector<uint8_t>& b) {
  ShFrame f;
  f.entry = entry_of(b, format::SectionId::kSh);
  f.offset = get_u64(b, entry_at(f.entry) + 24);
  f.header = b[f.offset] == 5 ? 28 : 24;
  f.stored = get_u64(b, entry_at(f.entry) + 32);
  const uint8_t* frame = b.data() + f.offset + f.header;
  const size_t frame_size = static_cast<size_t>(f.stored) - f.header;
  const unsigned long long size = ZSTD_getFrameContentSize(frame, frame_size);
  f.content.resize(static_cast<size_t>(size));
  const size_t got = ZSTD_decompress(f.content.data(), f.content.size(), frame, frame_size);
  REQUIRE(got == f.content.size());
  return f;
}

/// Rebuilds the file with `codes` in place of the sh section's codes: the section grows or shrinks, so the file
/// is the prefix up to the section, the new section, and the sections after it are not allowed (sh is the last
/// one).
std::vector<uint8_t> replace_sh_codes(const std::vector<uint8_t>& b, const ShFrame& f,
                                      const std::vector<uint8_t>& codes) {
  REQUIRE(f.offset + f.stored == b.size());  // sh is the last section
  std::vector<uint8_t> out(b.begin(), b.begin() + static_cast<ptrdiff_t>(f.offset + f.header));
  out.insert(out.end(), codes.begin(), codes.end());
  put_u64(out, entry_at(f.entry) + 32, f.header + codes.size());
  put_u64(out, 48, out.size());  // header file_size
  fix_all_checksums(out);
  return out;
}
/// The file with the sh frame re-coded (replace_sh_codes).
std::vector<uint8_t> write_sh_frame(const std::vector<uint8_t>& b, const ShFrame& f) {
  std::vector<uint8_t> frame(ZSTD_compressBound(f.content.size()));
  ZSTD_CCtx* cctx = ZSTD_createCCtx();
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_checksumFlag, 1);
  ZSTD_CCtx_setParameter(cctx, ZSTD_c_contentSizeFlag, 1);
  const size_t n = ZSTD_compress2(cctx, frame.data(), frame.size(), f.content.data(), f.content.size());
  ZSTD_freeCCtx(cctx);
  REQUIRE(!ZSTD_isError(n));
  frame.resize(n);
  return replace_sh_codes(b, f, frame);
}
/// How write_sh_xz codes the sh codes: the check, the dictionary, a delta filter before LZMA2.
struct XzCoding {
  lzma_check check = LZMA_CHECK_CRC32;
  uint32_t dictionary = uint32_t{1} << 20;
  bool delta = false;
};
/// The codes as one .xz stream (liblzma's one-block buffer encoder).
std::vector<uint8_t> xz_stream(const std::vector<uint8_t>& content, const XzCoding& coding) {
  lzma_options_lzma lzma;
  REQUIRE(!lzma_lzma_preset(&lzma, 1));
  lzma.dict_size = coding.dictionary;
  lzma_options_delta delta{};
  delta.type = LZMA_DELTA_TYPE_BYTE;
  delta.dist = 1;
  lzma_filter filters[3] = {{LZMA_FILTER_DELTA, &delta}, {LZMA_FILTER_LZMA2, &lzma}, {LZMA_VLI_UNKNOWN, nullptr}};
  std::vector<uint8_t> stream(lzma_stream_buffer_bound(content.size()));
  size_t pos = 0;
  REQUIRE(lzma_stream_buffer_encode(coding.delta ? filters : filters + 1, coding.check, nullptr, content.data(),
                                    content.size(), stream.data(), &pos, stream.size()) == LZMA_OK);
  stream.resize(pos);
  return stream;
}
/// The file with `stream` as the sh section's codes, the .xz flag set and stamped 1.5 (SPEC §2.2, §3.3.2).
std::vector<uint8_t> write_sh_xz(const std::vector<uint8_t>& b, const ShFrame& f, const std::vector<uint8_t>& stream) {
  std::vector<uint8_t> out = replace_sh_codes(b, f, stream);
  put_u32(out, 16, get_u32(out, 16) | format::kRequiredFlagXzCodes);
  put_u16(out, 10, 5);
  fix_header_checksum(out);
  return out;
}

std::vector<uint8_t> good_codebook_file() {
  const format::EncodedScene scene = patterned_scene(600, 1, 40, 5);
  auto bytes = format::serialize_scene(scene, codebook_options(64));
  REQUIRE(bytes.ok());
  return *bytes;
}

/// A 300-Gaussian, SH degree 1 archive with the default SH transform, 6 (under the fuzzers' 16 KiB inputs).
std::vector<uint8_t> good_colour_file() {
  auto bytes = format::serialize_scene(make_random_scene(300, 1, 5), codebook_options(0));
  REQUIRE(bytes.ok());
  return *bytes;
}

struct BadArchive {
  const char* name;
  StatusCode code;
  const char* fragment;
};

const BadArchive kBadArchives[] = {
    {"colour_without_flag", StatusCode::kCorruptData, "transform 6 (colour differences) without its required flag"},
    {"colour_in_1_3", StatusCode::kCorruptData, "transform 6 (colour differences) in a version 1.3 file"},
    {"colour_flag_without_transform", StatusCode::kCorruptData,
     "the SH colour-differences flag is set but the sh section does not use transform 6"},
    {"colour_code_out_of_range", StatusCode::kCorruptData, "Gaussian 3: code 128 of component 0 is out of range"},
    {"codebook_index_out_of_range", StatusCode::kCorruptData, "SH codebook index"},
    {"codebook_entry_out_of_range", StatusCode::kCorruptData, "SH codebook entry 0: code -128"},
    {"codebook_size_over_n", StatusCode::kCorruptData, "SH codebook of"},
    {"codebook_wrong_content_size", StatusCode::kCorruptData, "codes"},
    {"codebook_truncated_frame", StatusCode::kCorruptData, "sh"},
    {"xz_without_flag", StatusCode::kCorruptData, "codes in an .xz stream without their required flag"},
    {"xz_in_1_4", StatusCode::kCorruptData, "codes in an .xz stream in a version 1.4 file"},
    {"xz_flag_without_codes", StatusCode::kCorruptData,
     "the .xz codes flag is set but no quantized section stores .xz codes"},
    {"xz_check_none", StatusCode::kCorruptData, "SPEC 3.3.2 requires CRC32, CRC64 or SHA-256"},
    {"xz_delta_filter", StatusCode::kCorruptData, "SPEC 3.3.2 allows the LZMA2 filter alone"},
    {"xz_large_dictionary", StatusCode::kCorruptData, "LZMA2 dictionary of 67108864 bytes"},
    {"xz_wrong_size", StatusCode::kCorruptData, ".xz stream decodes to"},
    {"xz_check_mismatch", StatusCode::kCorruptData, "damaged data or check mismatch"},
    {"xz_two_streams", StatusCode::kCorruptData, "(SPEC 3.3.2: one stream, no padding)"},
    {"xz_truncated", StatusCode::kCorruptData, ".xz stream footer is damaged"},
};

std::vector<uint8_t> make_bad_archive(const std::string& name) {
  if (name.rfind("xz_", 0) == 0) {
    std::vector<uint8_t> b = good_colour_file();
    ShFrame f = read_sh_frame(b);
    if (name == "xz_flag_without_codes") {
      put_u32(b, 16, get_u32(b, 16) | format::kRequiredFlagXzCodes);
      put_u16(b, 10, 5);
      fix_header_checksum(b);
      return b;
    }
    XzCoding coding;
    if (name == "xz_check_none") coding.check = LZMA_CHECK_NONE;
    if (name == "xz_delta_filter") coding.delta = true;
    if (name == "xz_large_dictionary") coding.dictionary = uint32_t{64} << 20;
    if (name == "xz_wrong_size") f.content.push_back(0);
    std::vector<uint8_t> stream = xz_stream(f.content, coding);
    // The footer's backward size gives where the index starts; the block's CRC32 ends just before it.
    const uint64_t index_end = stream.size() - 12;
    const uint64_t index = index_end - (uint64_t{get_u32(stream, index_end + 4)} + 1) * 4;
    if (name == "xz_check_mismatch") stream[index - 1] ^= 0x40;
    if (name == "xz_two_streams") stream.insert(stream.end(), stream.begin(), stream.end());
    if (name == "xz_truncated") stream.resize(stream.size() / 2);
    std::vector<uint8_t> out = write_sh_xz(b, f, stream);
    if (name == "xz_without_flag") put_u32(out, 16, get_u32(out, 16) & ~format::kRequiredFlagXzCodes);
    if (name == "xz_in_1_4") put_u16(out, 10, 4);
    fix_header_checksum(out);
    return out;
  }
  if (name.rfind("colour_", 0) == 0) {
    std::vector<uint8_t> b = name == "colour_flag_without_transform" ? good_codebook_file() : good_colour_file();
    if (name == "colour_without_flag") {
      put_u32(b, 16, get_u32(b, 16) & ~format::kRequiredFlagShColourDifferences);
    } else if (name == "colour_in_1_3") {
      put_u16(b, 10, 3);
    } else if (name == "colour_flag_without_transform") {
      put_u32(b, 16, get_u32(b, 16) | format::kRequiredFlagShColourDifferences);
    } else if (name == "colour_code_out_of_range") {
      // Gaussian 3's DC: G = 0 and R - G = 0x80, so R = -128, outside [-127, 127] at multiplier 1.
      ShFrame f = read_sh_frame(b);
      const size_t n = get_u64(b, entry_at(f.entry) + 16);
      f.content[3] = 0x80;
      f.content[n + 3] = 0;
      return write_sh_frame(b, f);
    }
    fix_header_checksum(b);
    return b;
  }
  std::vector<uint8_t> b = good_codebook_file();
  ShFrame f = read_sh_frame(b);
  const uint32_t k = get_u32(b, f.offset + 24);
  const uint32_t values = get_u32(b, f.offset + 4), rest = values - 3;
  const size_t n = (f.content.size() - size_t{k} * rest) / 4;  // 3 DC codes + a 1-byte index each
  if (name == "codebook_index_out_of_range") {
    f.content[size_t{k} * rest + 3 * n + 17] = static_cast<uint8_t>(k);  // Gaussian 17 names entry K
    return write_sh_frame(b, f);
  }
  if (name == "codebook_entry_out_of_range") {
    f.content[5] = 0x80;
    return write_sh_frame(b, f);
  }
  if (name == "codebook_size_over_n") {
    put_u32(b, f.offset + 24, static_cast<uint32_t>(n + 1));
  } else if (name == "codebook_wrong_content_size") {
    put_u32(b, f.offset + 24, k - 1);  // the frame holds K entries, the header now claims K - 1
  } else if (name == "codebook_truncated_frame") {
    // The section (the last one) and the file end in the middle of the frame.
    const uint64_t keep = f.header + (f.stored - f.header) / 2;
    b.resize(static_cast<size_t>(f.offset + keep));
    put_u64(b, entry_at(f.entry) + 32, keep);
    put_u64(b, 48, b.size());
  }
  fix_all_checksums(b);
  return b;
}

std::string bad_archive_path(const std::string& name) { return data_path("bad/archive/" + name + ".rgs"); }

}  // namespace

TEST_CASE("archive SH colour differences: the bytes of SPEC 3.3.2 transform 6, decoding exactly transform 4's values") {
  for (uint32_t degree = 0; degree <= 3; ++degree) {
    for (const std::array<uint32_t, 4> multipliers :
         {std::array<uint32_t, 4>{1, 1, 1, 1}, {1, 3, 5, 6}, {4, 9, 30, 127}}) {
      CAPTURE(degree);
      CAPTURE(multipliers[0]);
      format::EncodedScene scene = make_random_scene(3000, degree, 17 + degree);
      const uint32_t values = 3 * format::sh_coefficient_count(degree);
      // The ends of the code range next to each other, so that R - G and B - G wrap modulo 256.
      for (uint64_t i = 0; i < 300; ++i) {
        for (uint32_t c = 0; c < values; ++c) scene.sh[i * values + c] = static_cast<int8_t>((i + c) % 2 ? 127 : -127);
      }
      format::WriteOptions write = codebook_options(0);
      write.archive.sh_step_multipliers = multipliers;
      auto archive = format::encode_archive(scene, write.archive);
      REQUIRE(archive.ok());
      const format::EncodedScene& d = archive->decoded;
      // The stored bytes, built here from SPEC's text: transform 4's codes, each triple as (R - G, G, B - G)
      // modulo 256, the DC triples as three planes of N, then N records of the rest triples.
      std::vector<uint8_t> want(d.count * values);
      for (uint64_t i = 0; i < d.count; ++i) {
        const uint64_t s = archive->source_index[i];
        for (uint32_t c = 0; c < values; c += 3) {
          int code[3];
          for (uint32_t k = 0; k < 3; ++k) {
            const uint32_t m = multipliers[format::sh_degree_of_coefficient(c / 3)];
            const int value = transform4(scene.sh[s * values + c + k], m);
            REQUIRE(d.sh[i * values + c + k] == value);
            code[k] = value / static_cast<int>(m);
          }
          const uint8_t triple[3] = {static_cast<uint8_t>(code[0] - code[1]), static_cast<uint8_t>(code[1]),
                                     static_cast<uint8_t>(code[2] - code[1])};
          for (uint32_t k = 0; k < 3; ++k) {
            (c == 0 ? want[k * d.count + i] : want[3 * d.count + i * (values - 3) + c - 3 + k]) = triple[k];
          }
        }
      }
      const std::vector<uint8_t>& sh = archive->stored[4];
      REQUIRE(sh.size() > 24);
      CHECK(sh[0] == 6);
      CHECK(sh[1] == 8);
      std::vector<uint8_t> content(want.size());
      REQUIRE(ZSTD_decompress(content.data(), content.size(), sh.data() + 24, sh.size() - 24) == want.size());
      CHECK(content == want);
      // The file: transform 6 sets its required flag and version 1.4, and reads back as encode_archive decoded it.
      auto bytes = format::serialize_scene(scene, write);
      REQUIRE(bytes.ok());
      REQUIRE(format::validate(bytes->data(), bytes->size()).ok());
      auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
      REQUIRE(file.ok());
      CHECK((file->header().required_flags & format::kRequiredFlagShColourDifferences) != 0);
      CHECK(file->header().minor == 4);
      auto read = file->read_scene();
      REQUIRE(read.ok());
      check_same_scene(*read, d);
    }
  }
}

TEST_CASE("archive codebook: exact when the codebook holds every rest vector, file decodes to encode_archive") {
  const format::EncodedScene scene = patterned_scene(4000, 3, 50, 9);
  format::ArchiveOptions options;
  options.sh_codebook_size = 64;
  auto archive = format::encode_archive(scene, options);
  REQUIRE(archive.ok());
  auto bytes = format::serialize_scene(scene, codebook_options(64));
  REQUIRE(bytes.ok());
  CHECK(format::validate(bytes->data(), bytes->size()).ok());
  auto file = format::RgsFile::from_bytes(bytes->data(), bytes->size());
  REQUIRE(file.ok());
  auto read = file->read_scene();
  REQUIRE(read.ok());
  check_same_scene(*read, archive->decoded);
  const format::EncodedScene& d = archive->decoded;
  const uint32_t values = 48;
  for (uint64_t i = 0; i < d.count; ++i) {
    const uint64_t s = archive->source_index[i];
    for (uint32_t c = 0; c < values; ++c) {
      const int want = scene.sh[s * values + c], got = d.sh[i * values + c];
      // 50 patterns, 64 entries: every leaf holds one vector, so every value is transform 4's.
      REQUIRE(got == transform4(want, archive->options.sh_step_multipliers[format::sh_degree_of_coefficient(c / 3)]));
    }
  }
}

TEST_CASE("archive codebook: the default codes repeated records once, decoding exactly transform 4's values") {
  const format::EncodedScene scene = patterned_scene(5000, 2, 300, 13);
  const format::ArchiveOptions options;  // sh_codebook_size 0: distinct records when they repeat
  auto archive = format::encode_archive(scene, options);
  REQUIRE(archive.ok());
  const std::vector<uint8_t>& sh = archive->stored[4];
  REQUIRE(sh.size() > 28);
  CHECK(sh[0] == 5);                    // transform 5
  CHECK(get_u32(sh, 24) == 300);        // one entry per distinct record
  CHECK(sh[1] == 9);                    // 9 index bits
  const uint32_t values = 27;
  for (uint64_t i = 0; i < archive->decoded.count; ++i) {
    const uint64_t s = archive->source_index[i];
    for (uint32_t c = 0; c < values; ++c) {
      const uint32_t m = archive->options.sh_step_multipliers[format::sh_degree_of_coefficient(c / 3)];
      REQUIRE(archive->decoded.sh[i * values + c] == transform4(scene.sh[s * values + c], m));
    }
  }
  auto bytes = format::serialize_scene(scene, codebook_options(0));
  REQUIRE(bytes.ok());
  CHECK(format::validate(bytes->data(), bytes->size()).ok());
  // Records that do not repeat take the colour differences of transform 6.
  auto plain = format::encode_archive(make_random_scene(2000, 2, 4), options);
  REQUIRE(plain.ok());
  CHECK(plain->stored[4][0] == 6);
}

TEST_CASE("archive codebook: bounded error with fewer entries than vectors, deterministic whatever the threads") {
  format::EncodedScene scene = make_random_scene(3000, 2, 21);
  // Equal sizes and opacities: equal importance, so the leaf means are plain means.
  for (uint16_t& v : scene.scales) v = scene.scales[0];
  for (uint16_t& v : scene.opacities) v = scene.opacities[0];
  format::WriteOptions one = codebook_options(256), three = codebook_options(256);
  one.archive.threads = 1;
  three.archive.threads = 3;
  auto a = format::serialize_scene(scene, one), b = format::serialize_scene(scene, three);
  REQUIRE(a.ok());
  REQUIRE(b.ok());
  CHECK(*a == *b);
  CHECK(format::validate(a->data(), a->size()).ok());
  auto archive = format::encode_archive(scene, one.archive);
  REQUIRE(archive.ok());
  // Each entry is the mean of its leaf, so the total squared error is below the data's own variance.
  const uint32_t values = 27;
  double err = 0, var = 0, mean[27] = {};
  for (uint64_t i = 0; i < scene.count; ++i) {
    for (uint32_t c = 3; c < values; ++c) mean[c] += scene.sh[i * values + c] / 3000.0;
  }
  for (uint64_t i = 0; i < archive->decoded.count; ++i) {
    const uint64_t s = archive->source_index[i];
    for (uint32_t c = 3; c < values; ++c) {
      const double e = archive->decoded.sh[i * values + c] - scene.sh[s * values + c];
      const double v = scene.sh[s * values + c] - mean[c];
      err += e * e;
      var += v * v;
    }
  }
  CHECK(err < 0.8 * var);
}

TEST_CASE("archive codebook: options out of range are refused") {
  const format::EncodedScene scene = make_random_scene(100, 1, 2);
  for (uint32_t size : {1u, 65537u}) {
    auto r = format::encode_archive(scene, codebook_options(size).archive);
    CHECK(r.status().code() == StatusCode::kInvalidArgument);
  }
  // Degree 0 has no rest coefficients: the codebook option falls back to transform 4.
  const format::EncodedScene dc_only = make_random_scene(100, 0, 2);
  auto bytes = format::serialize_scene(dc_only, codebook_options(16));
  REQUIRE(bytes.ok());
  CHECK(format::validate(bytes->data(), bytes->size()).ok());
}

TEST_CASE("archive .xz codes: a stream as SPEC 3.3.2 allows reads back as the zstd frame's codes") {
  const std::vector<uint8_t> b = good_colour_file();
  const ShFrame f = read_sh_frame(b);
  auto zstd = format::RgsFile::from_bytes(b.data(), b.size());
  REQUIRE(zstd.ok());
  auto want = zstd->read_scene();
  REQUIRE(want.ok());
  for (lzma_check check : {LZMA_CHECK_CRC32, LZMA_CHECK_CRC64, LZMA_CHECK_SHA256}) {
    // Dictionaries up to 1 MiB, which SPEC §3.3.2 allows for any codes (at most max(1 MiB, twice their size)).
    for (uint32_t dictionary : {uint32_t{4} << 10, uint32_t{1} << 20}) {
      CAPTURE(static_cast<int>(check));
      CAPTURE(dictionary);
      XzCoding coding;
      coding.check = check;
      coding.dictionary = dictionary;
      const std::vector<uint8_t> x = write_sh_xz(b, f, xz_stream(f.content, coding));
      REQUIRE(format::validate(x.data(), x.size()).ok());
      auto file = format::RgsFile::from_bytes(x.data(), x.size());
      REQUIRE(file.ok());
      CHECK(file->header().minor == 5);
      auto read = file->read_scene();
      REQUIRE(read.ok());
      check_same_scene(*read, *want);
    }
  }
}

TEST_CASE("archive SH transforms: must-fail files tests/data/bad/archive/") {
  const bool write = std::getenv("RGS_WRITE_BAD_ARCHIVE") != nullptr;
  for (const BadArchive& bad : kBadArchives) {
    const std::string name = bad.name;
    CAPTURE(name);
    const std::vector<uint8_t> made = make_bad_archive(bad.name);
    const Status made_status = format::validate(made.data(), made.size());
    CHECK(made_status.code() == bad.code);
    CHECK(made_status.message().find(bad.fragment) != std::string::npos);
    const std::string path = bad_archive_path(bad.name);
    if (write) {
      std::ofstream(path, std::ios::binary).write(reinterpret_cast<const char*>(made.data()),
                                                  static_cast<std::streamsize>(made.size()));
    }
    std::ifstream in(path, std::ios::binary);
    const std::string missing = path + " is missing: run the format tests with RGS_WRITE_BAD_ARCHIVE=1";
    REQUIRE_MESSAGE(in.good(), missing);
    const std::vector<uint8_t> committed((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const Status s = format::validate(committed.data(), committed.size());
    CHECK(s.code() == bad.code);
    CHECK(s.message().find(bad.fragment) != std::string::npos);
    // The reader refuses it too, before or while decoding the scene.
    auto file = format::RgsFile::from_bytes(committed.data(), committed.size());
    if (file.ok()) CHECK(!file->read_scene().ok());
  }
}
